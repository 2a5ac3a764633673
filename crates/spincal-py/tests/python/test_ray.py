"""spincal.ray on a local Ray cluster of 2 CPUs started inside the tests (and torn down after)."""

import json
import os
from typing import Any, Callable, Dict

import numpy as np
import pytest

import spincal

ray = pytest.importorskip("ray")
import spincal.ray as sray  # noqa: E402

# The default campaign with shorter turntable runs (30 s), as the library's fleet test.


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
    campaign = spincal.simulation_defaults()["campaign"]
    for run in campaign["runs"]:
        run["duration_s"] = 30.0
    return {"units": units, "faulty": faulty, "campaign": campaign}


@pytest.fixture(scope="module")
def cluster():
    ray.init(num_cpus=2, include_dashboard=False, object_store_memory=200 * 1024 * 1024, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fleet")
    folders, truths = spincal.simulate_fleet(folder, seed=2026, setup=_setup(8, [5]))
    return folder, folders, truths


def _comparable(results_json):
    data = json.loads(results_json)
    data.pop("seconds_total", None)
    data.pop("stage_seconds", None)
    return data


@pytest.fixture(scope="module")
def ray_fleet(cluster, fleet, tmp_path_factory):
    """The fleet calibrated on Ray once, with a folder holding no campaign fourth in the list."""
    _, folders, _ = fleet
    broken = tmp_path_factory.mktemp("broken") / "no-campaign"
    broken.mkdir()
    sources = folders[:3] + [str(broken)] + folders[3:]
    return broken, sray.calibrate_fleet(sources, progress=True)


def test_a_fleet_on_ray_recovers_each_unit_and_flags_the_faulty_one(ray_fleet, fleet, tmp_path):
    folder, folders, truths = fleet
    broken, result = ray_fleet
    assert len(result.units) == 9
    # The broken unit fails alone, with a located message; the eight others are calibrated.
    bad = result.units[3]
    assert not bad.ok and "campaign.toml" in bad.error and str(broken) in bad.error
    good = [u for u in result.units if u.ok]
    assert [u.label for u in good] == [os.path.basename(f) for f in folders]
    assert result.failed_units == ["no-campaign"]

    # Each unit's twelve sensor parameters within 3 reported standard errors of its truth (the
    # library's fleet test criterion: ≥ 6 of 12 per unit, ≥ 90 % over the fleet).
    inside = total = 0
    for unit, truth in zip(good, truths):
        s = truth.truth.sensor
        true = s.bias_mps2 + s.scale_error + s.misalignment_rad + s.quadratic_per_mps2
        params = unit.result.joint.sensor_params
        z = [abs(p.value - t) / p.std_error for p, t in zip(params, true)]
        assert len(z) == 12
        unit_inside = sum(v <= 3.0 for v in z)
        assert unit_inside >= 6, (unit.label, z)
        inside += unit_inside
        total += 12
    assert inside / total >= 0.9

    # The faulty unit (bias x +0.05 g, scale y +3 %) is flagged, and only it.
    faulty = [t.name for t in truths if t.faulty]
    assert result.flagged_units == faulty
    flagged = {o.parameter for o in result.table.outliers}
    assert any("bias" in p and "x" in p for p in flagged) and any("scale" in p and "y" in p for p in flagged)
    assert "unit" in result.table_csv.splitlines()[0]

    # The same results as calibrating a unit alone, in this process: the faulty unit and the first
    # (every unit travels the same way; the library's fleet test covers all eight's statistics).
    faulty_index = next(i for i, t in enumerate(truths) if t.faulty)
    for i in sorted({0, faulty_index}):
        unit, source = good[i], folders[i]
        alone = spincal.calibrate_unit(source)
        assert _comparable(unit._results_json) == _comparable(json.dumps(alone.result.to_dict()))
        assert (unit.corrector is None) == (alone.corrector is None)
        if unit.corrector is not None and alone.corrector is not None:
            assert unit.corrector.to_dict() == alone.corrector.to_dict()

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
