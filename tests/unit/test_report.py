"""The fit report: its files, what each figure names, the markdown, atomic writes."""

from __future__ import annotations

import dataclasses
from html.parser import HTMLParser

import numpy as np
import pytest

from aeroid.errors import UsageError
from aeroid.estimation import EstimationResult, failed_result, make_estimator
from aeroid.flights import UNITS
from aeroid.model import NAMES, OUTPUT_CHANNELS
from aeroid.report import (
    REPORT_NAME,
    autocorrelation,
    report_figures,
    write_report,
    write_text_atomic,
)

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def oe_result(paper_flight) -> EstimationResult:
    result = make_estimator("output-error", {}).fit(paper_flight, rng=0)
    assert result.success, result.message
    return result


def test_every_figure_names_its_channel_and_unit(oe_result, paper_flight) -> None:
    figures = report_figures(oe_result, paper_flight)
    assert set(figures) == {*OUTPUT_CHANNELS, "autocorrelation", "deflection", "correlation"}
    for name in OUTPUT_CHANNELS:
        labels = [ax.get_ylabel() for ax in figures[name].axes]
        assert labels == [f"{name} [{UNITS[name]}]", f"{name} residual [{UNITS[name]}]"]
        assert figures[name].axes[1].get_xlabel() == "t [s]"
        # the model line is the prediction, the measured points the log
        top = figures[name].axes[0]
        measured, model = (line.get_ydata() for line in top.get_lines())
        np.testing.assert_array_equal(measured, paper_flight[name])
        np.testing.assert_array_equal(model, oe_result.predict(paper_flight)[name])
    titles = [ax.get_title() for ax in figures["autocorrelation"].axes if ax.get_visible()]
    assert titles == [f"{name} residual" for name in OUTPUT_CHANNELS]
    assert figures["deflection"].axes[0].get_ylabel() == "delta [deg]"
    assert [t.get_text() for t in figures["correlation"].axes[0].get_xticklabels()] \
        == list(NAMES)


def test_report_files_exist_and_the_markdown_links_them(oe_result, paper_flight,
                                                        tmp_path) -> None:
    check = dict(oe_result.info["fit_check"])
    check["whiteness"] = {name: 0.5 for name in OUTPUT_CHANNELS}  # keys added later
    check["portmanteau"] = {name: {"q": 1.5, "p_value": 0.2} for name in OUTPUT_CHANNELS}
    check["white"] = True
    result = dataclasses.replace(oe_result, info={**oe_result.info, "fit_check": check},
                                 warnings=("a warning about | pipes",))
    path = write_report(result, paper_flight, tmp_path / "fit", notes=["reading: a note"])
    assert path == tmp_path / "fit" / REPORT_NAME
    text = path.read_text()
    for stem in (*OUTPUT_CHANNELS, "autocorrelation", "deflection", "correlation"):
        png = tmp_path / "fit" / f"{stem}.png"
        assert png.read_bytes()[:8] == PNG, stem
        assert f"]({stem}.png)" in text
    for name in OUTPUT_CHANNELS:
        assert f"![{name} [{UNITS[name]}]: measured, model in still air and residual]" \
            f"({name}.png)" in text  # the caption says the air (issue 26)
    assert not list((tmp_path / "fit").glob("*.tmp"))
    # the coefficient table: estimate, standard error, prior, floor, truth
    assert "| coefficient | estimate | std err | prior (start) | Cramér-Rao floor | truth |" \
        in text
    for name, value in zip(NAMES, result.theta, strict=True):
        assert f"| {name} | {value:.6g} |" in text
    # the fit check, every key (the new one too), and every warning and note
    (header,) = [line for line in text.splitlines() if line.startswith("| channel |")]
    columns = [c.strip() for c in header.strip("|").split("|")]
    assert columns[:4] == ["channel", "residual_rms", "noise_sd", "ratio"]
    assert {"whiteness", "portmanteau.q", "portmanteau.p_value"} <= set(columns)
    (row,) = [line for line in text.splitlines() if line.startswith("| q | ")]
    cells = dict(zip(columns, (c.strip() for c in row.strip("|").split("|")), strict=True))
    assert (cells["whiteness"], cells["portmanteau.q"], cells["portmanteau.p_value"]) \
        == ("0.5", "1.5", "0.2")
    assert "- white: true" in text
    assert "- worst: " in text and "- limit: 3" in text
    assert "- warning: a warning about \\| pipes" in text and "- reading: a note" in text


def test_a_failed_result_gets_a_report_without_model_figures(paper_flight, tmp_path) -> None:
    result = failed_result("ekf", "filter diverged")
    path = write_report(result, paper_flight, tmp_path)
    text = path.read_text()
    assert "**FAILED**: filter diverged" in text and ".png" not in text
    assert sorted(p.name for p in tmp_path.iterdir()) == [REPORT_NAME]


def test_an_unwritable_folder_is_one_line(oe_result, paper_flight, tmp_path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(UsageError) as info:
        write_report(oe_result, paper_flight, blocker / "sub")
    assert str(blocker / "sub") in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(UsageError):
        write_text_atomic(tmp_path / "missing" / "report.md", "x")
    assert not list(tmp_path.glob("**/*.tmp"))


def test_autocorrelation_matches_its_definition() -> None:
    rng = np.random.default_rng(3)
    x = rng.standard_normal(400) + 2.0
    centred = x - x.mean()
    direct = [np.sum(centred[:x.size - k] * centred[k:]) / np.sum(centred**2)
              for k in range(11)]
    np.testing.assert_allclose(autocorrelation(x, 10), direct, rtol=1e-12)
    # an AR(1) residual: lag-1 autocorrelation near its coefficient
    ar = np.zeros(20_000)
    e = rng.standard_normal(ar.size)
    for k in range(1, ar.size):
        ar[k] = 0.8 * ar[k - 1] + e[k]
    assert autocorrelation(ar, 1)[1] == pytest.approx(0.8, abs=0.02)


class _Page(HTMLParser):
    """Collects what an HTML report shows: image sources and alt texts, table cells, text."""

    def __init__(self) -> None:
        super().__init__()
        self.images: dict[str, str] = {}
        self.cells: list[str] = []
        self.text: list[str] = []
        self.open: list[str] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        if tag not in ("img", "meta", "br", "hr"):
            self.open.append(tag)
        attrs = dict(attrs)
        if tag == "img":
            self.images[attrs["src"]] = attrs.get("alt", "")
        if tag in ("td", "th"):
            self._cell = []

    def handle_startendtag(self, tag, attrs):  # <img ... />: nothing to close
        self.handle_starttag(tag, attrs)

    def handle_endtag(self, tag):
        assert self.open and self.open[-1] == tag, f"</{tag}> closes {self.open[-1:]}"
        self.open.pop()
        if tag in ("td", "th") and self._cell is not None:
            self.cells.append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)


def test_the_html_report_has_the_markdown_report_content(oe_result, paper_flight,
                                                         tmp_path) -> None:
    result = dataclasses.replace(oe_result, warnings=("a warning about | pipes <b>x</b>",))
    md = write_report(result, paper_flight, tmp_path / "md")
    page = write_report(result, paper_flight, tmp_path / "html", fmt="html")
    assert page == tmp_path / "html" / "report.html"
    parser = _Page()
    parser.feed(page.read_text())
    parser.close()
    assert parser.open == []  # every element closed: the page parses
    # every PNG written is shown, under the caption naming its channel and unit
    pngs = sorted(p.name for p in (tmp_path / "html").glob("*.png"))
    assert sorted(parser.images) == pngs and len(pngs) == len(OUTPUT_CHANNELS) + 3
    for name in OUTPUT_CHANNELS:
        assert parser.images[f"{name}.png"] == \
            f"{name} [{UNITS[name]}]: measured, model in still air and residual"
    # the same tables: every markdown table cell is a cell of the page
    md_cells = [c.strip().replace("\\|", "|") for line in md.read_text().splitlines()
                if line.startswith("| ") for c in line.strip().strip("|").split(" | ")]
    assert parser.cells == md_cells
    text = "".join(parser.text)
    assert "warning: a warning about | pipes <b>x</b>" in text  # shown, not interpreted
    for name, value in zip(NAMES, result.theta, strict=True):
        assert name in parser.cells and f"{value:.6g}" in parser.cells


def test_an_unknown_report_format_is_one_line(oe_result, paper_flight, tmp_path) -> None:
    with pytest.raises(UsageError, match="report format must be one of md, html, got 'pdf'"):
        write_report(oe_result, paper_flight, tmp_path, fmt="pdf")
    assert not list(tmp_path.iterdir())
