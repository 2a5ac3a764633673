"""spincal.ray on a local Ray cluster of 2 CPUs started inside the tests (and torn down after)."""

import json
import os
import pathlib
from typing import Any, Callable, Dict

import numpy as np
import pytest

import spincal

ray = pytest.importorskip("ray")
import spincal.ray as sray  # noqa: E402



def _crashing_once(body: Callable[..., Any], folder: str, label: Callable[..., str]) -> Any:
    """A Ray task running ``body`` whose first attempt for each label kills its worker process (as
    a lost node would), so Ray's retry path runs. Defined here, in the tests: the package ships no
    such hook. The nested function travels to the workers by value; ``body`` is the package's own
    task function, imported there by name."""

    def task(*args: Any) -> Any:
        marker = os.path.join(folder, f"{label(*args)}.crashed")
        if not os.path.exists(marker):
            with open(marker, "w") as f:
                f.write(str(os.getpid()))
            os._exit(1)
        return body(*args)

    return ray.remote(task)


def _crash_fleet_tasks_once(monkeypatch, folder):
    monkeypatch.setattr(sray, "_remote_calibrate", _crashing_once(sray._calibrate_shipped, str(folder), lambda label, *_: label))


def _crash_sweep_tasks_once(monkeypatch, folder):
    task = _crashing_once(sray._run_sweep_jobs, str(folder), lambda jobs_json, jobs: f"sweep-job-{jobs[0]}")
    monkeypatch.setattr(sray, "_remote_sweep_jobs", task)


def _setup(units, faulty):
    """The default campaign with 30 s turntable runs: the suite fleet's setup."""
    campaign = spincal.simulation_defaults()["campaign"]
    for run in campaign["runs"]:
        run["duration_s"] = 30.0
    return {"units": units, "faulty": faulty, "campaign": campaign}


@pytest.fixture(scope="module")
def cluster():
    ray.init(num_cpus=2, include_dashboard=False, object_store_memory=200 * 1024 * 1024, log_to_driver=False)
    yield
    ray.shutdown()


def _stored_fleet():
    """The suite's one fleet (crates/spincal/tests/common/suite_fleet.rs), calibrated once by the
    library; ``cargo test`` passes its folder. pytest run alone has none: Ray's results are then
    compared with this process's own calibration of the same units."""
    folder = os.environ.get("SPINCAL_SUITE_FLEET")
    return None if folder is None else pathlib.Path(folder)


# The units calibrated here: a good one and the faulty one (the suite fleet's sixth).
_REFERENCE = (0, 5)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fleet")
    folders, truths = spincal.simulate_fleet(folder, seed=2026, setup=_setup(8, [5]))
    stored = _stored_fleet()
    if stored is not None:
        # Python's simulation writes the suite's fleet, file for file; Ray then calibrates the
        # stored units, whose paths the stored results name.
        for f in folders:
            unit = os.path.basename(f)
            for name in os.listdir(f):
                with open(os.path.join(f, name), "rb") as ours, open(stored / "units" / unit / name, "rb") as theirs:
                    assert ours.read() == theirs.read(), f"{unit}/{name}"
        folders = [str(stored / "units" / os.path.basename(f)) for f in folders]
    return stored, folders, truths


def _comparable(results_json):
    data = json.loads(results_json)
    data.pop("seconds_total", None)
    data.pop("stage_seconds", None)
    return data


def _expected(stored, source):
    """A unit's results.json and model.json text as the library calibrated it."""
    unit = os.path.basename(source)
    if stored is None:
        alone = spincal.calibrate_unit(source)
        model = None if alone.corrector is None else json.dumps(alone.corrector.to_dict())
        return _comparable(json.dumps(alone.result.to_dict())), model
    results = (stored / "calibrated" / unit / "results.json").read_text()
    model = stored / "calibrated" / unit / "model.json"
    units = str(stored / "units")
    return _comparable(results.replace("<units>", units)), model.read_text().replace("<units>", units) if model.exists() else None


@pytest.fixture(scope="module")
def ray_fleet(cluster, fleet, tmp_path_factory):
    """Two units of the fleet calibrated on Ray once, with a folder holding no campaign between them."""
    _, folders, _ = fleet
    broken = tmp_path_factory.mktemp("broken") / "no-campaign"
    broken.mkdir()
    sources = [folders[_REFERENCE[0]], str(broken), folders[_REFERENCE[1]]]
    return broken, sray.calibrate_fleet(sources, progress=True)


def test_a_fleet_on_ray_recovers_each_unit_and_equals_the_library(ray_fleet, fleet, tmp_path):
    stored, folders, truths = fleet
    broken, result = ray_fleet
    assert len(result.units) == 3
    # The broken unit fails alone, with a located message; the two others are calibrated.
    bad = result.units[1]
    assert not bad.ok and "campaign.toml" in bad.error and str(broken) in bad.error
    good = [u for u in result.units if u.ok]
    assert [u.label for u in good] == [os.path.basename(folders[i]) for i in _REFERENCE]
    assert result.failed_units == ["no-campaign"]

    # Each unit's twelve sensor parameters within 3 reported standard errors of its truth (the
    # library's fleet test criterion per unit: ≥ 6 of 12; it judges all eight).
    for unit, i in zip(good, _REFERENCE):
        s = truths[i].truth.sensor
        true = s.bias_mps2 + s.scale_error + s.misalignment_rad + s.quadratic_per_mps2
        params = unit.result.joint.sensor_params
        z = [abs(p.value - t) / p.std_error for p, t in zip(params, true)]
        assert len(z) == 12
        assert sum(v <= 3.0 for v in z) >= 6, (unit.label, z)

    # Two units are too few to judge outliers (the library's fleet test flags the faulty one).
    assert result.flagged_units == []
    assert result.table.stats and not any(p.judged for p in result.table.stats)
    assert "unit" in result.table_csv.splitlines()[0]

    # Ray's results are the library's: results.json and model.json as the suite fleet stored them.
    for unit, i in zip(good, _REFERENCE):
        results, model = _expected(stored, folders[i])
        assert _comparable(unit._results_json) == results, unit.label
        if stored is not None:
            assert unit._model_json == model, unit.label
        else:
            assert (unit.corrector is None) == (model is None)
            if unit.corrector is not None:
                assert json.dumps(unit.corrector.to_dict()) == model

    result.write(tmp_path / "out")
    assert (tmp_path / "out" / "fleet.csv").exists()
    assert "<svg" in (tmp_path / "out" / "fleet.html").read_text()
    assert (tmp_path / "out" / good[0].label / "results.json").exists()
    assert "Held-out residual against physics" in (tmp_path / "out" / good[0].label / "report.html").read_text()


def test_a_retried_task_gives_the_same_result(ray_fleet, fleet, tmp_path, monkeypatch):
    _, folders, _ = fleet
    _, first = ray_fleet
    markers = tmp_path / "markers"
    markers.mkdir()
    # Every task's first attempt kills its worker, as a lost node would; Ray runs it again.
    _crash_fleet_tasks_once(monkeypatch, markers)
    again = sray.calibrate_fleet(folders[:1], max_retries=2)
    assert os.listdir(markers) == [f"{os.path.basename(folders[0])}.crashed"]
    assert again.units[0].ok, again.units[0].error
    assert _comparable(first.units[0]._results_json) == _comparable(again.units[0]._results_json)
    # Without retries the lost worker is that unit's failure, not the fleet's.
    markers2 = tmp_path / "markers2"
    markers2.mkdir()
    _crash_fleet_tasks_once(monkeypatch, markers2)
    lost = sray.calibrate_fleet(folders[:1], max_retries=0)
    assert not lost.units[0].ok and lost.units[0].error


def test_units_are_shipped_as_bytes(fleet):
    _, folders, _ = fleet
    root, campaign, files = sray.unit_payload(folders[0])
    assert campaign == "campaign.toml" and campaign in files
    assert all(isinstance(v, bytes) for v in files.values())
    assert len(files) == 1 + 3 * 5  # the campaign, 5 recordings, their truth and random-error files


def _untimed(value):
    """A result or model as a dict without its timings, the only thing a distributed run changes."""
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if "seconds" not in k}
    if isinstance(value, list):
        return [_untimed(v) for v in value]
    return value


def test_a_sweep_spread_over_ray_equals_the_local_sweep_bit_for_bit(cluster, tmp_path, monkeypatch):
    rec, _ = spincal.simulate(seed=11, turntable={"duration_s": 40.0})
    settings: Dict[str, Any] = dict(radius_m=0.10, sweep="small", restarts=2, seed=5)
    local = spincal.calibrate([rec], **settings)
    markers = tmp_path / "markers"
    markers.mkdir()
    # Every task's first attempt kills its worker; the retried tasks give the same runs.
    _crash_sweep_tasks_once(monkeypatch, markers)
    spread = sray.calibrate([rec], jobs_per_task=7, **settings)
    local_paper, spread_paper = local.result.paper, spread.result.paper
    assert local_paper is not None and spread_paper is not None
    n_jobs = len(local_paper.sweep) * 2
    assert len(local_paper.sweep) == 20
    assert sorted(os.listdir(markers)) == sorted(f"sweep-job-{k}.crashed" for k in range(0, n_jobs, 7))
    a, b = local.result.to_dict(), spread.result.to_dict()
    assert _untimed(a) == _untimed(b)
    # Floats compared as text would hide nothing, but check the sweep's MSEs to the bit anyway.
    for x, y in zip(a["paper"]["sweep"], b["paper"]["sweep"]):
        assert float(x["best_validation_mse"]).hex() == float(y["best_validation_mse"]).hex()
    assert local_paper.network_architecture == spread_paper.network_architecture
    assert (local.corrector is None) == (spread.corrector is None)
    np.testing.assert_array_equal(local.corrected, spread.corrected)


def test_a_failing_sweep_runner_raises_its_own_exception():
    rec, _ = spincal.simulate(seed=12, turntable={"duration_s": 20.0})

    class Lost(RuntimeError):
        pass

    def runner(jobs_json, n_jobs):
        raise Lost(f"{n_jobs} jobs lost")

    with pytest.raises(Lost, match="jobs lost"):
        spincal.calibrate([rec], radius_m=0.10, sweep="small", restarts=1, sweep_runner=runner)
    # A runner that drops a job is refused, naming it.
    def short(jobs_json, n_jobs):
        return spincal._spincal.run_sweep_jobs(jobs_json, list(range(n_jobs - 1)))

    with pytest.raises(spincal.FitError, match=r"job 19 missing"):
        spincal.calibrate([rec], radius_m=0.10, sweep="small", restarts=1, sweep_runner=short)
