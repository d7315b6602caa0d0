"""Summarise a (possibly partial) run of studies/rocket_measure.toml for issue 25's measure.

Reads the study's ``results.jsonl`` and prints, over its finished runs: the successes and
why the others failed; per Cx table point (and Cl0, Clp and the pitch-plane terms) how
many successful fits are within 3 se and the coverage of the 95 % interval (|error| <=
1.96 se) with its exact binomial 95 % interval (scipy's ``binomtest``), pooled over the
Cx points too; the fin terms held; the drawn masses; and, from each record's consider
fields, the method's own se, the mass share and the consider re-fits that failed. It
then writes the study's own report (``report.md``, ``results.csv``) for those runs.

    python benchmarks/rocket_measure_summary.py OUT_DIR [--study studies/rocket_measure.toml]
"""

from __future__ import annotations

import argparse
import collections
from pathlib import Path

import numpy as np
from scipy.stats import binomtest
from scipy.stats import chi2 as chi2_dist

from aeroid.study import load_study
from aeroid.study._report import write_report
from aeroid.study._store import read_results

Z_COVER, Z_WITHIN = 1.96, 3.0

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("out_dir", type=Path)
parser.add_argument("--study", default="studies/rocket_measure.toml")
args = parser.parse_args()
records = sorted(read_results(args.out_dir / "results.jsonl"), key=lambda r: r["run"])
study = load_study(args.study).with_runs(max(r["run"] for r in records) + 1)
ok = [r for r in records if r["success"]]
k = binomtest(len(ok), len(records)).proportion_ci(0.95, method="exact")
print(f"runs {len(records)} (0-{records[-1]['run']}); success {len(ok)} of {len(records)} "
      f"(exact 95 % {k.low:.2f}-{k.high:.2f})")
for message, n in collections.Counter(r["message"][:110] for r in records
                                      if not r["success"]).items():
    print(f"  failed x{n}: {message}")
for r in records:
    if not r["success"]:
        print(f"  run {r['run']}: mass scale {r.get('mass_scale', float('nan')):.4f}: "
              f"{r['message'][:110]}")
drawn = np.array([r["mass_scale"] for r in records if "mass_scale" in r])
if drawn.size:
    rel_sd = study.scenario.airframe.mass_sd_kg / study.scenario.airframe.mass_kg
    chi2 = (drawn.size - 1) * drawn.var(ddof=1) / rel_sd**2
    print(f"drawn mass scale: mean {drawn.mean():.4f}, sd {drawn.std(ddof=1):.4f} (stated "
          f"{rel_sd:g}; chi-square lower tail p {chi2_dist.cdf(chi2, drawn.size - 1):.3g}), "
          f"range {drawn.min():.4f}-{drawn.max():.4f}, beyond 1.96 sd "
          f"{int(np.sum(np.abs(drawn - 1.0) > 1.96 * rel_sd))} of {drawn.size}")


def cover_line(label, z):
    z = np.asarray(z, dtype=float)
    n, c = z.size, int(np.sum(z <= Z_COVER))
    ci = binomtest(c, n).proportion_ci(0.95, method="exact") if n else None
    inside = int(np.sum(z <= Z_WITHIN))
    return (f"  {label:10s} within 3 se {inside} of {n}; coverage {c}/{n} "
            f"({c / n:.2f}, exact 95 % {ci.low:.2f}-{ci.high:.2f}); median |err|/se "
            f"{np.median(z):.2f}, largest {z.max():.2f}" if n else f"  {label}: none")


names = ok[0]["names"] if ok else []
print("over the successful fits, |error| / total se (the mass share included):")
pooled = []
for j, name in enumerate(names):
    se = np.array([r["stderr"][j] for r in ok], dtype=float)
    if np.all(se == 0):
        print(f"  {name:10s} held at {ok[0]['theta'][j]:g} in {len(ok)} of {len(ok)}")
        continue
    z = np.array([abs(r["theta"][j] - r["truth"][j]) for r in ok]) / se
    pooled += list(z) if name.startswith("Cx@") else []
    print(cover_line(name, z))
if pooled:
    print(cover_line("Cx pooled", pooled))
with_consider = [r for r in ok if r.get("consider")]
if with_consider:
    bad = [r["run"] for r in with_consider if r["consider"]["refit_messages"]]
    print(f"consider re-fits: {len(bad)} of {len(with_consider)} successful fits had an "
          f"unsuccessful re-fit (runs {bad})")
    for r in with_consider:
        if r["consider"]["refit_messages"]:
            print(f"  run {r['run']}: {r['consider']['refit_messages'][0][:150]}")
    print("median se: own, mass share, total (successful fits)")
    for j, name in enumerate(names):
        own_j = np.array([r["consider"]["stderr_without"][j] for r in with_consider],
                         dtype=float)
        if not np.any(np.isfinite(own_j)):  # held: no se of its own
            continue
        own = np.nanmedian(own_j)
        share = np.nanmedian(np.array([r["consider"]["stderr_share"][j]
                                       for r in with_consider], dtype=float))
        total = np.median([r["stderr"][j] for r in with_consider])
        print(f"  {name:10s} {own:10.3g} {share:10.3g} {total:10.3g}")
if with_consider:  # the mass share a coast implies (F = m a), against the re-fits' share
    rel = study.scenario.airframe.mass_sd_kg / study.scenario.airframe.mass_kg
    print(f"offline check, not the toolkit's output: se = sqrt(own^2 + (theta x {rel:g})^2) "
          "for the force coefficients (a coast's estimate scales with the mass: the consider "
          "share a converged re-fit pair gives), own se for the moments")
    clean = [r for r in with_consider if not r["consider"]["refit_messages"]]
    for label, group in (("all successful", with_consider), ("re-fits converged", clean)):
        print(f" {label} ({len(group)} fits):")
        pooled = []
        for j, name in enumerate(names):
            own = np.array([r["consider"]["stderr_without"][j] for r in group], dtype=float)
            if not group or not np.all(own > 0):  # held (no se): not scored
                continue
            theta = np.array([r["theta"][j] for r in group])
            force = name.startswith(("Cx", "Cz"))
            se = np.hypot(own, theta * rel) if force else own
            z = np.abs(theta - np.array([r["truth"][j] for r in group])) / se
            pooled += list(z) if name.startswith("Cx@") else []
            print(cover_line(name, z))
        if pooled:
            print(cover_line("Cx pooled", pooled))
offsets = [r["attitude_offset"] for r in ok if r.get("attitude_offset")]
if offsets:
    for a in ("phi", "theta"):
        v = np.array([o[a] for o in offsets])
        print(f"attitude offset {a}: median |offset| {np.median(np.abs(v[:, 0])):.2e} rad, "
              f"median se {np.median(v[:, 1]):.2e}")
print("report:", write_report(study, args.out_dir, records, figures=False,
                              command=f"aeroid study {args.study} --jobs 1"))
