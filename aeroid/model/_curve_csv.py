"""One reader of a curve CSV: named columns, finite numbers, one-line errors naming the file.

A motor's thrust curve (``time_s, thrust_N[, mass_kg]``: :func:`aeroid.model.read_thrust_curve`)
and a design tool's drag curve (``Mach, Cd``: :func:`aeroid.report.read_reference_curve`)
are the same kind of file: a header of known column names (matched without case and
surrounding blanks), some required and some optional, any other column refused (never
silently ignored), every value a finite number. :func:`read_curve_csv` reads that shape;
each caller keeps its own words (what the curve is called, how its columns are listed,
whether a value is named by its "line" or its "row") and its own error kind, so the
messages are the callers' own. The checks of the values' meaning (increasing times or
Mach, ranges, units) stay with each curve.

It lives in the model layer so that both the model (thrust) and the report (reference
curve) may import it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aeroid.errors import AeroidError

__all__ = ["read_curve_csv"]


def read_curve_csv(path: str | Path, *, required: tuple[str, ...],
                   optional: tuple[str, ...] = (), kind: str, columns_text: str,
                   row_word: str = "row", error: type[AeroidError] = AeroidError
                   ) -> dict[str, np.ndarray]:
    """Return each present column of a curve CSV as floats, keyed by its lower-case name.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    required, optional : tuple of str
        The column names, lower case (the file's header is matched without case and
        surrounding blanks); a column of neither is refused.
    kind : str
        What the curve is, for messages: ``"thrust curve"``, ``"reference curve"``.
    columns_text : str
        How the columns are listed in the refusal: ``"a {kind} has {columns_text}
        (missing: ...; not used: ...)"``.
    row_word : str
        How a bad value's place is named: ``"column NAME {row_word} N"`` (N the file's
        line number, the header being line 1).
    error : type
        The :class:`aeroid.errors.AeroidError` kind raised.

    Raises
    ------
    AeroidError
        (of kind ``error``) One line naming the file: a file that cannot be read, a
        missing or unknown column, a value that is not a finite number.
    """
    where = str(path)
    try:
        frame = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise error(f"{where}: cannot read the {kind}: "
                    f"{' '.join(str(exc).split())}") from None
    names = {str(c).strip().lower(): c for c in frame.columns}
    known = (*required, *optional)
    missing = [c for c in required if c not in names]
    extra = sorted(str(c) for k, c in names.items() if k not in known)
    if missing or extra:
        raise error(f"{where}: a {kind} has {columns_text} (missing: "
                    f"{', '.join(missing) or 'none'}; not used: {', '.join(extra) or 'none'})")
    values = {}
    for key in (k for k in known if k in names):
        column = pd.to_numeric(frame[names[key]], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(column))
        if bad.size:
            raise error(f"{where}: column {names[key]} {row_word} {int(bad[0]) + 2} is not "
                        f"a finite number ({frame[names[key]].iloc[bad[0]]!r})")
        values[key] = column
    return values
