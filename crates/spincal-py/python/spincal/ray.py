"""Fleets on a Ray cluster: one task per unit, the fleet table and its outliers from the library.

Install with ``pip install "spincal[ray]"``. Connect to a cluster first (``ray.init()`` or
``ray.init(address="auto")``); without one, :func:`calibrate_fleet` starts a local one as
``ray.init()`` does. The workers need the ``spincal`` package: in the cluster's image, or shipped
with the job as the wheel, ``ray.init(address="auto", runtime_env={"py_modules": ["dist/spincal-….whl"]})``
(Ray uploads a local wheel and installs it on each node that runs a task).

How the work moves:

- The driver reads each unit's campaign file, finds every file it reads (recordings, truth files)
  and ships their bytes with the task: workers need no shared filesystem.
- Each task runs on one CPU (``num_cpus=1``) and one thread (``RAYON_NUM_THREADS=1``, and the
  library's one-thread pool per unit): no nested oversubscription.
- A task writes the files into a private temporary folder, calibrates the unit exactly as
  ``spincal calibrate --campaign`` does and returns results.json and model.json as text. The
  work is deterministic, so a retried task (a worker lost) returns the same result.
- A unit that fails (a bad campaign file, a missing recording, a fit that cannot be made, a
  worker lost more often than ``max_retries``) is reported in its :class:`UnitResult`; the other
  units' results are kept.
- The fleet table (every sensor parameter with its standard error per unit, fleet statistics,
  outlier flags) is made by the library's ``spincal::fleet`` from the units' results.

Example::

    import ray, spincal.ray
    ray.init(address="auto")
    fleet = spincal.ray.calibrate_fleet(["units/imu-01", "units/imu-02", ...], progress=True)
    print(fleet.flagged_units)
    fleet.write("fleet-out")        # per unit results.json, report.html, model.json …; fleet.json, fleet.csv
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import ray

from . import Calibration, CampaignResult, Corrector, Error, FormatError, Result, UsageError, _spincal, _write_files
from . import calibrate as _calibrate_locally

__all__ = ["UnitResult", "FleetResult", "calibrate_fleet", "unit_payload", "calibrate", "sweep_runner"]

PathLike = Union[str, "os.PathLike[str]"]


def unit_payload(source: PathLike) -> Tuple[str, str, Dict[str, bytes]]:
    """What a worker needs to calibrate a unit: (the folder the files are relative to, the
    campaign file relative to it, {relative path: bytes} of every file the campaign reads).

    Raises :class:`spincal.FormatError` when the campaign file cannot be read or names a file
    that does not exist.

    Example::

        >>> root, campaign, files = unit_payload("units/imu-01")                 # doctest: +SKIP
        >>> campaign, sorted(files)[:2]                                           # doctest: +SKIP
        ('campaign.toml', ['campaign.toml', 'run-1-33rpm-r0.060-out+x-up+z.csv'])
    """
    campaign, inputs = _spincal.campaign_inputs(os.fspath(source))
    paths = [os.path.abspath(os.fspath(p)) for p in inputs]
    root = os.path.commonpath([os.path.dirname(p) for p in paths])
    files: Dict[str, bytes] = {}
    for p in paths:
        try:
            with open(p, "rb") as f:
                files[os.path.relpath(p, root)] = f.read()
        except OSError as e:
            raise FormatError(f"{p}: cannot read: {e.strerror}") from None
    return root, os.path.relpath(os.path.abspath(os.fspath(campaign)), root), files


def _calibrate_shipped(label: str, root: str, campaign: str, files: Mapping[str, bytes]) -> Dict[str, Any]:
    """The task body: the shipped files in a private folder, the unit calibrated on one thread."""
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="spincal-unit-") as tmp:
        for name, data in files.items():
            path = os.path.join(tmp, name)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "wb") as f:
                f.write(data)
        try:
            unit, results, model = _spincal.calibrate_unit(os.path.join(tmp, campaign))
            # Results name the files read: name the driver's, as calibrating in place would.
            here, there = json.dumps(tmp)[1:-1], json.dumps(root)[1:-1]
            results = results.replace(here, there)
            model = None if model is None else model.replace(here, there)
            outcome: Dict[str, Any] = {"unit": unit, "results_json": results, "model_json": model, "error": None}
        except Error as e:
            # The message names the worker's copy; name the driver's files instead.
            outcome = {"error": f"{type(e).__name__}: {str(e).replace(tmp, root)}"}
    outcome.update(label=label, seconds=time.perf_counter() - started, pid=os.getpid(), node=_node())
    return outcome


def _node() -> str:
    try:
        return ray.get_runtime_context().get_node_id()
    except Exception:  # pragma: no cover - outside a Ray worker
        return "local"


_remote_calibrate = ray.remote(_calibrate_shipped)


class UnitResult:
    """One unit of a fleet: ``label`` (its name in the fleet), ``source``, ``ok``, ``result`` (a
    :class:`spincal.CampaignResult`, or None), ``corrector`` (or None), ``error`` (the located
    message, or None), ``seconds`` (the task's wall time) and ``node``."""

    __slots__ = ("label", "source", "result", "corrector", "error", "seconds", "node", "_results_json", "_model_json")

    def __init__(self, label: str, source: str, outcome: Mapping[str, Any]):
        self.label = label
        self.source = source
        self.error: Optional[str] = outcome.get("error")
        self.seconds: Optional[float] = outcome.get("seconds")
        self.node: Optional[str] = outcome.get("node")
        self._results_json: Optional[str] = outcome.get("results_json")
        self._model_json: Optional[str] = outcome.get("model_json")
        self.result = None if self._results_json is None else CampaignResult._from_json(self._results_json)
        self.corrector = (
            None if self._model_json is None else Corrector(_spincal.Corrector.from_json(self._model_json, f"{label}/model.json"))
        )

    @property
    def ok(self) -> bool:
        return self.error is None

    def to_dict(self) -> Dict[str, Any]:
        return {
            "label": self.label,
            "source": self.source,
            "ok": self.ok,
            "error": self.error,
            "seconds": self.seconds,
            "result": None if self.result is None else self.result.to_dict(),
        }

    def __repr__(self) -> str:
        state = f"saved={self.result.saved!r}" if self.result is not None else f"error={self.error!r}"
        return f"UnitResult({self.label!r}, {state})"


class FleetResult:
    """A fleet's results: ``units`` (:class:`UnitResult` per source, in order), ``table`` (the
    library's fleet table: ``parameters``, ``rows`` with values and standard errors, ``stats``,
    ``outliers``, ``rule``), ``table_csv``, ``html`` (fleet.html), ``flagged_units`` and
    ``seconds`` (wall time)."""

    __slots__ = ("units", "table", "table_csv", "html", "seconds")

    def __init__(self, units: List[UnitResult], table: Result, table_csv: str, html: str, seconds: float):
        self.units = units
        self.table = table
        self.table_csv = table_csv
        self.html = html
        self.seconds = seconds

    @property
    def flagged_units(self) -> List[str]:
        """Units with at least one parameter flagged as an outlier, in fleet order."""
        flagged = {o.unit for o in self.table.outliers}
        return [u.label for u in self.units if u.label in flagged]

    @property
    def failed_units(self) -> List[str]:
        return [u.label for u in self.units if not u.ok]

    def to_dict(self) -> Dict[str, Any]:
        return {"units": [u.to_dict() for u in self.units], "table": self.table.to_dict(), "seconds": self.seconds}

    def write(self, folder: PathLike, *, force: bool = False) -> None:
        """Writes per calibrated unit what ``spincal fleet`` writes into ``<label>/`` (results.json,
        report.html, model.json when saved, imucal.json, imu_tk ``.calib`` files),
        ``fleet.json`` (the table), ``fleet.csv`` and ``fleet.html`` (each parameter across the
        units, outliers highlighted) into ``folder``. A file there that spincal did not write
        raises :class:`UsageError` unless ``force``, and then nothing is written."""
        folder = os.fspath(folder)
        files: List[Tuple[str, str]] = []
        for u in self.units:
            if not u.ok:
                continue
            unit_dir = os.path.join(folder, u.label)
            for name, text in _spincal.campaign_files(u._results_json or "", u._model_json):
                files.append((os.path.join(unit_dir, name), text))
        files.append((os.path.join(folder, "fleet.json"), self.table.to_json() + "\n"))
        files.append((os.path.join(folder, "fleet.csv"), self.table_csv))
        files.append((os.path.join(folder, "fleet.html"), self.html))
        _write_files(files, force)

    def __repr__(self) -> str:
        return (
            f"FleetResult(units={len(self.units)}, failed={self.failed_units}, flagged={self.flagged_units}, "
            f"seconds={self.seconds:.1f})"
        )


def calibrate_fleet(
    units: Sequence[PathLike],
    *,
    outliers: Optional[Mapping[str, Any]] = None,
    max_retries: int = 3,
    runtime_env: Optional[Mapping[str, Any]] = None,
    max_in_flight: Optional[int] = None,
    progress: Union[bool, Any] = False,
) -> FleetResult:
    """Calibrates every unit (a campaign file or a folder holding ``campaign.toml``) as one Ray
    task each, on the cluster ``ray.init()`` reached, and makes the fleet table with outliers.

    ``outliers`` changes the library's outlier rule (``false_alarm_probability``, ``screen``,
    ``min_units``; the values used are in the table's ``settings``, the rule in its ``rule``). ``max_retries``: how often a task whose worker was lost is run again
    (the result is the same). ``runtime_env`` is merged into the tasks' (``env_vars`` always
    holds ``RAYON_NUM_THREADS=1``). ``max_in_flight`` bounds the tasks submitted at once (default:
    four per CPU of the cluster), so the driver reads and holds only that many units' files.
    ``progress=True`` shows a tqdm bar over the units.

    Returns a :class:`FleetResult`; a unit's failure is in its :class:`UnitResult`, never an
    exception for the fleet.

    Example::

        >>> ray.init(num_cpus=2)                                                  # doctest: +SKIP
        >>> fleet = spincal.ray.calibrate_fleet(sorted(glob.glob("units/*")))    # doctest: +SKIP
        >>> fleet.flagged_units                                                   # doctest: +SKIP
        ['unit-06']
    """
    started = time.perf_counter()
    if not ray.is_initialized():
        ray.init()
    sources = [os.fspath(u) for u in units]
    labels = _spincal.unit_labels(sources)
    env = dict(runtime_env or {})
    env_vars = dict(env.get("env_vars", {}))
    env_vars["RAYON_NUM_THREADS"] = "1"
    env["env_vars"] = env_vars
    task = _remote_calibrate.options(num_cpus=1, max_retries=max_retries, runtime_env=env)

    if max_in_flight is None:
        max_in_flight = max(1, 4 * int(ray.cluster_resources().get("CPU", 1)))
    outcomes: Dict[int, Dict[str, Any]] = {}
    pending: Dict[Any, int] = {}
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(sources), desc="fleet", unit="unit")
    next_unit = 0
    try:
        while next_unit < len(sources) or pending:
            # Submit up to max_in_flight tasks; a unit's files are read only when it is submitted.
            while next_unit < len(sources) and len(pending) < max_in_flight:
                i = next_unit
                next_unit += 1
                try:
                    root, campaign, files = unit_payload(sources[i])
                except Error as e:
                    outcomes[i] = {"error": f"{type(e).__name__}: {e}"}
                    if bar is not None:
                        bar.update(1)
                    continue
                pending[task.remote(labels[i], root, campaign, files)] = i
            if not pending:
                continue
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                i = pending.pop(ref)
                try:
                    outcomes[i] = ray.get(ref)
                except Exception as e:  # the task itself was lost (worker died too often, …)
                    outcomes[i] = {"error": f"{type(e).__name__}: {e}".strip()}
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()

    results = [UnitResult(labels[i], sources[i], outcomes[i]) for i in range(len(sources))]
    table_json, table_csv, html = _spincal.fleet_table(
        [(u.label, u.source, u._results_json, u._model_json, u.error) for u in results],
        outliers_json=None if outliers is None else json.dumps(dict(outliers)),
    )
    return FleetResult(results, Result(json.loads(table_json)), table_csv, html, time.perf_counter() - started)


def _run_sweep_jobs(jobs_json: str, jobs: List[int]) -> List[str]:
    """The task body of a distributed sweep: the given jobs, one after another, on one thread."""
    return _spincal.run_sweep_jobs(jobs_json, jobs)


_remote_sweep_jobs = ray.remote(_run_sweep_jobs)


def sweep_runner(
    *,
    jobs_per_task: int = 1,
    max_retries: int = 3,
    runtime_env: Optional[Mapping[str, Any]] = None,
    progress: Union[bool, Any] = False,
) -> Callable[[str, int], List[str]]:
    """A ``sweep_runner`` for :func:`spincal.calibrate` that spreads the network sweep over the
    Ray cluster ``ray.init()`` reached: the sweep's problem (the paired columns and settings, as
    exact JSON) goes to the object store once, and every ``jobs_per_task`` jobs (an architecture
    and a restart each) become one task on one CPU and one thread. Each job has its own seed, so
    the calibration is the local one, bit for bit, and a retried task (a worker lost, up to
    ``max_retries`` times) gives the same runs. ``progress=True`` shows a tqdm bar over tasks.

    Example::

        >>> runner = spincal.ray.sweep_runner(jobs_per_task=4)                    # doctest: +SKIP
        >>> cal = spincal.calibrate([rec], sweep="full", sweep_runner=runner)     # doctest: +SKIP
    """
    if jobs_per_task < 1:
        raise UsageError(f"jobs_per_task {jobs_per_task}: must be at least 1")
    env = dict(runtime_env or {})
    env_vars = dict(env.get("env_vars", {}))
    env_vars["RAYON_NUM_THREADS"] = "1"
    env["env_vars"] = env_vars

    def run(jobs_json: str, n_jobs: int) -> List[str]:
        if not ray.is_initialized():
            ray.init()
        task = _remote_sweep_jobs.options(num_cpus=1, max_retries=max_retries, runtime_env=env)
        shared = ray.put(jobs_json)
        chunks = [list(range(i, min(i + jobs_per_task, n_jobs))) for i in range(0, n_jobs, jobs_per_task)]
        pending = {task.remote(shared, chunk): k for k, chunk in enumerate(chunks)}
        results: Dict[int, List[str]] = {}
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(chunks), desc="network sweep", unit="task")
        try:
            while pending:
                done, _ = ray.wait(list(pending), num_returns=1)
                for ref in done:
                    results[pending.pop(ref)] = ray.get(ref)
                    if bar is not None:
                        bar.update(1)
        finally:
            if bar is not None:
                bar.close()
        return [run for k in range(len(chunks)) for run in results[k]]

    return run


def calibrate(
    recordings: Any,
    *,
    jobs_per_task: int = 1,
    max_retries: int = 3,
    runtime_env: Optional[Mapping[str, Any]] = None,
    **settings: Any,
) -> Calibration:
    """:func:`spincal.calibrate` with its network sweep spread over the Ray cluster (see
    :func:`sweep_runner`); every other stage runs here. Same arguments, same result bit for bit
    (only timings differ).

    Example::

        >>> ray.init(num_cpus=2)                                                  # doctest: +SKIP
        >>> cal = spincal.ray.calibrate([rec], sweep="full", restarts=10)         # doctest: +SKIP
    """
    runner = sweep_runner(
        jobs_per_task=jobs_per_task,
        max_retries=max_retries,
        runtime_env=runtime_env,
        progress=settings.get("progress", False),
    )
    return _calibrate_locally(recordings, sweep_runner=runner, **settings)
