"""spincal: turntable-referenced IMU accelerometer calibration, from Python.

The science is the spincal Rust library (the same code as the ``spincal`` command); this package
converts arguments and results. Signals are numpy arrays in SI units (s, m/s², rad/s); results
are typed objects with attributes and ``to_dict()``; every error is a ``spincal.Error`` carrying the
library's message (file, line, column, key or parameter at fault). Long work releases the GIL,
stops on Ctrl-C (``KeyboardInterrupt``) and shows a tqdm bar with ``progress=True``.

Example::

    import spincal
    rec, truth = spincal.simulate(seed=7)
    cal = spincal.calibrate([rec], sweep="none", hidden="4", restarts=1)
    print(cal.result.chosen)
    corrected = cal.corrector.correct(rec.accel)
    cal.write("cal")            # model.json, results.json, report.html

Fleets on a Ray cluster: ``spincal.ray`` (``pip install "spincal[ray]"``).
"""

from __future__ import annotations

import json
import os
from contextlib import contextmanager
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _spincal
from ._results import (
    AllanResult,
    CalibrationResult,
    CampaignResult,
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
    "CampaignCalibration",
    "Result",
    "TurntableFit",
    "CalibrationResult",
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
RecordingLike = Union[Recording, PathLike, bytes, Any]


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


def _is_dataframe(value: Any) -> bool:
    return type(value).__name__ == "DataFrame" and hasattr(value, "columns") and hasattr(value, "to_csv")


def _dataframe_bytes(frame: Any) -> bytes:
    """A DataFrame as CSV text, so that the library finds its columns by name exactly as the CLI
    does (numbers are written with Python's round-trip repr: no value changes)."""
    return frame.to_csv(index=False, float_format=None).encode("utf-8")


def read(
    source: Union[PathLike, bytes, Any],
    *,
    name: Optional[str] = None,
    format: Optional[str] = None,
    columns: Optional[str] = None,
    accel_unit: Optional[str] = None,
    time_unit: Optional[str] = None,
    gyro_unit: Optional[str] = None,
    sample_rate_hz: Optional[float] = None,
    accel_scale: Optional[float] = None,
    retime: bool = False,
) -> Recording:
    """Reads a recording in any format spincal reads: delimited text, imu_tk, imucal, MPU-6050,
    phyphox, the 3DM-GX1 binary stream (detected, or named by ``format``).

    ``source`` is a path, the file's bytes (``name`` then names it in errors), or a pandas
    DataFrame (columns found by name as the CLI does: ``t``/``time``, ``ax``/``acc_x``/``ax_g`` …;
    or given as ``columns="t,ax,ay,az"``). Units as the CLI: from the column names (``_g``,
    ``_ms``) or ``accel_unit="g"``, ``time_unit="ms"``. Returns a :class:`Recording` in SI units:
    ``rec.time`` (n,), ``rec.accel`` (n, 3) m/s², ``rec.gyro`` (n, 3) rad/s or None.

    Raises :class:`FormatError` naming the file, line and column at fault.

    Example::

        >>> rec = spincal.read("rec33.csv", accel_unit="g")        # doctest: +SKIP
        >>> rec.accel.shape, rec.sample_rate_hz                      # doctest: +SKIP
        ((12000, 3), 100.0)
    """
    if _is_dataframe(source):
        source, name = _dataframe_bytes(source), name or "<DataFrame>"
    elif isinstance(source, (bytearray, memoryview)):
        source = bytes(source)
    elif not isinstance(source, bytes):
        source = os.fspath(source)
    return _spincal.read(
        source,
        name=name,
        format=format,
        columns=columns,
        accel_unit=accel_unit,
        time_unit=time_unit,
        gyro_unit=gyro_unit,
        sample_rate_hz=sample_rate_hz,
        accel_scale=accel_scale,
        retime=retime,
    )


def recording(
    time: Any, accel: Any, gyro: Any = None, *, name: str = "array"
) -> Recording:
    """A :class:`Recording` from arrays: ``time`` (n,) in s, ``accel`` (n, 3) in m/s², optional
    ``gyro`` (n, 3) in rad/s. Time must not go backwards (:class:`FormatError` names the sample).

    Example::

        >>> t = np.arange(1000) / 100.0
        >>> a = np.tile([0.0, 0.0, 9.81], (1000, 1))
        >>> spincal.recording(t, a).sample_rate_hz
        100.0
    """
    t = np.ascontiguousarray(time, dtype=np.float64)
    a = np.asarray(accel, dtype=np.float64)
    g = None if gyro is None else np.asarray(gyro, dtype=np.float64)
    if a.ndim != 2 or a.shape[1:] != (3,):
        raise UsageError(f"accel: expected an (n, 3) array, got shape {a.shape}")
    return _spincal.recording(t, a, g, name=name)


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
    radius_tol_m: float = 0.002,
    objective_axes: str = "xyz",
    drift: bool = True,
    fit_offsets: bool = True,
    separate_radii: bool = False,
    gravity_mps2: float = 9.80665,
    range_g: Optional[float] = None,
    bounds: Optional[Mapping[str, Tuple[float, float]]] = None,
    progress: Progress = False,
) -> TurntableFit:
    """Fits the turntable model (ω²r plus tilted gravity, offsets, drift) to one or more
    recordings, as ``spincal fit``: bounded Nelder–Mead then Levenberg–Marquardt, standard errors,
    correlations, and what the data did not determine.

    ``recordings``: :class:`Recording` objects, paths or DataFrames. ``bounds`` replaces a
    parameter's bounds by name (SI units). Returns a :class:`TurntableFit`; its ``references``
    are the reference accelerations (n, 3) in m/s².

    Example::

        >>> rec, truth = spincal.simulate()
        >>> fit = spincal.fit_turntable([rec], rpm=33.3)
        >>> abs(fit.recordings[0].session.omega_radps / truth.session.omega_radps - 1) < 1e-3
        True
    """
    recs = [_as_recording(r) for r in recordings]
    with _progress(progress, "turntable fit") as callback:
        text, references = _spincal.fit_turntable(
            recs,
            rpm=rpm,
            radius_m=radius_m,
            radius_tol_m=radius_tol_m,
            objective_axes=objective_axes,
            drift=drift,
            fit_offsets=fit_offsets,
            separate_radii=separate_radii,
            gravity_mps2=gravity_mps2,
            range_g=range_g,
            bounds=[(k, float(lo), float(hi)) for k, (lo, hi) in (bounds or {}).items()],
            progress=callback,
        )
    return TurntableFit(json.loads(text), references)


class Corrected(Result):
    """Corrected samples: ``accel`` (n, 3) m/s², ``valid`` (n,) bool (False for the first samples
    without a full delay history and for samples outside a network's training range, both passed
    through), ``outside_training_range`` (n,) bool (a network is not applied there; a physical
    model still corrects)."""

    __slots__ = ("accel", "valid", "outside_training_range")

    def __init__(self, accel: np.ndarray, valid: np.ndarray, outside: np.ndarray):
        super().__init__({"rows": int(accel.shape[0]), "outside_training_range": int(outside.sum())})
        object.__setattr__(self, "accel", accel)
        object.__setattr__(self, "valid", valid)
        object.__setattr__(self, "outside_training_range", outside)

    def to_dict(self) -> Dict[str, Any]:
        return {
            "accel": self.accel.tolist(),
            "valid": self.valid.tolist(),
            "outside_training_range": self.outside_training_range.tolist(),
        }


class Corrector:
    """A saved corrector (model.json) of any kind: ``ann``, ``linear``, ``static``,
    ``physical`` or ``physical_ann``. Load with :func:`load_corrector`; apply with :meth:`correct`.

    Example::

        >>> c = spincal.load_corrector("cal/model.json")                          # doctest: +SKIP
        >>> out = c.correct(rec.accel)                                            # doctest: +SKIP
        >>> out.accel.shape                                                       # doctest: +SKIP
        (12000, 3)
    """

    __slots__ = ("_inner",)

    def __init__(self, inner: "_spincal.Corrector"):
        self._inner = inner

    @property
    def kind(self) -> str:
        """``ann``, ``linear``, ``static``, ``physical`` or ``physical_ann``."""
        return self._inner.kind

    @property
    def axes(self) -> List[str]:
        """The axes it changes; the others pass through."""
        return list(self._inner.axes)

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

    def save(self, path: PathLike) -> None:
        """Writes model.json (temporary file, then renamed)."""
        self._inner.save(os.fspath(path))

    def correct(self, data: Union[np.ndarray, Recording, PathLike, Any], **read_options: Any) -> Corrected:
        """Corrects samples in time order, exactly as ``spincal correct`` does row by row.

        ``data``: an (n, 3) float64 array in m/s² (read in place whatever its strides; other
        dtypes are converted), a :class:`Recording`, a DataFrame or a path (read with
        ``read_options`` as :func:`read`). Returns :class:`Corrected`.

        Example::

            >>> out = corrector.correct(np.array([[0.1, 0.0, 9.8]]))              # doctest: +SKIP
        """
        if isinstance(data, np.ndarray):
            accel = data if data.dtype == np.float64 else data.astype(np.float64)
        else:
            accel = _as_recording(data, read_options).accel
        if accel.ndim != 2 or accel.shape[1:] != (3,):
            raise UsageError(f"accel: expected an (n, 3) array, got shape {accel.shape}")
        out, valid, outside = self._inner.correct(accel)
        return Corrected(out, valid, outside)


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


def correct(model: Union[Corrector, PathLike], data: Any, **read_options: Any) -> Corrected:
    """Applies a saved corrector to an array, a recording, a DataFrame or a file.

    Example::

        >>> out = spincal.correct("cal/model.json", "rec33.csv")                  # doctest: +SKIP
        >>> out.accel[:3]                                                         # doctest: +SKIP
    """
    corrector = model if isinstance(model, Corrector) else load_corrector(model)
    return corrector.correct(data, **read_options)


class Calibration:
    """A finished calibration: ``result`` (results.json as a :class:`CalibrationResult`),
    ``corrector`` (the saved :class:`Corrector`, or None when every corrector was worse than
    uncorrected on another recording; ``result.verdict`` says why), ``references`` and ``corrected`` arrays, and
    :meth:`write` for model.json, results.json and report.html."""

    __slots__ = ("_inner", "result", "corrector")

    def __init__(self, inner: "_spincal.Calibration"):
        self._inner = inner
        self.result = CalibrationResult._from_json(inner.result_json())
        saved = inner.corrector()
        self.corrector = None if saved is None else Corrector(saved)

    @property
    def references(self) -> List[np.ndarray]:
        """The reference acceleration (the turntable's physics), (n, 3) m/s² per recording."""
        return self._inner.references()

    @property
    def corrected(self) -> np.ndarray:
        """The chosen corrector applied to the first recording, (n, 3) m/s²."""
        return self._inner.corrected()

    def to_dict(self) -> Dict[str, Any]:
        """results.json's content."""
        return self.result.to_dict()

    def write(self, folder: PathLike) -> None:
        """Writes model.json, results.json and report.html into ``folder`` (as the CLI)."""
        self._inner.write(os.fspath(folder))

    def __repr__(self) -> str:
        return f"Calibration(chosen={self.result.chosen!r}, best_overall={self.result.best_overall!r})"


class CampaignCalibration:
    """A finished campaign calibration: ``result`` (:class:`CampaignResult`), ``corrector`` (or
    None when no corrector held on every held-out condition), :meth:`report_html` and
    :meth:`write`."""

    __slots__ = ("result", "corrector", "_results_json", "_model_json")

    def __init__(self, inner: Optional["_spincal.CampaignCalibration"]):
        if inner is not None:
            saved = inner.corrector()
            self._set(inner.result_json(), None if saved is None else saved.to_json())

    def _set(self, results: str, model: Optional[str]) -> None:
        self._results_json = results
        self._model_json = model
        self.result = CampaignResult._from_json(results)
        self.corrector = None if model is None else Corrector(_spincal.Corrector.from_json(model, "model.json"))

    @classmethod
    def _from_texts(cls, results: str, model: Optional[str]) -> "CampaignCalibration":
        cal = cls(None)
        cal._set(results, model)
        return cal

    def to_dict(self) -> Dict[str, Any]:
        """results.json's content."""
        return self.result.to_dict()

    def report_html(self) -> str:
        """report.html as ``spincal calibrate --campaign`` writes it: the verdict, every
        corrector on held-out conditions (table and plot), the sensor model, the gyroscope."""
        return dict(_spincal.campaign_files(self._results_json, self._model_json))["report.html"]

    def write(self, folder: PathLike) -> None:
        """Writes what ``spincal calibrate --campaign`` writes into ``folder`` (created):
        model.json (when a corrector was saved), results.json, report.html, imucal.json and the
        imu_tk ``.calib`` files. Each file is written to a temporary name and renamed."""
        folder = os.fspath(folder)
        os.makedirs(folder, exist_ok=True)
        for name, text in _spincal.campaign_files(self._results_json, self._model_json):
            tmp = os.path.join(folder, f".{name}.tmp")
            with open(tmp, "w") as f:
                f.write(text)
            os.replace(tmp, os.path.join(folder, name))

    def __repr__(self) -> str:
        return f"CampaignCalibration(unit={self.result.unit!r}, saved={self.result.saved!r})"


def calibrate_campaign(campaign: PathLike, *, progress: Progress = False) -> CampaignCalibration:
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
    return CampaignCalibration(inner)


def calibrate(
    recordings: Union[Sequence[RecordingLike], PathLike],
    *,
    rpm: Optional[float] = None,
    radius_m: Optional[float] = None,
    radius_tol_m: float = 0.002,
    objective_axes: str = "xyz",
    drift: bool = True,
    fit_offsets: bool = True,
    separate_radii: bool = False,
    gravity_mps2: float = 9.80665,
    range_g: Optional[float] = None,
    sweep: Optional[str] = None,
    hidden: Optional[str] = None,
    restarts: int = 3,
    sweep_hessian_samples: int = 8192,
    correct_axes: str = "x,y",
    delays: int = 0,
    seed: int = 1,
    arx: str = "6,8,1",
    bj: str = "4,4,4,4,1",
    narx: str = "2,2,1",
    hw: str = "2,3,1",
    progress: Progress = False,
    sweep_runner: Optional[Callable[[str, int], Sequence[str]]] = None,
) -> Union[Calibration, CampaignCalibration]:
    """Calibrates accelerometer data with the turntable as the reference, as ``spincal calibrate``
    (same arguments, same defaults, same results.json numbers).

    ``recordings``: a list of :class:`Recording` objects, paths or DataFrames (turntable
    sessions), or the path of a campaign file (``*.toml``, then see :func:`calibrate_campaign`).
    ``sweep``: ``"small"`` (default), ``"full"`` (the paper's 165 architectures) or ``"none"``
    with ``hidden="10,6"``. ``progress=True`` shows a tqdm bar; Ctrl-C stops the work.
    ``sweep_runner``: who runs the network sweep's jobs (architectures × restarts), called as
    ``sweep_runner(jobs_json, n_jobs)`` and returning every job's run as text, in any order, from
    ``spincal._spincal.run_sweep_jobs(jobs_json, job_indices)`` wherever that runs;
    :func:`spincal.ray.sweep_runner` spreads them over a Ray cluster. The result equals the local
    sweep's, bit for bit (only the timings differ).

    Returns a :class:`Calibration` (``.result``, ``.corrector``, ``.write(folder)``).

    Example::

        >>> rec, truth = spincal.simulate(seed=3)
        >>> cal = spincal.calibrate([rec], radius_m=0.10, sweep="none", hidden="4", restarts=1)
        >>> cal.result.chosen in {row.model for row in cal.result.comparison}
        True
    """
    if isinstance(recordings, (str, os.PathLike)):
        path = os.fspath(recordings)
        if path.endswith(".toml"):
            return calibrate_campaign(path, progress=progress)
        recordings = [path]
    recs = [_as_recording(r) for r in recordings]
    with _progress(progress, "calibrating") as callback:
        inner = _spincal.calibrate(
            recs,
            rpm=rpm,
            radius_m=radius_m,
            radius_tol_m=radius_tol_m,
            objective_axes=objective_axes,
            drift=drift,
            fit_offsets=fit_offsets,
            separate_radii=separate_radii,
            gravity_mps2=gravity_mps2,
            range_g=range_g,
            sweep=sweep,
            hidden=hidden,
            restarts=restarts,
            sweep_hessian_samples=sweep_hessian_samples,
            correct_axes=correct_axes,
            delays=delays,
            seed=seed,
            arx=arx,
            bj=bj,
            narx=narx,
            hw=hw,
            progress=callback,
            sweep_runner=sweep_runner,
        )
    return Calibration(inner)


def static_calibration(
    data: RecordingLike,
    *,
    parameters: int = 9,
    gravity_mps2: float = 9.80665,
    init_s: float = 2.0,
    window_s: float = 1.0,
    threshold_factor: float = 3.0,
    min_interval_s: float = 2.0,
) -> Tuple[StaticResult, Corrector]:
    """Classic calibration from still poses (6, 9 or 12 parameters), as ``spincal static``:
    still intervals found by moving variance, then bias, scale and misalignment fitted to
    gravity. Returns the :class:`StaticResult` and the ``static`` :class:`Corrector`.

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


def allan(data: Union[np.ndarray, RecordingLike], dt_s: Optional[float] = None, *, per_decade: int = 10) -> AllanResult:
    """Overlapping Allan deviation of a still recording (or an (n, 3) array sampled every
    ``dt_s`` seconds), with the noise density, bias instability and where the floor lies.

    Example::

        >>> a = np.random.default_rng(1).normal(0, 0.01, (100_000, 3))
        >>> r = spincal.allan(a, dt_s=0.01)
        >>> 0.0009 < r.noise.noise_density[0] < 0.0011
        True
    """
    if isinstance(data, np.ndarray):
        if dt_s is None:
            raise UsageError("dt_s is needed with an array (the sampling interval, s)")
        accel = data
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


def calibrate_unit(source: PathLike, *, progress: Progress = False) -> CampaignCalibration:
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
    return CampaignCalibration._from_texts(results, model)
