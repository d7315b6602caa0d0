"""Rows of a scenario's true tables in the total angle of attack (private).

:mod:`aeroid.flights._scenario` reads ``[coefficients] Cma = {alpha_deg = [[deg, value],
...]}`` with :func:`angle_rows`.
"""

from __future__ import annotations

from typing import Any

from aeroid.errors import AirframeError
from aeroid.model import fileform


def angle_rows(value: dict[str, Any], where: str) -> list[tuple[float, ...]]:
    """The rows ``[deg, value]`` of ``{alpha_deg = [[deg, value], ...]}``."""
    fileform.check_keys(value, ("alpha_deg",), where, required=("alpha_deg",))
    given = value["alpha_deg"]
    if not isinstance(given, list) or not given:
        raise AirframeError(f"{where}: alpha_deg must be rows [[deg, value], ...], "
                            f"got {given!r}")
    return [fileform.numbers(row, 2, f"{where} (rows [alpha_deg, value])") for row in given]
