"""spincal: turntable-referenced IMU accelerometer calibration, from Python.

The science is the spincal Rust library (the same code as the ``spincal`` command); this package
converts arguments and results. Signals are numpy arrays in SI units (s, m/s², rad/s); results
are typed objects with attributes and ``to_dict()``; every error is a ``spincal.Error`` carrying the
library's message (file, line, column, key or parameter at fault). Long work releases the GIL,
stops on Ctrl-C (``KeyboardInterrupt``) and shows a tqdm bar with ``progress=True``.

Example::

    import spincal
    rec, truth = spincal.simulate(seed=7)
    cal = spincal.calibrate([rec], radius_m=0.10, hidden=[4], restarts=1)
    print(cal.result.verdict)   # one recording: nothing saved, and what to record next
    cal.write("cal")            # results.json, report.html (model.json when saved)
    unit = spincal.calibrate_campaign("unit7/campaign.toml")   # still poses and turntable runs
    fixed = unit.corrector.correct(frame)          # a pandas/polars DataFrame, an array, a recording
    out = fixed.to_pandas()                        # corrected columns, valid, status; frame's index

Fleets on a Ray cluster: ``spincal.ray`` (``pip install "spincal[ray]"``).
"""

from __future__ import annotations

import json
import os
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union, cast

import numpy as np
import numpy.typing as npt

from . import _frames, _spincal
from ._params import Axes, Orders, calibration_changes, default_params, fit_changes, orders_list
from ._results import (
    AllanResult,
    PaperProtocol,
    CampaignResult,
    Parameter,
    Parameters,
    Result,
    StaticResult,
    TurntableFit,
    Truth,
)
from ._spincal import (
    Error,
    FitError,
    FormatError,
    ModelError,
    OutputError,
    Recording,
    UsageError,
)

__version__: str = _spincal.version()

__all__ = [
    "Error",
    "FormatError",
    "ModelError",
    "FitError",
    "UsageError",
    "OutputError",
    "Recording",
    "Corrector",
    "Corrected",
    "Calibration",
    "Result",
    "Parameter",
    "Parameters",
    "TurntableFit",
    "PaperProtocol",
    "CampaignResult",
    "StaticResult",
    "AllanResult",
    "Truth",
    "read",
    "recording",
    "simulate",
    "simulate_campaign",
    "simulation_defaults",
    "fit_turntable",
    "calibrate",
    "calibrate_campaign",
    "default_params",
    "load_corrector",
    "correct",
    "static_calibration",
    "allan",
    "sensitivity",
    "simulate_fleet",
    "calibrate_unit",
]

PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[bool, Callable[[str, int, Optional[int]], Any], None]
#: A recording, a file (path or bytes) or a pandas/polars DataFrame.
RecordingLike = Union[Recording, PathLike, bytes, Any]
#: Columns by name or 1-based position, time first (None: no time column): ``["t", "ax", "ay", "az"]``.
Columns = _frames.Columns
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@contextmanager
def _progress(progress: Progress, label: str) -> Iterator[Optional[Callable[[str, int, Optional[int]], None]]]:
    """The callback handed to the library: a tqdm bar for ``True``, the caller's own callable, or
    none."""
    if progress is None or progress is False:
        yield None
        return
    if callable(progress):
        yield progress
        return
    try:
        from tqdm.auto import tqdm
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise UsageError("progress=True needs tqdm: pip install tqdm (or pass a callable)") from e
    bar = tqdm(desc=label, total=None, unit="step", leave=False)

    def show(stage: str, done: int, total: Optional[int]) -> None:
        if bar.total != total:
            bar.total = total
        bar.set_description(f"{label}: {stage}", refresh=False)
        bar.n = done
        bar.refresh()

    try:
        yield show
    finally:
        bar.close()


def read(
    source: Union[PathLike, bytes, Any],
    *,
    name: Optional[str] = None,
    format: Optional[str] = None,
    columns: Columns = None,
    accel_unit: Optional[str] = None,
    time_unit: Optional[str] = None,
    gyro_unit: Optional[str] = None,
    sample_rate_hz: Optional[float] = None,
    accel_scale: Optional[float] = None,
    retime: bool = False,
) -> Recording:
    """Reads a recording in any format spincal reads: delimited text, imu_tk, imucal, MPU-6050,
    phyphox, the 3DM-GX1 binary stream, MAT-files, ROS bags (detected, or named by ``format``).

    ``source`` is a path, the file's bytes (``name`` then names it in errors), or a pandas or
    polars DataFrame. A DataFrame's columns are found by the CLI's rules (``t``/``time``/``t_s``,
    ``ax``/``acc_x``/``ax_g`` …, gyro ``gx``/``gyro_x`` …) or named by ``columns=["t", "ax", "ay",
    "az"]`` (names or 1-based positions; seven entries with the gyro); they are handed over as
    arrays, never as text. Without a time column give ``sample_rate_hz`` (time = sample number /
    rate; ``columns`` may then start with None). Units as the CLI: from the column names (``_g``,
    ``_ms``, ``_dps``) or ``accel_unit="g"``, ``time_unit="ms"``, ``gyro_unit="dps"``. Returns a
    :class:`Recording` in SI units: ``rec.time`` (n,), ``rec.accel`` (n, 3) m/s², ``rec.gyro``
    (n, 3) rad/s or None.

    Raises :class:`FormatError` naming the file (or frame), line or row, and column at fault: a
    value that is not a finite number is refused, as everywhere in spincal.

    Example::

        >>> import pandas as pd
        >>> frame = pd.DataFrame({"time": [0.0, 0.01, 0.02], "ax_g": [0.0, 0.1, 0.2],
        ...                       "ay_g": [0.0, 0.0, 0.0], "az_g": [1.0, 1.0, 1.0]})
        >>> rec = spincal.read(frame)
        >>> rec.columns, float(rec.accel[1, 0])
        (['time', 'ax_g', 'ay_g', 'az_g'], 0.980665)
        >>> spincal.read(frame[["ax_g", "ay_g", "az_g"]], sample_rate_hz=100).time.tolist()
        [0.0, 0.01, 0.02]
    """
    kind = _frames.frame_kind(source)
    if kind is not None:
        if format is not None or accel_scale is not None or retime:
            raise UsageError("format, accel_scale and retime apply to files; a DataFrame is read by its columns")
        label = name or "<DataFrame>"
        plan = _frames.plan(
            source,
            name=label,
            columns=columns,
            accel_unit=accel_unit,
            time_unit=time_unit,
            gyro_unit=gyro_unit,
            time_optional=sample_rate_hz is not None,
        )
        time, accel, gyro = _frames.planned_columns(source, kind, plan)
        return _spincal.recording_from_columns(
            None if sample_rate_hz is not None else time,
            accel,
            gyro,
            plan,
            name=label,
            format=f"{kind} DataFrame",
            sample_rate_hz=sample_rate_hz,
            temperature=_frames.planned_temperature(source, kind, plan),
        )
    if isinstance(source, (bytearray, memoryview)):
        source = bytes(source)
    elif not isinstance(source, bytes):
        source = os.fspath(source)
    keys = _frames.column_keys(columns)
    if keys is not None and None in keys:
        raise UsageError("columns: None (no time column) is for DataFrames; a file states its time or its rate")
    return _spincal.read(
        source,
        name=name,
        format=format,
        columns=None if keys is None else ",".join(k for k in keys if k is not None),
        accel_unit=accel_unit,
        time_unit=time_unit,
        gyro_unit=gyro_unit,
        sample_rate_hz=sample_rate_hz,
        accel_scale=accel_scale,
        retime=retime,
    )


def recording(
    time: Any,
    accel: Any,
    gyro: Any = None,
    *,
    name: str = "array",
    sample_rate_hz: Optional[float] = None,
    temperature: Any = None,
) -> Recording:
    """A :class:`Recording` from arrays (numpy arrays, lists or tuples): ``time`` (n,) in s,
    ``accel`` (n, 3) in m/s², optional ``gyro`` (n, 3) in rad/s and ``temperature`` (n,) in °C.
    ``time`` may be None with ``sample_rate_hz`` (time = sample number / rate). Every value must
    be a finite number and time must not go backwards (:class:`FormatError` names the row and
    column).

    Example::

        >>> t = np.arange(1000) / 100.0
        >>> a = np.tile([0.0, 0.0, 9.81], (1000, 1))
        >>> spincal.recording(t, a).sample_rate_hz
        100.0
        >>> spincal.recording(None, [[0.0, 0.0, 9.81]] * 3, sample_rate_hz=50).time.tolist()
        [0.0, 0.02, 0.04]
    """
    a = _frames.array_columns(accel, "accel")
    g = None if gyro is None else _frames.array_columns(gyro, "gyro")
    if time is None and sample_rate_hz is None:
        raise UsageError("time is None: give sample_rate_hz (time = sample number / rate)")
    t = None if time is None else _frames.as_floats(time, "time")
    if t is not None and t.ndim != 1:
        raise UsageError(f"time: expected an (n,) array, got shape {t.shape}")
    plan = _frames.si_plan(t is not None, g is not None)
    return _spincal.recording_from_columns(
        t if sample_rate_hz is None else None,
        _frames.split(a),
        None if g is None else _frames.split(g),
        plan,
        name=name,
        format="array",
        sample_rate_hz=sample_rate_hz,
        temperature=None if temperature is None else _frames.as_floats(temperature, "temperature"),
    )


def _as_recording(value: RecordingLike, read_options: Optional[Mapping[str, Any]] = None) -> Recording:
    if isinstance(value, Recording):
        return value
    return read(value, **dict(read_options or {}))


def simulation_defaults() -> Dict[str, Dict[str, Any]]:
    """The simulator's default settings: ``{"sensor": …, "turntable": …, "campaign": …}`` (SI
    units and the unit in each name); pass changed entries to :func:`simulate` or
    :func:`simulate_campaign`.

    Example::

        >>> spincal.simulation_defaults()["turntable"]["rpm"]
        33.333333333333336
    """
    sensor, turntable, campaign = _spincal.simulation_defaults()
    return {"sensor": json.loads(sensor), "turntable": json.loads(turntable), "campaign": json.loads(campaign)}


def simulate(
    *,
    seed: int = 7,
    sensor: Optional[Mapping[str, Any]] = None,
    turntable: Optional[Mapping[str, Any]] = None,
) -> Tuple[Recording, Truth]:
    """Simulates a 3DM-GX1-like sensor on a record player; deterministic for a seed.

    ``sensor`` and ``turntable`` change the defaults (:func:`simulation_defaults`), e.g.
    ``turntable={"rpm": 45, "duration_s": 60}``, ``sensor={"bias_g": [0.01, 0, 0]}``; an unknown
    key raises :class:`UsageError`. Returns the recording and the :class:`Truth`.

    Example::

        >>> rec, truth = spincal.simulate(seed=7, turntable={"duration_s": 10})
        >>> len(rec)
        1000
    """
    rec, truth = _spincal.simulate(
        None if sensor is None else json.dumps(dict(sensor)),
        None if turntable is None else json.dumps(dict(turntable)),
        seed,
    )
    return rec, Truth._from_json(truth)


def simulate_campaign(
    folder: PathLike, *, seed: int = 7, setup: Optional[Mapping[str, Any]] = None
) -> Truth:
    """Writes a simulated unit's campaign into ``folder`` (``campaign.toml``, the recordings in
    m/s², ``*.truth.csv``, ``*.random.csv`` (drift + white noise per sample) and ``truth.json``),
    as ``spincal simulate --campaign``; ``setup``
    changes the defaults (``simulation_defaults()["campaign"]``, e.g. ``{"sensor": {...}}``).
    Refuses to replace files (:class:`UsageError`). Returns the :class:`Truth`.

    Example::

        >>> truth = spincal.simulate_campaign("unit7", seed=7)                   # doctest: +SKIP
        >>> cal = spincal.calibrate_campaign("unit7/campaign.toml")              # doctest: +SKIP
    """
    text = _spincal.simulate_campaign(os.fspath(folder), seed, None if setup is None else json.dumps(dict(setup)))
    return Truth._from_json(text)


def fit_turntable(
    recordings: Sequence[RecordingLike],
    *,
    rpm: Optional[float] = None,
    radius_m: Optional[float] = None,
    radius_tol_m: Optional[float] = None,
    objective_axes: Optional[str] = None,
    drift: Optional[bool] = None,
    fit_offsets: Optional[bool] = None,
    separate_radii: Optional[bool] = None,
    gravity_mps2: Optional[float] = None,
    range_g: Optional[float] = None,
    bounds: Optional[Mapping[str, Tuple[float, float]]] = None,
    params: Optional[Mapping[str, Any]] = None,
    progress: Progress = False,
) -> TurntableFit:
    """Fits the turntable model (ω²r plus tilted gravity, offsets, drift) to one or more
    recordings, as ``spincal fit``: bounded Nelder–Mead then Levenberg–Marquardt, standard errors,
    correlations, and what the data did not determine.

    ``recordings``: :class:`Recording` objects, paths or DataFrames. Every setting left None is
    the library's default (:func:`default_params` ``["fit"]``); ``radius_tol_m`` (default
    0.002) is the tolerance of ``radius_m``; ``bounds`` replaces a parameter's bounds by name (SI
    units); ``params={"fit": {...}}`` changes any other setting of the fit. Returns a
    :class:`TurntableFit`: ``fit.parameters["radius"].value``, ``.stderr``, ``.unit``;
    ``references`` are the reference accelerations (n, 3) in m/s².

    Example::

        >>> rec, truth = spincal.simulate()
        >>> fit = spincal.fit_turntable([rec], rpm=33.3)
        >>> abs(fit.recordings[0].session.omega_radps / truth.session.omega_radps - 1) < 1e-3
        True
        >>> fit.parameters["radius"].unit
        'm'
    """
    recs = [_as_recording(r) for r in recordings]
    fit = fit_changes(
        rpm=rpm,
        radius_m=radius_m,
        radius_tol_m=radius_tol_m,
        objective_axes=objective_axes,
        drift=drift,
        fit_offsets=fit_offsets,
        separate_radii=separate_radii,
        gravity_mps2=gravity_mps2,
        range_g=range_g,
        bounds=bounds,
    )
    changes = calibration_changes(
        params, fit, sweep=None, hidden=None, restarts=None, sweep_hessian_samples=None,
        correct_axes=None, delays=None, seed=None,
    )
    with _progress(progress, "turntable fit") as callback:
        text, references = _spincal.fit_turntable(
            recs, params_json=json.dumps(changes) if changes else None, progress=callback
        )
    return TurntableFit(json.loads(text), references)


_STATUS_NAMES: List[str] = list(_spincal.STATUS_NAMES)
_REFUSED = _STATUS_NAMES.index("refused")


@dataclass(frozen=True, eq=False)
class Corrected:
    """Rows corrected as ``spincal correct`` corrects them, one per input row, in order.

    ``accel`` (n, 3) m/s² (every axis; the axes the corrector does not change pass through),
    ``gyro`` (n, 3) rad/s (when the model calibrates the gyroscope and the data has it, else
    None), ``valid`` (n,) (False for the first rows without a full delay history, for rows a
    network does not correct and for refused rows), ``outside_training_range`` (n,), and
    ``status`` (n,): ``ok``, ``physics-only``, ``outside-range``, ``no-temperature``,
    ``outside-temperature-range``, ``suspect-temperature`` or ``refused: row …: why`` (a
    value that is not a finite number, time going backwards; the row's corrected values are
    NaN), the words of ``spincal correct``'s status column. ``refused`` maps each refused row's
    position to its reason. For a model whose parameters' covariance predicts its error (the
    ``physical`` kind and the ``linear`` map of ``linear-12`` from a campaign), ``predicted_sd`` (n, 3) m/s² is each row's predicted
    standard deviation of the correction and ``predicted_better`` (n,) whether on every corrected
    axis the correction is predicted to beat no correction (its square above twice its
    variance); other kinds give None for both.

    :meth:`to_pandas` and :meth:`to_polars` give the columns ``spincal correct`` adds to its
    input, named by the library's one rule: ``<axis>_corrected_<unit>`` per corrected axis in
    the input's unit (``ax_corrected_g``, ``gx_corrected_dps``), then
    ``<axis>_corrected_sd_<unit>`` and ``predicted_better`` where predicted, ``valid``,
    ``status``, with the input's index: ``frame.join(out.to_pandas())`` is the CLI's output.
    Arrays, recordings and files are in SI units, so their columns are ``ax_corrected_mps2``,
    ``gx_corrected_radps`` ….
    """

    accel: FloatArray
    gyro: Optional[FloatArray]
    valid: BoolArray
    outside_training_range: BoolArray
    status_codes: npt.NDArray[np.uint8]
    refused: Dict[int, str]
    axes: Tuple[str, ...]
    columns: Tuple[str, ...] = field(repr=False)
    accel_to_mps2: float = field(repr=False, default=1.0)
    gyro_to_radps: float = field(repr=False, default=1.0)
    index: Any = field(repr=False, default=None)
    predicted_sd: Optional[FloatArray] = field(repr=False, default=None)
    predicted_better: Optional[BoolArray] = field(repr=False, default=None)
    accel_unit: str = field(repr=False, default="mps2")
    gyro_unit: str = field(repr=False, default="radps")

    def __len__(self) -> int:
        return int(self.accel.shape[0])

    def _row_label(self, row: int) -> Any:
        return row if self.index is None else self.index[row]

    def _status_categories(self) -> Tuple[List[str], npt.NDArray[np.int32]]:
        """Every status as a category and each row's code into them (refused rows each their own)."""
        codes = self.status_codes.astype(np.int32)
        categories = _STATUS_NAMES[:_REFUSED]
        for k, (row, why) in enumerate(sorted(self.refused.items())):
            categories.append(f"refused: row {self._row_label(row)}: {why}")
            codes[row] = _REFUSED + k
        return categories, codes

    @property
    def status(self) -> npt.NDArray[np.object_]:
        """Each row's status, as ``spincal correct`` writes it."""
        categories, codes = self._status_categories()
        return np.asarray(categories, dtype=object)[codes]

    def _output_columns(self) -> Dict[str, FloatArray]:
        """The corrected columns in the input's units, computed and named as the CLI does."""
        from_mps2 = 1.0 / self.accel_to_mps2
        k = self.gyro_to_radps
        values: List[FloatArray] = [
            self.accel[:, "xyz".index(axis)] if from_mps2 == 1.0 else self.accel[:, "xyz".index(axis)] * from_mps2
            for axis in self.axes
        ]
        if self.gyro is not None:
            values += [self.gyro[:, a] if k == 1.0 else self.gyro[:, a] / k for a in range(3)]
        if self.predicted_sd is not None:
            values += [
                self.predicted_sd[:, "xyz".index(axis)] if from_mps2 == 1.0 else self.predicted_sd[:, "xyz".index(axis)] * from_mps2
                for axis in self.axes
            ]
        names = _spincal.corrected_column_names(
            list(self.axes),
            self.accel_unit,
            None if self.gyro is None else self.gyro_unit,
            self.predicted_sd is not None,
        )
        # predicted_better, the last name where predicted, is added by the frames themselves.
        return dict(zip(names, values))

    def to_pandas(self) -> Any:
        """A pandas DataFrame with the input's index: ``<axis>_corrected_<unit>`` per corrected
        axis (and gyro axis) in the input's unit, ``valid`` (bool) and ``status`` (categorical).

        Example::

            >>> out = corrector.correct(frame).to_pandas()                      # doctest: +SKIP
            >>> frame.join(out)          # what `spincal correct` writes        # doctest: +SKIP
        """
        import pandas as pd

        categories, codes = self._status_categories()
        data: Dict[str, Any] = dict(self._output_columns())
        if self.predicted_better is not None:
            data["predicted_better"] = self.predicted_better
        data["valid"] = self.valid
        data["status"] = pd.Categorical.from_codes(cast(Any, codes), categories=pd.Index(categories))
        index = self.index if self.index is not None else pd.RangeIndex(len(self))
        return pd.DataFrame(data, index=index, copy=False)

    def to_polars(self) -> Any:
        """A polars DataFrame of the same columns as :meth:`to_pandas` (``status`` as an Enum),
        rows in the input's order.

        Example::

            >>> out = corrector.correct(frame).to_polars()                      # doctest: +SKIP
        """
        import polars as pl

        categories, codes = self._status_categories()
        columns: List[Any] = [pl.Series(name, values) for name, values in self._output_columns().items()]
        if self.predicted_better is not None:
            columns.append(pl.Series("predicted_better", self.predicted_better))
        columns.append(pl.Series("valid", self.valid))
        status = pl.Series("status", categories, dtype=pl.String).gather(codes)
        columns.append(status.cast(pl.Enum(categories)))
        return pl.DataFrame(columns)

    def to_dict(self) -> Dict[str, Any]:
        """Plain lists: ``accel``, ``gyro`` (or None), ``valid``, ``outside_training_range``,
        ``status``."""
        return {
            "accel": self.accel.tolist(),
            "gyro": None if self.gyro is None else self.gyro.tolist(),
            "valid": self.valid.tolist(),
            "outside_training_range": self.outside_training_range.tolist(),
            "status": self.status.tolist(),
        }


class Corrector:
    """A saved corrector (model.json) of any kind: ``ann``, ``linear``, ``static``,
    ``physical``, ``physical_linear`` or ``physical_ann``, with the gyroscope's calibration when
    the campaign had gyro columns (``has_gyro``). Load with :func:`load_corrector`; apply with
    :meth:`correct`.

    Example::

        >>> c = spincal.load_corrector("cal/model.json")                          # doctest: +SKIP
        >>> out = c.correct(frame)                                                # doctest: +SKIP
        >>> out.to_pandas().columns.tolist()                                      # doctest: +SKIP
        ['ax_corrected_g', 'ay_corrected_g', 'valid', 'status']
    """

    __slots__ = ("_inner",)

    def __init__(self, inner: "_spincal.Corrector"):
        self._inner = inner

    @property
    def kind(self) -> str:
        """``ann``, ``linear``, ``static``, ``physical``, ``physical_linear`` or ``physical_ann``."""
        return self._inner.kind

    @property
    def axes(self) -> List[str]:
        """The accelerometer axes it changes; the others pass through."""
        return list(self._inner.axes)

    @property
    def has_gyro(self) -> bool:
        """True when it also calibrates the gyroscope (applied to gyro columns by :meth:`correct`)."""
        return self._inner.has_gyro

    @property
    def has_thermal(self) -> bool:
        """Whether the model corrects the accelerometer for temperature (a campaign whose still
        recordings logged one): rows then need a temperature."""
        return self._inner.has_thermal

    @property
    def warmup_samples(self) -> int:
        """Samples at the start without a full delay history (passed through, ``valid`` False)."""
        return self._inner.warmup_samples

    def __repr__(self) -> str:
        return repr(self._inner)

    def to_json(self) -> str:
        """model.json's text."""
        return self._inner.to_json()

    def to_dict(self) -> Dict[str, Any]:
        """model.json's content as plain data."""
        return json.loads(self._inner.to_json())

    def save(self, path: PathLike, *, force: bool = False) -> None:
        """Writes model.json (temporary file, then renamed). An existing file that spincal did
        not write (or that changed since it did) raises :class:`UsageError` unless ``force``."""
        self._inner.save(os.fspath(path), force=force)

    def correct_file(
        self,
        input: PathLike,
        output: PathLike,
        *,
        gyro_file: Optional[PathLike] = None,
        force: bool = False,
        **read: Any,
    ) -> Dict[str, Any]:
        """Corrects the file ``input`` into the file ``output`` exactly as ``spincal correct``
        does, to the bit, through the same library pipeline: delimited text is streamed in
        constant memory (every row out in the input's order, refused rows marked in place), other
        formats are read whole. ``read`` takes :func:`read`'s options (``format``, ``columns``,
        ``accel_unit``, ``time_unit``, ``gyro_unit``, ``sample_rate_hz``, ``accel_scale``,
        ``retime``). ``gyro_file``: the gyroscope from a second file (``spincal correct
        --gyro-file``), merged on time inside the stream (rows outside its span written with
        status ``no-gyro``). An existing ``output`` that spincal did not write is refused unless
        ``force``. Returns the summary: ``rows``, ``refused``, ``skipped``, … and ``warnings``
        (what the CLI prints), ``refusals`` (None when no row was refused).

        Example::

            >>> summary = corrector.correct_file("run.csv", "run-corrected.csv")  # doctest: +SKIP
            >>> summary["rows"], summary["refused"]                                # doctest: +SKIP
            (12000, 0)
        """
        keys = _frames.column_keys(read.pop("columns", None))
        if keys is not None and None in keys:
            raise UsageError("columns: None (no time column) is for DataFrames; a file states its time or its rate")
        text = self._inner.correct_file(
            os.fspath(input),
            os.fspath(output),
            columns=None if keys is None else ",".join(k for k in keys if k is not None),
            gyro_file=None if gyro_file is None else os.fspath(gyro_file),
            force=force,
            **read,
        )
        return cast(Dict[str, Any], json.loads(text))

    def correct(
        self,
        data: Union[npt.ArrayLike, Recording, PathLike, bytes, Any],
        *,
        gyro: Optional[npt.ArrayLike] = None,
        time: Optional[npt.ArrayLike] = None,
        temperature: Optional[npt.ArrayLike] = None,
        columns: Columns = None,
        accel_unit: Optional[str] = None,
        time_unit: Optional[str] = None,
        gyro_unit: Optional[str] = None,
        **read_options: Any,
    ) -> Corrected:
        """Corrects rows in time order exactly as ``spincal correct`` does: the same library
        calls, the gyroscope too when the model calibrates it, the same ``status`` per row (a row
        with a value that is not a finite number, or whose time goes backwards, is refused and
        the next rows go on). Returns :class:`Corrected`.

        ``data``:

        - a pandas or polars DataFrame: columns found as :func:`read` finds them (``columns=``,
          units from the names or ``accel_unit``/``time_unit``/``gyro_unit``), handed over as
          arrays (never as text); a time column is optional (when present, rows whose time goes
          back are refused, as by the CLI); the output keeps the frame's index;
        - an (n, 3) array, list or tuple of m/s² (read in place when float64, whatever its
          strides), with optional ``gyro`` (n, 3) rad/s, ``time`` (n,) s and ``temperature`` (n,) °C;
        - a :class:`Recording`, or a file (path or bytes, read whole with ``read_options`` as
          :func:`read`).

        Example::

            >>> rec, _ = spincal.simulate(seed=7, turntable={"duration_s": 5})
            >>> linear = spincal.load_corrector("tests/linear.json")            # doctest: +SKIP
            >>> out = linear.correct(rec.accel)                                  # doctest: +SKIP
            >>> out.status[:2].tolist()                                          # doctest: +SKIP
            ['ok', 'ok']
        """
        kind = _frames.frame_kind(data)
        index = None
        if kind is not None:
            if read_options:
                raise UsageError(f"{', '.join(read_options)}: not used for a DataFrame (its columns are read as they are)")
            plan = _frames.plan(
                data,
                name="<DataFrame>",
                columns=columns,
                accel_unit=accel_unit,
                time_unit=time_unit,
                gyro_unit=gyro_unit,
                time_optional=True,
            )
            t, accel, g = _frames.planned_columns(data, kind, plan)
            # Read only when used: a text column named like a temperature must not stop a model without one.
            temp = _frames.planned_temperature(data, kind, plan) if self.has_thermal else None
            index = cast(Any, data).index if kind == "pandas" else None
        elif isinstance(data, (np.ndarray, list, tuple)):
            if columns is not None or accel_unit is not None or time_unit is not None or gyro_unit is not None or read_options:
                raise UsageError("columns and units apply to DataFrames and files; arrays are in s, m/s² and rad/s")
            a = _frames.array_columns(data, "accel")
            ga = None if gyro is None else _frames.array_columns(gyro, "gyro")
            t = None if time is None else _frames.as_floats(time, "time")
            temp = None if temperature is None else _frames.as_floats(temperature, "temperature")
            plan = _frames.si_plan(t is not None, ga is not None)
            accel, g = _frames.split(a), None if ga is None else _frames.split(ga)
        else:
            if gyro is not None or time is not None or temperature is not None:
                raise UsageError("gyro, time and temperature go with an accel array; a recording or file has its own")
            options = dict(read_options, columns=columns, accel_unit=accel_unit, time_unit=time_unit, gyro_unit=gyro_unit)
            rec = _as_recording(data, {k: v for k, v in options.items() if v is not None})
            rg = rec.gyro
            t = rec.time
            temp = rec.temperature
            plan = _frames.si_plan(True, rg is not None)
            accel, g = _frames.split(rec.accel), None if rg is None else _frames.split(rg)
        if self.has_gyro and g is None:
            warnings.warn(
                "the model calibrates the gyroscope, but the data has no gyro columns; only the accelerometer was corrected",
                stacklevel=2,
            )
        if self.has_thermal and temp is None:
            warnings.warn(
                "the model corrects for temperature, but the data has no temperature; every row is corrected as at the reference temperature and marked no-temperature",
                stacklevel=2,
            )
        out, gyro_out, valid, outside, codes, refusals, predicted = self._inner.correct_columns(accel, g, t, temp, plan)
        sd, better = (None, None) if predicted is None else predicted
        return Corrected(
            accel=out,
            gyro=gyro_out,
            valid=valid,
            outside_training_range=outside,
            status_codes=codes,
            refused=dict(refusals),
            axes=tuple(self.axes),
            columns=tuple(plan.names),
            accel_to_mps2=plan.accel_to_mps2,
            gyro_to_radps=plan.gyro_to_radps,
            accel_unit=plan.accel_unit,
            gyro_unit=plan.gyro_unit or "radps",
            index=index,
            predicted_sd=sd,
            predicted_better=better,
        )


def load_corrector(path: PathLike) -> Corrector:
    """Loads a saved corrector (model.json from ``spincal calibrate``, ``train`` or ``static -o``).

    A file of another ``format_version`` or with an invalid field raises :class:`ModelError`
    naming the field.

    Example::

        >>> c = spincal.load_corrector("cal/model.json")                          # doctest: +SKIP
        >>> c.kind, c.axes                                                        # doctest: +SKIP
        ('ann', ['x', 'y'])
    """
    return Corrector(_spincal.Corrector.load(os.fspath(path)))


def correct(model: Union[Corrector, PathLike], data: Any, **options: Any) -> Corrected:
    """Applies a saved corrector (a :class:`Corrector` or the path of model.json) to a
    DataFrame, an array, a recording or a file, as :meth:`Corrector.correct`.

    Example::

        >>> out = spincal.correct("cal/model.json", frame)                       # doctest: +SKIP
        >>> out.to_pandas().head()                                                # doctest: +SKIP
    """
    corrector = model if isinstance(model, Corrector) else load_corrector(model)
    return corrector.correct(data, **options)


def _write_files(files: Sequence[Tuple[str, str]], force: bool) -> None:
    """Writes each (path, text) through the library's writer, as the CLI does: all are checked
    first, and an existing file that spincal did not write (or that changed since it did) raises
    :class:`UsageError` unless ``force``, before anything is written; each file goes through a
    temporary file and is recorded in its folder's ``.spincal-outputs.json``, so writing again
    into the same folder just works. Missing folders are made."""
    _spincal.write_outputs([(os.fspath(p), t) for p, t in files], force)


class Calibration:
    """A finished calibration, of a campaign file or of turntable recordings: ``result``
    (results.json as a :class:`CampaignResult`, the one result of every calibration, with the
    paper's figures as ``result.paper`` where its protocol ran), ``corrector`` (the saved
    :class:`Corrector`, or None when no corrector held on every held-out condition;
    ``result.verdict`` says why), :meth:`report_html` and :meth:`write`; where the paper's
    protocol ran (:func:`calibrate`), also the ``references`` and ``corrected`` arrays."""

    __slots__ = ("_inner", "_texts", "result", "corrector")

    def __init__(self, inner: "_spincal.Calibration"):
        self._inner: Optional["_spincal.Calibration"] = inner
        self._texts: Optional[Tuple[str, Optional[str]]] = None
        self.result = CampaignResult._from_json(inner.result_json())
        saved = inner.corrector()
        self.corrector = None if saved is None else Corrector(saved)

    @classmethod
    def _from_texts(cls, results: str, model: Optional[str]) -> "Calibration":
        """A calibration made elsewhere (a fleet's worker), from its results.json and model.json."""
        cal = cls.__new__(cls)
        cal._inner = None
        cal._texts = (results, model)
        cal.result = CampaignResult._from_json(results)
        cal.corrector = None if model is None else Corrector(_spincal.Corrector.from_json(model, "model.json"))
        return cal

    def _signals(self) -> "_spincal.Calibration":
        if self._inner is None:
            raise Error("references and corrected exist where the paper's protocol ran (spincal.calibrate on recordings); this calibration ran a campaign file")
        return self._inner

    @property
    def references(self) -> List[np.ndarray]:
        """The reference acceleration (the turntable's physics), (n, 3) m/s² per recording; where
        the paper's protocol ran."""
        return self._signals().references()

    @property
    def corrected(self) -> np.ndarray:
        """The saved corrector applied to the first recording (the recording itself when nothing
        was saved), (n, 3) m/s²; where the paper's protocol ran."""
        return self._signals().corrected()

    def to_dict(self) -> Dict[str, Any]:
        """results.json's content."""
        return self.result.to_dict()

    def _files(self) -> List[Tuple[str, str]]:
        if self._inner is not None:
            return self._inner.files()
        results, model = cast(Tuple[str, Optional[str]], self._texts)
        return _spincal.campaign_files(results, model)

    def report_html(self) -> str:
        """report.html as ``spincal calibrate`` writes it: whether model.json can be trusted and
        where, every corrector on held-out conditions, the sensor model, the gyroscope, and the
        paper's sections where its protocol ran."""
        return dict(self._files())["report.html"]

    def write(self, folder: PathLike, *, force: bool = False) -> None:
        """Writes what ``spincal calibrate`` writes into ``folder`` (created): model.json,
        imucal.json and the imu_tk ``.calib`` files when a corrector was saved, results.json and
        report.html. Each file is written to a temporary name and renamed; a file there that
        spincal did not write raises :class:`UsageError` unless ``force``, and then nothing is
        written."""
        folder = os.fspath(folder)
        _write_files([(os.path.join(folder, name), text) for name, text in self._files()], force)

    def __repr__(self) -> str:
        return f"Calibration(unit={self.result.unit!r}, saved={self.result.saved!r})"


def calibrate_campaign(campaign: PathLike, *, progress: Progress = False) -> Calibration:
    """Calibrates one unit from its campaign file (TOML), as ``spincal calibrate --campaign``:
    one sensor model fitted jointly to every still pose and turntable run, correctors scored on
    held-out conditions.

    Example::

        >>> spincal.simulate_campaign("unit7", seed=7)                              # doctest: +SKIP
        >>> cal = spincal.calibrate_campaign("unit7/campaign.toml", progress=True)  # doctest: +SKIP
        >>> [(p.name, p.value, p.std_error) for p in cal.result.joint.sensor_params][:2]  # doctest: +SKIP
    """
    with _progress(progress, "campaign") as callback:
        inner = _spincal.calibrate_campaign(os.fspath(campaign), progress=callback)
    return Calibration(inner)


def calibrate(
    recordings: Sequence[RecordingLike],
    *,
    rpm: Optional[float] = None,
    radius_m: Optional[float] = None,
    radius_tol_m: Optional[float] = None,
    objective_axes: Optional[str] = None,
    drift: Optional[bool] = None,
    fit_offsets: Optional[bool] = None,
    separate_radii: Optional[bool] = None,
    gravity_mps2: Optional[float] = None,
    range_g: Optional[float] = None,
    sweep: Optional[str] = None,
    hidden: Optional[Orders] = None,
    restarts: Optional[int] = None,
    sweep_hessian_samples: Optional[int] = None,
    correct_axes: Optional[Axes] = None,
    delays: Optional[int] = None,
    seed: Optional[int] = None,
    arx: Optional[Orders] = None,
    bj: Optional[Orders] = None,
    narx: Optional[Orders] = None,
    hw: Optional[Orders] = None,
    params: Optional[Mapping[str, Any]] = None,
    progress: Progress = False,
    sweep_runner: Optional[Callable[[str, int], Sequence[str]]] = None,
) -> Calibration:
    """Calibrates accelerometer data with the turntable as the reference, as ``spincal calibrate``
    (the same settings, the same defaults, the same results.json numbers). For a campaign file
    use :func:`calibrate_campaign`.

    ``recordings``: a list of :class:`Recording` objects, paths or DataFrames (turntable
    sessions). Every setting left None is the library's default (:func:`default_params`, what
    ``spincal calibrate`` runs). ``sweep``: ``"small"`` (default), ``"full"`` (the paper's 165
    architectures) or ``"none"``; ``hidden=[10, 6]`` fixes one architecture; ``restarts`` per
    architecture; ``correct_axes=["x", "y"]``; ``arx=[6, 8, 1]``, ``bj``, ``narx``, ``hw``: the
    system-identification models' orders. ``params`` changes any other setting of the library's
    ``Params`` by its name there, nested as :func:`default_params` shows (e.g.
    ``params={"lm": {"max_epochs": 50}, "division": {"mode": "interleaved", ...}}``); an unknown
    or unusable setting raises :class:`UsageError` naming its path. ``progress=True`` shows a
    tqdm bar; Ctrl-C stops the work.

    ``sweep_runner``: who runs the network sweep's jobs (architectures × restarts), called as
    ``sweep_runner(jobs_json, n_jobs)`` and returning every job's run as text, in any order, from
    ``spincal._spincal.run_sweep_jobs(jobs_json, job_indices)`` wherever that runs;
    :func:`spincal.ray.sweep_runner` spreads them over a Ray cluster. The result equals the local
    sweep's, bit for bit (only the timings differ).

    Returns a :class:`Calibration` (``.result``, ``.corrector``, ``.write(folder)``).

    Example::

        >>> rec, truth = spincal.simulate(seed=3)
        >>> cal = spincal.calibrate([rec], radius_m=0.10, hidden=[4], restarts=1)
        >>> cal.result.saved is None                  # one recording holds no second condition
        True
        >>> cal.result.paper.best_on_validation in {row.model for row in cal.result.paper.comparison}
        True
    """
    if isinstance(recordings, (str, bytes, os.PathLike)) or _frames.frame_kind(recordings) is not None:
        path = recordings if isinstance(recordings, (str, os.PathLike)) else None
        if path is not None and os.fspath(path).endswith(".toml"):
            raise UsageError(f"{os.fspath(path)}: a campaign file: use spincal.calibrate_campaign")
        recordings = [recordings]
    recs = [_as_recording(r) for r in recordings]
    fit = fit_changes(
        rpm=rpm,
        radius_m=radius_m,
        radius_tol_m=radius_tol_m,
        objective_axes=objective_axes,
        drift=drift,
        fit_offsets=fit_offsets,
        separate_radii=separate_radii,
        gravity_mps2=gravity_mps2,
        range_g=range_g,
    )
    changes = calibration_changes(
        params,
        fit,
        sweep=sweep,
        hidden=hidden,
        restarts=restarts,
        sweep_hessian_samples=sweep_hessian_samples,
        correct_axes=correct_axes,
        delays=delays,
        seed=seed,
    )
    sysid = [(kind, orders_list(orders, kind)) for kind, orders in (("arx", arx), ("bj", bj), ("narx", narx), ("hw", hw)) if orders is not None]
    with _progress(progress, "calibrating") as callback:
        inner = _spincal.calibrate(
            recs,
            params_json=json.dumps(changes) if changes else None,
            sysid=sysid or None,
            progress=callback,
            sweep_runner=sweep_runner,
        )
    return Calibration(inner)


def static_calibration(
    data: RecordingLike,
    *,
    parameters: int = 9,
    gravity_mps2: Optional[float] = None,
    init_s: Optional[float] = None,
    window_s: Optional[float] = None,
    threshold_factor: Optional[float] = None,
    min_interval_s: Optional[float] = None,
) -> Tuple[StaticResult, Corrector]:
    """Classic calibration from still poses (6, 9 or 12 parameters), the one call ``spincal
    static`` makes: still intervals found by moving variance, then bias, scale and misalignment
    fitted to gravity, and the recording's own gyro (when it has one) from those poses and the
    rotations between them. A setting left ``None`` takes ``spincal static``'s default (standard
    gravity, a 3 s initial still period, a 1 s window, threshold ×3, intervals of 1 s or more).
    A model the poses leave a parameter of poorly determined is never returned: the next smaller
    one they determine is (``result.reduced`` says why), or :class:`Error` when none is.
    Returns the :class:`StaticResult` and the ``static`` :class:`Corrector`.

    Example::

        >>> result, corrector = spincal.static_calibration("poses.csv")           # doctest: +SKIP
        >>> result.fit.calibration.bias                                           # doctest: +SKIP
    """
    rec = _as_recording(data)
    text, corrector = _spincal.static_calibration(
        rec,
        parameters=parameters,
        gravity_mps2=gravity_mps2,
        init_s=init_s,
        window_s=window_s,
        threshold_factor=threshold_factor,
        min_interval_s=min_interval_s,
    )
    return StaticResult._from_json(text), Corrector(corrector)


def allan(data: Union[npt.ArrayLike, RecordingLike], dt_s: Optional[float] = None, *, per_decade: int = 10) -> AllanResult:
    """Overlapping Allan deviation of a still recording (or an (n, 3) array sampled every
    ``dt_s`` seconds), with the noise density, bias instability and where the floor lies.

    Example::

        >>> a = np.random.default_rng(1).normal(0, 0.01, (100_000, 3))
        >>> r = spincal.allan(a, dt_s=0.01)
        >>> 0.0009 < r.noise.noise_density[0] < 0.0011
        True
    """
    if isinstance(data, (np.ndarray, list, tuple)):
        if dt_s is None:
            raise UsageError("dt_s is needed with an array (the sampling interval, s)")
        accel = _frames.array_columns(data, "data")
    else:
        rec = _as_recording(data)
        accel = rec.accel
        dt_s = dt_s if dt_s is not None else 1.0 / rec.sample_rate_hz
    return AllanResult._from_json(_spincal.allan(np.asarray(accel, dtype=np.float64), float(dt_s), per_decade=per_decade))


def sensitivity(
    *,
    radius_m: float = 0.10,
    tilt_deg: float = 5.0,
    rpm: float = 33.3,
    beta_deg: float = 0.0,
    gravity_mps2: float = 9.80665,
    vary_percent: float = 15.0,
) -> List[Result]:
    """The paper's Table 1 at any nominal values: each parameter moved by ±``vary_percent`` and
    its effect on the mean and amplitude of a_x and a_y (in g).

    Example::

        >>> rows = spincal.sensitivity(radius_m=0.10, tilt_deg=5, rpm=33.3, vary_percent=15)
        >>> rows[0].parameter
        'r'
    """
    text = _spincal.sensitivity(
        radius_m=radius_m,
        tilt_deg=tilt_deg,
        rpm=rpm,
        beta_deg=beta_deg,
        gravity_mps2=gravity_mps2,
        vary_percent=vary_percent,
    )
    return [Result(row) for row in json.loads(text)]


def simulate_fleet(
    folder: PathLike, *, seed: int = 7, setup: Optional[Mapping[str, Any]] = None
) -> Tuple[List[str], List[Truth]]:
    """Simulates a fleet of units scattered around a nominal sensor (some made faulty) into
    ``folder``: one campaign folder per unit (``unit-01``, …) and ``fleet-truth.json``.
    ``setup`` changes the library's FleetSetup: ``units``, ``faulty`` (0-based indices),
    ``spread``, ``fault``, ``campaign``. Returns the unit folders and each unit's truth
    (``name``, ``faulty``, ``truth``).

    Example::

        >>> folders, truths = spincal.simulate_fleet("fleet", setup={"units": 8, "faulty": [5]})  # doctest: +SKIP
        >>> truths[5].faulty                                                                     # doctest: +SKIP
        True
    """
    folders, text = _spincal.simulate_fleet(os.fspath(folder), seed, None if setup is None else json.dumps(dict(setup)))
    return [os.fspath(f) for f in folders], [Truth(t) for t in json.loads(text)]


def calibrate_unit(source: PathLike, *, progress: Progress = False) -> Calibration:
    """Calibrates one unit of a fleet (a campaign file, or a folder holding ``campaign.toml``)
    on one thread, exactly as ``spincal calibrate --campaign`` and as each task of
    :func:`spincal.ray.calibrate_fleet` does.

    Example::

        >>> cal = spincal.calibrate_unit("fleet/unit-01")                         # doctest: +SKIP
        >>> cal.result.saved                                                      # doctest: +SKIP
        'physical-linear'
    """
    with _progress(progress, "unit") as callback:
        unit, results, model = _spincal.calibrate_unit(os.fspath(source), progress=callback)
    return Calibration._from_texts(results, model)
