"""The Python package gives the CLI's numbers, to the last bit."""

import csv
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import spincal


def _read_corrected(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows


_MANIFEST = ".spincal-outputs.json"


def _listing(folder):
    """A folder's files, sorted, without spincal's record of what it wrote there (_MANIFEST)."""
    return sorted(p.name for p in Path(folder).iterdir() if p.name != _MANIFEST)


def _without_timing(value):
    if isinstance(value, dict):
        return {k: _without_timing(v) for k, v in value.items() if not k.startswith("seconds") and k != "stage_seconds"}
    if isinstance(value, list):
        return [_without_timing(v) for v in value]
    return value


def test_read_gives_the_simulated_samples_and_dataframes_are_read_by_name(simulated):
    path, rec, _ = simulated
    read = spincal.read(path)
    assert read.format == "csv" and len(read) == len(rec)
    assert np.array_equal(read.time, rec.time)
    assert np.array_equal(read.accel, rec.accel)
    assert read.accel.shape == (len(rec), 3)
    from_bytes = spincal.read(path.read_bytes(), name="rec.csv")
    assert np.array_equal(from_bytes.accel, rec.accel)
    pd = pytest.importorskip("pandas")
    frame = pd.read_csv(path, float_precision="round_trip")
    assert list(frame.columns)[:4] == ["t_s", "ax_mps2", "ay_mps2", "az_mps2"]
    from_frame = spincal.read(frame[["az_mps2", "t_s", "ax_mps2", "ay_mps2"]])
    assert np.array_equal(from_frame.accel, rec.accel)
    assert np.array_equal(from_frame.time, rec.time)


def test_correcting_an_array_equals_spincal_correct_to_the_last_bit(simulated, trained, cli, tmp_path):
    path, rec, _ = simulated
    model = trained / "model.json"
    out = tmp_path / "corrected.csv"
    cli("correct", "--model", model, path, "-o", out)
    rows = _read_corrected(out)
    assert len(rows) == len(rec)
    corrector = spincal.load_corrector(model)
    assert corrector.kind == "ann"
    result = corrector.correct(rec.accel)  # a Fortran-ordered view: read in place
    # A corrected column for exactly the axes the corrector changes (the paper's x and y).
    assert corrector.axes == ["x", "y"], corrector.axes
    assert [c for c in rows[0] if "_corrected_" in c] == [f"a{a}_corrected_mps2" for a in corrector.axes]
    for axis, name in enumerate(["ax", "ay", "az"]):
        column = f"{name}_corrected_mps2"
        if "xyz"[axis] not in corrector.axes:
            # An axis it does not change passes through unchanged.
            assert np.array_equal(result.accel[:, axis], rec.accel[:, axis]), name
            continue
        cli_values = np.array([float(r[column]) for r in rows])
        assert np.array_equal(cli_values, result.accel[:, axis]), name
    assert [r["valid"] == "1" for r in rows] == result.valid.tolist()
    # The same numbers from a C-ordered copy, a file and a DataFrame.
    again = spincal.correct(model, np.ascontiguousarray(rec.accel))
    assert np.array_equal(again.accel, result.accel)
    assert np.array_equal(spincal.correct(corrector, path).accel, result.accel)


def test_calibration_gives_the_clis_results_json(simulated, calibrated):
    path, _, _ = simulated
    cal = spincal.calibrate([str(path)], radius_m=0.1, sweep="none", hidden="4", restarts=1)
    cli_result = json.loads((calibrated / "results.json").read_text())
    assert _without_timing(cal.to_dict()) == _without_timing(cli_result)
    # One recording holds no second condition: nothing saved, and the verdict says so first.
    assert cal.result.saved is None and cli_result["saved"] is None and cal.corrector is None
    assert not (calibrated / "model.json").exists()
    assert cal.result.verdict.startswith("Nothing saved")
    # The paper's figures: the turntable fit's parameters by name and the comparison as a table.
    paper = cal.result.paper
    assert paper is not None
    radius = paper.parameters["radius"]
    cli_radius = next(p for p in cli_result["paper"]["turntable"]["params"] if p["name"] == "radius")
    assert (radius.value, radius.stderr, radius.unit) == (cli_radius["value"], cli_radius["std_error"], cli_radius["unit"])
    table = paper.to_pandas()
    assert list(table.index) == [row["model"] for row in cli_result["paper"]["comparison"]]
    first = cli_result["paper"]["comparison"][0]
    assert table.iloc[0]["validation_fit_percent"] == first["validation"]["fit_percent_mean"]


def test_calibration_writes_the_report(simulated, tmp_path):
    _, rec, _ = simulated
    cal = spincal.calibrate([rec], radius_m=0.1, sweep="none", hidden="3", restarts=1)
    cal.write(tmp_path / "out")
    assert _listing(tmp_path / "out") == ["report.html", "results.json"]
    report = (tmp_path / "out" / "report.html").read_text()
    assert "<html" in report[:2000].lower() and "The paper's protocol" in report
    # Nothing saved: the corrected signal is the recording itself.
    assert cal.corrector is None
    assert np.array_equal(cal.corrected, rec.accel)


def test_writing_again_replaces_spincals_own_files_and_refuses_the_users(simulated, trained, calibrated, tmp_path):
    _, rec, _ = simulated
    # A folder the CLI wrote is spincal's own to Python too, and written again without force.
    out = tmp_path / "cal"
    shutil.copytree(calibrated, out)
    cal = spincal.calibrate([rec], radius_m=0.1, sweep="none", hidden="3", restarts=1)
    cal.write(out)
    cal.write(out)
    assert _listing(out) == _listing(calibrated)
    # Edited by hand afterwards, the report is the user's: nothing is written.
    report = out / "report.html"
    report.write_text(report.read_text() + "<!-- my notes -->\n")
    before = {name: (out / name).read_bytes() for name in _listing(out)}
    with pytest.raises(spincal.UsageError, match="report.html.*changed since spincal wrote it"):
        cal.write(out)
    assert {name: (out / name).read_bytes() for name in _listing(out)} == before
    cal.write(out, force=True)
    assert "my notes" not in report.read_text()

    # A model and a recording: their own files replaced, a user's lookalike kept.
    corrector = spincal.load_corrector(trained / "model.json")
    model = tmp_path / "model.json"
    corrector.save(model)
    corrector.save(model)
    recording = tmp_path / "rec.csv"
    rec.write_csv(recording, unit="g")
    rec.write_csv(recording, unit="g")
    theirs = {
        tmp_path / "their-model.json": json.dumps(corrector.to_dict(), indent=1),
        tmp_path / "xsens.csv": "t_s,ax_g,ay_g,az_g\n0.00,0.01,-0.02,1.00\n",
    }
    for path, text in theirs.items():
        path.write_text(text)
    with pytest.raises(spincal.UsageError, match="their-model.json.*spincal did not write it"):
        corrector.save(tmp_path / "their-model.json")
    with pytest.raises(spincal.UsageError, match="xsens.csv.*spincal did not write it"):
        rec.write_csv(tmp_path / "xsens.csv")
    for path, text in theirs.items():
        assert path.read_text() == text, path
    rec.write_csv(tmp_path / "xsens.csv", force=True)
    assert (tmp_path / "xsens.csv").read_text() == recording.read_text()


def test_campaign_calibration_gives_the_clis_results_json(tmp_path, cli):
    unit = tmp_path / "unit"
    truth = spincal.simulate_campaign(unit, seed=5)
    cli("calibrate", "--campaign", unit / "campaign.toml", "--out", tmp_path / "cli")
    cal = spincal.calibrate_campaign(unit / "campaign.toml")
    assert isinstance(cal, spincal.Calibration)
    with pytest.raises(spincal.UsageError, match="calibrate_campaign"):
        spincal.calibrate(unit / "campaign.toml")
    cli_result = json.loads((tmp_path / "cli" / "results.json").read_text())
    assert _without_timing(cal.to_dict()) == _without_timing(cli_result)
    names = [p.name for p in cal.result.joint.sensor_params]
    assert any(n.startswith("bias_x") for n in names)
    # The same parameters by name, the unit apart, standard errors beside the values.
    by_name = cal.result.parameters
    first = cli_result["joint"]["sensor_params"][0]
    assert list(by_name)[0] == "bias_x" and by_name["bias_x"].unit == "m/s²"
    assert (by_name["bias_x"].value, by_name["bias_x"].stderr) == (first["value"], first["std_error"])
    assert len(by_name) == len(cli_result["joint"]["sensor_params"])
    table = by_name.to_pandas()
    assert table.loc["bias_x", "value"] == first["value"] and list(table.columns) == ["value", "stderr", "unit"]
    gyro = cal.result.gyro_parameters
    assert gyro is not None and len(gyro) == len(cli_result["gyro"]["params"])
    # The joint fit finds the simulation's true bias within a few of its own standard errors.
    for k, axis in enumerate("xyz"):
        fitted = by_name[f"bias_{axis}"]
        assert fitted.stderr is not None, (axis, fitted)
        assert abs(fitted.value - truth.sensor.bias_mps2[k]) < 4 * fitted.stderr, (axis, fitted, truth.sensor.bias_mps2)
    cal.write(tmp_path / "py")
    assert json.loads((tmp_path / "py" / "results.json").read_text())["unit"] == cli_result["unit"]
    # The same files as the CLI's; all but the timed ones (results.json, report.html) to the byte.
    written = _listing(tmp_path / "py")
    assert written == _listing(tmp_path / "cli")
    assert {"report.html", "imucal.json", "imu_tk_acc.calib", "imu_tk_gyro.calib"} <= set(written)
    for name in set(written) - {"results.json", "report.html"}:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    html = cal.report_html()
    assert html == (tmp_path / "py" / "report.html").read_text()
    assert "Held-out residual against physics" in html and "<svg" in html and cal.result.unit in html


def test_fit_and_static_and_allan_and_sensitivity_match_the_cli(simulated, cli, tmp_path):
    path, rec, truth = simulated
    fit = spincal.fit_turntable([rec], rpm=33.3)
    omega = fit.recordings[0].session.omega_radps
    assert abs(omega / truth.session.omega_radps - 1) < 1e-3
    assert fit.references[0].shape == (len(rec), 3)
    rows = spincal.sensitivity(radius_m=0.1, tilt_deg=5, rpm=33.3, vary_percent=15)
    cli_rows = json.loads(cli("sensitivity", "--radius", "0.1", "--tilt-deg", "5", "--rpm", "33.3", "--vary", "15", "--json").stdout)
    assert [r.to_dict() for r in rows] == cli_rows
    # Static: the same poses file through `spincal static`, whose text prints each still interval
    # and the parameters at full precision.
    poses = tmp_path / "poses.csv"
    _still_poses().write_csv(poses, unit="mps2")
    result, _ = spincal.static_calibration(poses, parameters=6)
    text = cli("--quiet", "static", "--model", "6", poses).stdout
    fitted = result.to_dict()["fit"]["calibration"]
    for name in ["bias", "scale"]:
        line = next(l for l in text.splitlines() if l.startswith(f"{name} ["))
        assert json.loads(line.split(": ", 1)[1]) == fitted[name], (line, fitted[name])
    intervals = result.to_dict()["intervals"]
    assert f"still intervals: {len(intervals)} " in text and len(intervals) == 6, text
    for iv in intervals:
        assert f"{iv['end'] - iv['start']} samples" in text, (iv, text)
    # Allan: the same still file through `spincal allan --json`.
    still = tmp_path / "still.csv"
    noise = np.random.default_rng(1).normal(0, 0.01, (20_000, 3)) + [0.0, 0.0, 9.80665]
    spincal.recording(np.arange(20_000) / 100.0, noise).write_csv(still, unit="mps2")
    cli_allan = json.loads(cli("--quiet", "allan", still, "--json").stdout)
    ours = spincal.allan(still).to_dict()
    assert ours["curve"] == cli_allan["curve"] and ours["noise"] == cli_allan["params"]


BIAS = np.array([0.05, -0.03, 0.02])


def _still_poses():
    """Six still poses, ±g on each axis, with the known bias BIAS, and noisy moves between them."""
    bias = BIAS
    g = 9.80665
    poses = [[g, 0, 0], [-g, 0, 0], [0, g, 0], [0, -g, 0], [0, 0, g], [0, 0, -g]]
    rng = np.random.default_rng(3)
    blocks, moves = [], []
    for k, p in enumerate(poses):
        blocks.append(np.tile(np.array(p) + bias, (800, 1)) + rng.normal(0, 0.002, (800, 3)))
        if k < len(poses) - 1:
            nxt = np.array(poses[k + 1]) + bias
            moves.append(np.linspace(np.array(p) + bias, nxt, 300) + rng.normal(0, 0.5, (300, 3)))
    accel = np.vstack([x for pair in zip(blocks, moves + [np.empty((0, 3))]) for x in pair])
    return spincal.recording(np.arange(len(accel)) / 100.0, accel)


def test_static_calibration_recovers_a_bias():
    bias, g = BIAS, 9.80665
    poses = [[g, 0, 0], [-g, 0, 0], [0, g, 0], [0, -g, 0], [0, 0, g], [0, 0, -g]]
    rec = _still_poses()
    result, corrector = spincal.static_calibration(rec, parameters=6)
    assert corrector.kind == "static"
    assert len(result.intervals) == 6
    fixed = corrector.correct(np.tile(np.array(poses[4]) + bias, (5, 1))).accel
    assert np.allclose(fixed[0], poses[4], atol=0.01)


def test_allan_of_white_noise():
    a = np.random.default_rng(1).normal(0, 0.01, (100_000, 3))
    r = spincal.allan(a, dt_s=0.01)
    # white noise σ at 100 Hz: density σ·√Δt = 0.001 m/s²/√Hz
    assert all(abs(d / 0.001 - 1) < 0.1 for d in r.noise.noise_density)
    assert len(r.curve.tau_s) == len(r.curve.adev[0])


def test_correct_file_merges_a_gyro_file_on_time_as_spincal_correct_does(cli, tmp_path):
    """`correct_file(..., gyro_file=G)` is `spincal correct --gyro-file G`, to the byte: a gyro
    at 190 Hz on its own jittered clock over 3–18 s of a 100 Hz accelerometer's 0–20 s."""
    model = tmp_path / "model.json"
    static = {"kind": "static", "model": "bias_scale", "bias": [0, 0, 0], "scale": [1, 1, 1],
              "misalignment": [0, 0, 0], "nonlinearity": [0, 0, 0], "gravity_mps2": 9.81, "input_unit": "m/s^2"}
    gyro_model = {"bias_radps": [0.01, 0, 0], "sensitivity": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "input_unit": "rad_per_s"}
    model.write_text(json.dumps({"format_version": 2, "spincal_version": spincal.__version__,
                                 "corrector": static, "gyro": gyro_model}))
    rng = np.random.default_rng(3)
    t = np.arange(2001) / 100 + rng.uniform(-0.002, 0.002, 2001)
    accel = tmp_path / "acc.csv"
    accel.write_text("t,ax,ay,az\n" + "".join(f"{x:.6f},0.01,-0.02,9.81\n" for x in t))
    n = 15 * 190 + 1
    tg = 3.0 + np.arange(n) / 190 + rng.uniform(-0.001, 0.001, n)
    gyro = tmp_path / "gyr.txt"
    gyro.write_text("".join(f"{x:.6f} {0.1 * np.sin(x):.7f} 0.2 0.3\n" for x in tg))
    by_cli = tmp_path / "cli.csv"
    cli("correct", "--model", model, accel, "--gyro-file", gyro, "-o", by_cli)
    by_python = tmp_path / "python.csv"
    summary = spincal.load_corrector(model).correct_file(accel, by_python, gyro_file=gyro)
    assert by_python.read_bytes() == by_cli.read_bytes()
    rows = _read_corrected(by_python)
    assert len(rows) == 2001
    no_gyro = [r for r in rows if r["status"].startswith("no-gyro")]
    assert summary["no_gyro"] == len(no_gyro) and 450 < len(no_gyro) < 550
    assert all(r["gx_corrected_radps"] == "" and r["valid"] == "0" for r in no_gyro)


def test_correct_file_streams_a_file_to_a_file_equal_to_spincal_correct_to_the_byte(simulated, trained, cli, tmp_path):
    path, rec, _ = simulated
    model = trained / "model.json"
    by_cli = tmp_path / "cli.csv"
    cli("correct", "--model", model, path, "-o", by_cli)
    # A refused row (a value that is no number) and an empty cell, in place: every row comes out.
    lines = path.read_text().splitlines()
    fields = lines[40].split(",")
    lines[40] = ",".join(fields[:1] + ["oops"] + fields[2:])
    lines[60] = ",".join(lines[60].split(",")[:-1] + [""])
    damaged = tmp_path / "damaged.csv"
    damaged.write_text("\n".join(lines) + "\n")
    corrector = spincal.load_corrector(model)
    by_python = tmp_path / "python.csv"
    summary = corrector.correct_file(path, by_python)
    assert by_python.read_bytes() == by_cli.read_bytes()
    assert summary["rows"] == len(rec) and summary["refused"] == 0 and summary["refusals"] is None
    damaged_cli = tmp_path / "damaged-cli.csv"
    done = cli("correct", "--model", model, damaged, "-o", damaged_cli, check=False)
    assert done.returncode == 3, done.stderr
    damaged_python = tmp_path / "damaged-python.csv"
    summary = corrector.correct_file(damaged, damaged_python)
    assert damaged_python.read_bytes() == damaged_cli.read_bytes()
    assert summary["rows"] == len(rec) and summary["refused"] == 1 and summary["skipped"] == 1
    assert "line 41" in summary["refusals"] and any("no value in a column used" in w for w in summary["warnings"])
    out_rows = _read_corrected(damaged_python)
    assert len(out_rows) == len(rec)
    assert [r["t_s"] for r in out_rows] == [line.split(",")[0] for line in lines[1:]]
    # An existing file spincal did not write is not replaced.
    theirs = tmp_path / "theirs.csv"
    theirs.write_text("t,ax,ay,az\n0,0,0,9.8\n")
    with pytest.raises(spincal.UsageError, match="spincal did not write it"):
        corrector.correct_file(path, theirs)
    assert theirs.read_text() == "t,ax,ay,az\n0,0,0,9.8\n"
