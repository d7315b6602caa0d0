"""A steady wind added to the model's inputs: numbers (a fit's wind) and symbols (issue 26).

The wind is the constants ``wind_n, wind_e, wind_d`` [m/s, NED] or, with per-sample
values, the exogenous columns of the same names (:data:`aeroid.model.EXOGENOUS`); a
steady wind estimated on top of them adds to both.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca

from aeroid.model import _inputs as inputs
from aeroid.model import _symbolic
from aeroid.model._equations import Constants
from aeroid.model._inputs import Record

#: The wind's fields of the constants and columns of the exogenous table.
WIND_FIELDS = ("wind_n", "wind_e", "wind_d")


def with_steady_wind(const: Constants, record: Record, wind_ned: Sequence[float]
                     ) -> tuple[Constants, Record]:
    """Return ``const`` and ``record`` with a steady wind (north, east, down [m/s]) added.

    The wind adds to the constants' wind and, where the record has per-sample values,
    to each sample's (what :func:`aeroid.model.symbolic_record` does with ``wind_free``).
    """
    names = WIND_FIELDS
    wind = [float(w) for w in wind_ned]
    const = const._replace(**{k: getattr(const, k) + w for k, w in zip(names, wind,
                                                                       strict=True)})
    if record.exogenous is None:
        return const, record
    table = record.exogenous.copy()
    for k, w in zip(names, wind, strict=True):
        table[:, inputs.EXOGENOUS.index(k)] += w
    return const, Record(record.dt, record.delta, record.pieces, table)


def with_wind_symbols(const: Constants, sym: _symbolic.IntervalSymbols, wind: ca.SX
                      ) -> tuple[Constants, _symbolic.IntervalSymbols, ca.SX]:
    """The constants and interval symbols with a steady wind ``wind`` (3 or 0) added.

    Returns the constants, the interval symbols, and the row to add to a sample's
    exogenous row (zeros but the wind columns; empty without per-sample values).
    """
    n_exo = sym.exo_a.shape[0]
    row = ca.SX.zeros(n_exo)
    if wind.shape[0] == 0:
        return const, sym, row
    names = WIND_FIELDS
    if not n_exo:
        return const._replace(**{k: getattr(const, k) + wind[j]
                                 for j, k in enumerate(names)}), sym, row
    for j, k in enumerate(names):
        row[inputs.EXOGENOUS.index(k)] = wind[j]
    return const, sym._replace(exo_a=sym.exo_a + row, exo_b=sym.exo_b + row), row
