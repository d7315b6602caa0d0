"""Write ``studies/<name>.md``: the committed summary of a study's measured report.

Usage (repository root, after ``aeroid study studies/<name>.toml ...``)::

    python studies/summarize.py <name> --command "aeroid study ..." --note "..."

Keeps the design, the overall table and the per-coefficient error tables of
``results/<name>/report.md`` (the bias/spread tables and figures stay in the full
report), and keeps a hand-written ``## Observations`` section of the existing summary.
"""

from __future__ import annotations

import argparse
import datetime as dt
import platform
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _strip_details(report: str) -> str:
    out, skipping = [], False
    for line in report.splitlines():
        if line.startswith("Bias, spread, coverage"):
            skipping = True
            continue
        if line.startswith("## Figures"):
            break
        if skipping and line.startswith("## "):
            skipping = False
        if not skipping:
            out.append(line)
    return "\n".join(out).rstrip() + "\n"


def main() -> None:
    """Parse the arguments and write the summary."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name")
    parser.add_argument("--command", required=True, help="the command that produced it")
    parser.add_argument("--note", default="", help="timing and conditions of the run")
    args = parser.parse_args()
    report = (ROOT / "results" / args.name / "report.md").read_text()
    target = ROOT / "studies" / f"{args.name}.md"
    observations = ""
    if target.exists() and "## Observations" in target.read_text():
        observations = "\n## Observations" + target.read_text().split("## Observations", 1)[1]
    body = _strip_details(report).split("\n", 1)[1]
    head = (f"# Study: {args.name} — measured summary\n\n"
            f"Measured {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC on {platform.machine()}, "
            f"{__import__('os').cpu_count()} cores, with `{args.command}`. {args.note}\n\n"
            f"The full report (bias, spread, Cramér-Rao ratio and coverage per coefficient, "
            f"and the figures) is written to `results/{args.name}/` by that command; this "
            f"file keeps the summary.\n")
    target.write_text(head + body + observations)
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
