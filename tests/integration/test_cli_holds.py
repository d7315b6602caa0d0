"""``aeroid estimate --hold NAME=VALUE --prior NAME=MEAN:SD`` (issue 25): end to end."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from aeroid.cli import main
from aeroid.model._coefficients import NAMES, nominal


@pytest.fixture(scope="module")
def flight_csv(tmp_path_factory, paper_flight) -> Path:
    path = tmp_path_factory.mktemp("cli_holds") / "flight.csv"
    prior = tuple(paper_flight.airframe.prior_vector())
    dataclasses.replace(paper_flight, airframe=paper_flight.airframe.replace(prior=prior)
                        ).write(path)
    return path


def test_hold_and_prior_reach_the_fit_and_the_json(flight_csv, capsys):
    czd = float(nominal()[NAMES.index("Czd")])
    code = main(["estimate", str(flight_csv), "--method", "equation-error", "--json",
                 "--hold", f"Czd={czd!r}", "--prior", "Cmq=-2000:300"])
    out = json.loads(capsys.readouterr().out)
    assert code in (0, 1)
    assert out["held"] == {"Czd": czd}
    assert out["priors"] == {"Cmq": {"mean": -2000.0, "sd": 300.0}}
    assert out["coefficients"]["Czd"] == czd
    assert out["stderr"]["Czd"] is None  # held: no standard error
    assert np.isfinite(out["stderr"]["Cmq"])


def test_table_says_held(flight_csv, capsys):
    main(["estimate", str(flight_csv), "--method", "equation-error", "--quiet",
          "--hold", "Czd=-1.27"])
    rows = [line.split() for line in capsys.readouterr().out.splitlines()]
    czd = next(r for r in rows if r and r[0] == "Czd")
    assert czd[2] == "held"


@pytest.mark.parametrize(("args", "words"), [
    (["--hold", "Cq=0"], "unknown coefficient 'Cq'"),
    (["--hold", "Czd"], "expected NAME=VALUE"),
    (["--prior", "Cmq=-1500:0"], "sd must be > 0"),
    (["--prior", "Cmq=-1500"], "expected NAME=MEAN:SD"),
    (["--hold", "Cmq=1", "--prior", "Cmq=1:2"], "already held"),
])
def test_bad_holds_are_one_line_errors(flight_csv, capsys, args, words):
    code = main(["estimate", str(flight_csv), "--method", "equation-error", *args])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert words in err and len(err.splitlines()) == 1
