"""A log of an airframe without a moving fin (``fin = "passive"``, issue 25).

Such a log needs no fin column: its deflection is zero, which :func:`passive_fin_frame`
puts in the flight's ``delta`` channel and says in one line; a fin column that moves is
refused (the airframe says the fin does not). The estimators hold the fin terms Czd and
Cmd at zero (:meth:`aeroid.estimation.Estimator.fit`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aeroid.errors import FlightError
from aeroid.model import Airframe

__all__ = ["PASSIVE_FIN_NOTE", "passive_fin_frame", "passive_fin_problem"]

#: What reading a passive-fin log does.
PASSIVE_FIN_NOTE = ('the airframe\'s fin is passive (fin = "passive"): no fin column, the '
                    "deflection is 0 and the fin terms Czd, Cmd are held at 0")


def passive_fin_problem(delta: np.ndarray) -> str | None:
    """Return one line when a passive fin's ``delta`` channel moves, else None."""
    delta = np.asarray(delta, dtype=float)
    moving = np.flatnonzero(delta != 0.0)
    if moving.size == 0:
        return None
    return (f'a fin column (delta) that moves with a passive fin (airframe fin = "passive"): '
            f"{moving.size} non-zero sample(s), first at row {moving[0]}; drop the column or "
            "declare the moving fin")


def passive_fin_frame(frame: pd.DataFrame, airframe: Airframe, where: str
                      ) -> tuple[pd.DataFrame, str | None]:
    """Return the frame of a passive-fin log with ``delta = 0`` and the note, or as it is.

    Raises
    ------
    FlightError
        One line naming ``where`` when the log's fin column moves.
    """
    if airframe.fin != "passive":
        return frame, None
    if "delta" in frame.columns:
        problem = passive_fin_problem(frame["delta"].to_numpy(dtype=float))
        if problem is not None:
            raise FlightError(f"{where}: {problem}")
        return frame, None
    columns = list(frame.columns)
    at = columns.index("r") + 1 if "r" in columns else len(columns)
    return frame.assign(delta=0.0)[[*columns[:at], "delta", *columns[at:]]], PASSIVE_FIN_NOTE
