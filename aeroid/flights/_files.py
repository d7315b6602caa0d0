"""Flight files: CSV or Parquet data, the JSON sidecar, and a user's column map.

Data
    CSV (any file but ``.parquet``) or Parquet (``.parquet``; needs pyarrow, the
    ``parquet`` extra). One column per channel, a header row. Columns that are not
    aeroid channels (after the column map) are not read, and named in a notice.
Sidecar
    ``<name>.json`` beside the data (:mod:`aeroid.flights._sidecar`), read only when it
    carries aeroid's format tag. An airframe given to :func:`read_flight` always wins
    over the sidecar's, whose airframe is then not read; the sidecar's metadata (noise,
    seed, true coefficients and sensor positions) is kept, since it describes the data,
    not the airframe.
Column map
    ``{name in the file: channel}`` (:func:`read_column_map`), applied before reading;
    ``""`` drops a column, ``{channel, unit}`` converts one (:mod:`aeroid.flights._columns`).
    A wrapped roll or yaw angle is unwrapped where the rates resolve it.

Reading is bounded: only a regular file is opened (a FIFO would block forever, a
device never end); only the channel columns are parsed, in blocks of
:data:`CSV_BLOCK_ROWS` rows straight into one float array, so the peak memory is about
twice the flight's own (8 bytes per value); and a file whose estimated flight needs more
than the memory available is refused before parsing, with its estimate.
"""

from __future__ import annotations

import csv
import io
import logging
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aeroid.errors import AirframeError, FlightError
from aeroid.flights._channels import ANGLE_CHANNELS, CHANNELS, UNITS
from aeroid.flights._columns import (
    UNIT_FACTORS,
    UNIT_OFFSETS,
    ChannelMap,
    channel_map,
    check_targets,
    unwrap_angles,
)
from aeroid.flights._flight import Flight, air_angles, write_flight
from aeroid.flights._passive_fin import passive_fin_frame
from aeroid.flights._sidecar import read_sidecar
from aeroid.model import Airframe, fileform, load_airframe

#: Logger of aeroid's one-line notices (the command line prints them on stderr).
_NOTICES = logging.getLogger("aeroid")

#: Rows parsed per block: the parser's own buffers stay near 20 MB for 20 channels.
CSV_BLOCK_ROWS = 65_536
#: Peak memory of a read over the flight's own size (parsed blocks + the final array).
READ_MEMORY_FACTOR = 2.0
#: Longest header row read: a thousand columns of 60 characters fit; a file without line
#: breaks is not read whole just to find its header.
MAX_HEADER_CHARS = 1 << 16
#: Bytes of the file's beginning used to estimate its bytes per row.
_SAMPLE_BYTES = 1 << 16


# Column map -----------------------------------------------------------------------------
def read_column_map(path: str | Path) -> ChannelMap:
    """Return ``{name in the file: aeroid channel}`` from a TOML file, with units.

    The mapping is the file's top-level pairs, or its ``[columns]`` table (and then
    nothing else). A value is a channel name, ``""`` (drop the column), or
    ``{channel = "p", unit = "deg/s"}`` (convert on reading; :mod:`aeroid.flights._columns`).

    Raises
    ------
    FlightError
        One line naming the file: a value that is not a channel name, an unknown
        channel or unit, a unit of the wrong kind, or two columns sent to one channel.
    """
    try:
        data: dict[str, Any] = fileform.read_toml(path)
    except AirframeError as exc:
        raise FlightError(str(exc)) from None
    table: Mapping[str, Any] = data
    if isinstance(data.get("columns"), Mapping):
        others = sorted(k for k in data if k != "columns")
        if others:
            raise FlightError(f"{path}: a column map with a [columns] table has nothing "
                              f"else; unknown key(s) {', '.join(others)}")
        table = data["columns"]
    return channel_map(table, str(path))


def _mapped_names(header: list[str], columns: Mapping[str, str] | None,
                  path: Path) -> list[str]:
    """Return the channel name of each header column after the column map (``""``: dropped)."""
    if not columns:
        return list(header)
    check_targets(columns, str(path))
    absent = sorted(set(columns) - set(header))
    if absent:
        raise FlightError(f"{path}: column map names column(s) not in the file: {absent}")
    renamed_away = {name for name, channel in columns.items() if name != channel}
    for name, channel in columns.items():
        if channel and channel != name and channel in header and channel not in renamed_away:
            raise FlightError(f"{path}: column map sends {name!r} to {channel!r}, but the file "
                              f"already has a column {channel!r} (map or rename that one too)")
    return [columns.get(h, h) for h in header]


# Reading --------------------------------------------------------------------------------
def read_flight(
    path: str | Path,
    *,
    airframe: Airframe | str | Path | None = None,
    columns: Mapping[str, Any] | str | Path | None = None,
    degrees: bool = False,
    angles_in_degrees: bool | None = None,
) -> Flight:
    """Read a flight file (CSV or Parquet) and its sidecar when it is aeroid's.

    Parameters
    ----------
    path : path
        The data file: a regular file, CSV or (``.parquet``) Parquet.
    airframe : Airframe or path, optional
        An airframe or its TOML file. Always wins over the sidecar's airframe (whose
        metadata is kept); required when there is no aeroid sidecar.
    columns : mapping or path, optional
        The column map (:func:`read_column_map`) or its TOML file:
        ``{name in the file: channel}``, ``""`` to drop a column, or
        ``{"channel": ..., "unit": ...}`` to convert one.
    degrees : bool
        The file's angles are in degrees and its rates in deg/s (channels
        :data:`~aeroid.flights.ANGLE_CHANNELS` without a unit in the column map); they
        are converted to radians.
    angles_in_degrees : bool, optional
        The former name of ``degrees``.

    What reading did (units converted, a wrapped roll or yaw angle unwrapped, columns
    dropped or not read) is said in one line each on the
    ``aeroid`` logger and kept in the flight's :attr:`~Flight.notes` (a conversion as
    ``converted: column (unit -> aeroid unit), ...``).

    Raises
    ------
    FlightError
        One line naming the file and what is wrong. The data are not validated here:
        call :meth:`Flight.validate`.
    """
    path = Path(path)
    degrees = bool(degrees or angles_in_degrees)
    if isinstance(airframe, str | Path):
        airframe = load_airframe(airframe)
    if isinstance(columns, str | Path):
        columns = read_column_map(columns)
    elif columns is not None and not isinstance(columns, ChannelMap):
        columns = channel_map(columns, f"{path}: column map")
    units = dict(columns.units) if isinstance(columns, ChannelMap) else {}
    size = fileform.regular_file_size(path, FlightError)
    parquet = path.suffix == ".parquet"
    header = _parquet_header(path) if parquet else _csv_header(path)
    names = _mapped_names(header, columns, path)
    padded = [h for h, n in zip(header, names, strict=True) if n not in CHANNELS
              and h != h.strip() and h.strip() in CHANNELS]  # "t, ax1, ...": padded names
    if padded:
        raise FlightError(f"{path}: column name(s) {', '.join(map(repr, padded[:4]))}"
                          f"{', ...' if len(padded) > 4 else ''} have spaces around them; "
                          "names must match exactly: remove the spaces from the header")
    metadata, sidecar_airframe, sidecar_note = read_sidecar(path, need_airframe=airframe is None)
    airframe = airframe or sidecar_airframe
    if airframe is None:
        raise FlightError(f"{path}: no airframe ({sidecar_note}; give --airframe FILE)")
    keep = [j for j, n in enumerate(names) if n in CHANNELS]
    order = sorted(keep, key=lambda j: CHANNELS.index(names[j]))
    if not order:
        shown = ", ".join(map(repr, header[:6])) + (", ..." if len(header) > 6 else "")
        raise FlightError(f"{path}: no aeroid channel among the columns ({shown}); map them "
                          "with --columns")
    file_columns = [header[j] for j in order]
    read_channels = [names[j] for j in order]
    derived = [c for c in ("alpha", "beta") if c not in read_channels
               and all(x in read_channels for x in ("u", "v", "w"))]
    channels = sorted(read_channels + derived, key=CHANNELS.index)
    index = {c: j for j, c in enumerate(channels)}
    positions = [index[c] for c in read_channels]
    if parquet:
        values = _read_parquet(path, file_columns, positions, len(channels))
    else:
        _check_memory(path, size, len(channels))
        values = _read_csv(path, file_columns, positions, len(channels))
    notes = _convert_units(values, index, dict(zip(file_columns, read_channels, strict=True)),
                           units, degrees)
    if derived:
        alpha, beta = air_angles(*(values[:, index[c]] for c in ("u", "v", "w")))
        for name, column in (("alpha", alpha), ("beta", beta)):
            if name in derived:
                values[:, index[name]] = column
    frame = {c: values[:, index[c]] for c in channels if c in ("t", "p", "q", "r", "phi",
                                                                 "theta", "psi")}
    if "t" in frame:
        unwrapped = unwrap_angles(frame, frame["t"])
        for name in ("phi", "psi"):
            if name in frame:
                values[:, index[name]] = frame[name]
        notes += unwrapped
    notes += _column_notes(header, names)
    metadata["source"] = str(path)
    data, passive = passive_fin_frame(pd.DataFrame(values, columns=channels, copy=False),
                                      airframe, str(path))  # fin = "passive": no fin column
    notes += [passive] if passive else []
    for note in notes:
        _NOTICES.info(f"{path}: {note}")
    return Flight(data, airframe, metadata, notes=tuple(notes))


def _convert_units(values: np.ndarray, index: Mapping[str, int], read: Mapping[str, str],
                   units: Mapping[str, str], degrees: bool) -> list[str]:
    """Convert columns with a unit, then (``degrees``) the other angle channels, in place."""
    done: dict[str, str] = {}
    for column, channel in read.items():
        unit = units.get(column)
        if unit is not None:
            factor, offset = UNIT_FACTORS[unit][0], UNIT_OFFSETS.get(unit, 0.0)
            values[:, index[channel]] = values[:, index[channel]] * factor + offset
            done[column] = f"{unit} -> {UNITS[channel]}"
        elif degrees and channel in ANGLE_CHANNELS:
            np.radians(values[:, index[channel]], out=values[:, index[channel]])
            done[column] = f"{'deg/s' if UNITS[channel] == 'rad/s' else 'deg'} -> " \
                           f"{UNITS[channel]}"
    if not done:
        return []
    shown = ", ".join(f"{c} ({u})" for c, u in done.items())
    return [f"converted: {shown}"]


def _column_notes(header: list[str], names: list[str]) -> list[str]:
    """One line naming the columns dropped by the map and those not read."""
    dropped = [h for h, n in zip(header, names, strict=True) if n == ""]
    unused = [h for h, n in zip(header, names, strict=True) if n and n not in CHANNELS]
    notes = []
    if dropped:
        notes.append(f"dropped by the column map: {', '.join(dropped)}")
    if unused:
        notes.append(f"not read (not aeroid channels; map them with the column map, or drop "
                     f"them with \"\"): {', '.join(unused)}")
    return notes


def _csv_header(path: Path) -> list[str]:
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            line = fh.readline(MAX_HEADER_CHARS + 1)
        if len(line) > MAX_HEADER_CHARS:
            raise FlightError(f"{path}: cannot read flight data (header row longer than "
                              f"{MAX_HEADER_CHARS} characters: not a CSV log?)")
        header = next(csv.reader(io.StringIO(line)), [])
    except UnicodeDecodeError:
        raise FlightError(f"{path}: cannot read flight data (not UTF-8 text)") from None
    except OSError as exc:
        raise FlightError(f"{path}: cannot read ({exc.strerror})") from None
    if not header:
        raise FlightError(f"{path}: cannot read flight data (no header row)")
    _no_duplicates(header, path)
    return header


def _parquet_header(path: Path) -> list[str]:
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise FlightError(f"{path}: reading Parquet needs pyarrow "
                          "(pip install 'aeroid-toolkit[parquet]')") from None
    try:
        header = [str(n) for n in pq.read_schema(path).names]
    except Exception as exc:  # pyarrow.ArrowInvalid and friends on a corrupt file
        raise FlightError(f"{path}: cannot read flight data ({_first_line(exc)})") from None
    _no_duplicates(header, path)
    return header


def _no_duplicates(header: list[str], path: Path) -> None:
    seen: set[str] = set()
    for name in header:
        if name in seen:
            raise FlightError(f"{path}: column {name!r} appears twice in the header")
        seen.add(name)


def _read_csv(path: Path, file_columns: list[str], positions: list[int],
              width: int) -> np.ndarray:
    """Parse the named columns in blocks into columns ``positions`` of a (n, width) array."""
    blocks: list[np.ndarray] = []
    try:
        with warnings.catch_warnings():  # mixed types: non-numeric cells become NaN below
            warnings.simplefilter("ignore", pd.errors.DtypeWarning)
            reader = pd.read_csv(path, usecols=file_columns, chunksize=CSV_BLOCK_ROWS,
                                 encoding="utf-8-sig")
            with reader:
                for chunk in reader:
                    blocks.append(_as_floats(chunk[file_columns]))
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError,
            ValueError) as exc:
        raise FlightError(f"{path}: cannot read flight data ({_first_line(exc)})") from None
    n = sum(len(b) for b in blocks)
    values = np.empty((n, width))
    start = 0
    while blocks:  # free each block once copied
        block = blocks.pop(0)
        values[start:start + len(block), positions] = block
        start += len(block)
    return values


def _read_parquet(path: Path, file_columns: list[str], positions: list[int],
                  width: int) -> np.ndarray:
    import pyarrow.parquet as pq

    try:
        n = pq.ParquetFile(path).metadata.num_rows
        _check_rows(path, n, width)
        frame = pd.read_parquet(path, columns=file_columns, engine="pyarrow")
    except FlightError:
        raise
    except Exception as exc:  # pyarrow.ArrowInvalid and friends on a corrupt file
        raise FlightError(f"{path}: cannot read flight data ({_first_line(exc)})") from None
    values = np.empty((len(frame), width))
    values[:, positions] = _as_floats(frame[file_columns])
    return values


def _is_float_like(dtype: Any) -> bool:
    return pd.api.types.is_numeric_dtype(dtype) and not pd.api.types.is_bool_dtype(dtype)


def _as_floats(frame: pd.DataFrame) -> np.ndarray:
    """The frame as floats; non-numeric cells (text, booleans) become NaN for ``validate``."""
    if all(_is_float_like(t) for t in frame.dtypes):
        return frame.to_numpy(dtype=float)
    out = np.empty(frame.shape)
    for j, name in enumerate(frame.columns):
        column = frame[name]
        if pd.api.types.is_bool_dtype(column.dtype):
            out[:, j] = np.nan
        elif _is_float_like(column.dtype):
            out[:, j] = column.to_numpy(dtype=float)
        else:
            as_text = column.astype(object)
            flags = as_text.map(lambda x: isinstance(x, bool | np.bool_)).to_numpy(dtype=bool)
            out[:, j] = pd.to_numeric(as_text.where(~flags), errors="coerce").to_numpy(float)
    return out


def _check_memory(path: Path, size: int, width: int) -> None:
    """Refuse a CSV whose estimated flight would not fit in the memory available."""
    with path.open("rb") as fh:
        sample = fh.read(_SAMPLE_BYTES)
    lines = sample.count(b"\n")
    if lines < 2 or size <= len(sample):
        return
    _check_rows(path, int(size / (len(sample) / lines)), width)


def _check_rows(path: Path, rows: int, width: int) -> None:
    need = READ_MEMORY_FACTOR * rows * max(width, 1) * 8
    available = available_memory_bytes()
    if available is not None and need > available:
        raise FlightError(
            f"{path}: about {rows} rows x {width} channels need about {need / 2**30:.1f} GiB "
            f"to read, more than the {available / 2**30:.1f} GiB of memory available; "
            "cut the log to the window you fit")


def available_memory_bytes() -> int | None:
    """Return the memory available to a new allocation [bytes], or None when unknown.

    Linux: ``MemAvailable`` of ``/proc/meminfo``; elsewhere the free physical pages.
    """
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return None


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


__all__ = ["available_memory_bytes", "read_column_map", "read_flight", "write_flight"]
