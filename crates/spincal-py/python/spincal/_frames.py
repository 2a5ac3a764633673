"""DataFrames (pandas and polars) and arrays handed to the library as columns, never as text.

The library decides which column is which (:func:`spincal._spincal.plan_columns`, the rules
``spincal`` applies to a file's header line); only the columns it chose are taken out of the
frame, as float64 arrays read in place where the frame already holds float64.
"""

from __future__ import annotations

from typing import Any, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _spincal
from ._spincal import ColumnPlan, FormatError, UsageError

Columns = Union[str, Sequence[Union[str, int, None]], None]
FloatArray = npt.NDArray[np.float64]


def frame_kind(value: Any) -> Optional[str]:
    """``"pandas"`` or ``"polars"`` for a DataFrame of either, else None (neither is imported)."""
    kind = type(value)
    if kind.__name__ != "DataFrame":
        return None
    module = kind.__module__.split(".")[0]
    return module if module in ("pandas", "polars") else None


def column_keys(columns: Columns) -> Optional[List[Optional[str]]]:
    """``columns=`` as the library's keys: names or 1-based positions (as text), time first;
    ``"t,ax,ay,az"`` is split at the commas.

    Example::

        >>> spincal._frames.column_keys("t, ax,ay,az")
        ['t', 'ax', 'ay', 'az']
        >>> spincal._frames.column_keys([None, "ax", 3, "az"])
        [None, 'ax', '3', 'az']
    """
    if columns is None:
        return None
    if isinstance(columns, str):
        return [c.strip() for c in columns.split(",")]
    keys: List[Optional[str]] = []
    for c in columns:
        if c is None or isinstance(c, str):
            keys.append(c)
        elif isinstance(c, (int, np.integer)) and not isinstance(c, bool):
            keys.append(str(int(c)))
        else:
            raise UsageError(f"columns: {c!r} is neither a column name, a 1-based position nor None")
    return keys


def header(frame: Any) -> List[str]:
    return [str(c) for c in frame.columns]


def as_floats(values: Any, what: str) -> FloatArray:
    """A 1-D float64 array of ``values`` (in place when it already is one); nulls become NaN."""
    try:
        return np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise FormatError(f"{what}: not numbers ({e})") from None


def frame_column(frame: Any, kind: str, position: int, name: str) -> FloatArray:
    """Column ``position`` (0-based) of a DataFrame as float64 (pandas: missing values as NaN)."""
    what = f"column {name}"
    if kind == "pandas":
        series = frame.iloc[:, position]
        try:
            values = series.to_numpy(dtype=np.float64, na_value=np.nan)
        except (TypeError, ValueError) as e:
            raise FormatError(f"{what}: not numbers ({e})") from None
        return np.asarray(values, dtype=np.float64)
    series = frame.to_series(position)
    if series.null_count():
        series = series.cast(float).fill_null(float("nan"))
    try:
        return as_floats(series.to_numpy(), what)
    except Exception as e:  # polars raises its own errors for strings
        raise FormatError(f"{what}: not numbers ({e})") from None


def plan(
    frame: Any,
    *,
    name: str,
    columns: Columns,
    accel_unit: Optional[str],
    time_unit: Optional[str],
    gyro_unit: Optional[str],
    time_optional: bool,
) -> ColumnPlan:
    return _spincal.plan_columns(
        header(frame),
        name=name,
        columns=column_keys(columns),
        accel_unit=accel_unit,
        time_unit=time_unit,
        gyro_unit=gyro_unit,
        time_optional=time_optional,
    )


Three = Tuple[FloatArray, FloatArray, FloatArray]


def planned_temperature(frame: Any, kind: str, p: ColumnPlan) -> Optional[FloatArray]:
    """The planned temperature column of ``frame`` in its own unit (or None)."""
    if p.temperature is None:
        return None
    return frame_column(frame, kind, p.temperature, p.names[-1])


def planned_columns(frame: Any, kind: str, p: ColumnPlan) -> Tuple[Optional[FloatArray], Three, Optional[Three]]:
    """The planned columns of ``frame``: time (or None), accel x, y, z, gyro x, y, z (or None)."""
    names = p.names
    time = None if p.time is None else frame_column(frame, kind, p.time, names[0])
    ax, ay, az = (frame_column(frame, kind, p.accel[a], names[1 + a]) for a in range(3))
    gyro: Optional[Three] = None
    if p.gyro is not None:
        gx, gy, gz = (frame_column(frame, kind, p.gyro[a], names[4 + a]) for a in range(3))
        gyro = (gx, gy, gz)
    return time, (ax, ay, az), gyro


_SI_HEADER = ["t", "ax_mps2", "ay_mps2", "az_mps2", "gx_radps", "gy_radps", "gz_radps"]
_si_plans: dict = {}


def si_plan(time: bool, gyro: bool) -> ColumnPlan:
    """The plan of arrays in SI units (s, m/s², rad/s), as the library reads such a header."""
    key = (time, gyro)
    if key not in _si_plans:
        names = _SI_HEADER[: 7 if gyro else 4]
        if not time:
            names = names[1:]
        _si_plans[key] = _spincal.plan_columns(names, name="arrays", time_optional=not time)
    return _si_plans[key]


def array_columns(value: Any, what: str, width: int = 3) -> FloatArray:
    """An (n, width) float64 array from an array, a list or a tuple (in place for float64)."""
    a = np.asarray(value, dtype=np.float64) if not isinstance(value, np.ndarray) or value.dtype != np.float64 else value
    if a.ndim != 2 or a.shape[1] != width:
        raise UsageError(f"{what}: expected an (n, {width}) array, got shape {a.shape}")
    return a


def split(a: FloatArray) -> Three:
    return a[:, 0], a[:, 1], a[:, 2]
