"""DataFrames (pandas and polars) in and out: columns handed over as arrays by the library's column
rules, and `spincal correct`'s output reproduced from Python, gyro included, to the last bit."""

import csv
import math

import numpy as np
import pytest

import spincal

pd = pytest.importorskip("pandas")


@pytest.fixture(scope="module")
def campaign_model(tmp_path_factory, cli):
    """A campaign calibrated by the CLI: its model.json calibrates the gyroscope too."""
    folder = tmp_path_factory.mktemp("campaign")
    unit = folder / "unit"
    spincal.simulate_campaign(unit, seed=5)
    cli("calibrate", "--campaign", unit / "campaign.toml", "--out", folder / "cal")
    model = folder / "cal" / "model.json"
    assert spincal.load_corrector(model).has_gyro, "the campaign's model should calibrate the gyro"
    recordings = sorted(p for p in unit.glob("*.csv") if not p.name.endswith((".truth.csv", ".random.csv")))
    return model, recordings


def _frame_in_g_and_dps(source, target):
    """The recording's rows written with the acceleration in g and the gyro in °/s (unit-bearing
    names), two rows whose values are not numbers and one whose time goes back: what a user's
    file looks like. Written with Python's round-trip repr, so pandas and the CLI read the same
    bits."""
    frame = pd.read_csv(source, float_precision="round_trip")
    out = pd.DataFrame(
        {
            "time_s": frame["t_s"],
            "ax_g": frame["ax_mps2"] / 9.80665,
            "ay_g": frame["ay_mps2"] / 9.80665,
            "az_g": frame["az_mps2"] / 9.80665,
            "gx_dps": np.degrees(frame["gx_radps"]),
            "gy_dps": np.degrees(frame["gy_radps"]),
            "gz_dps": np.degrees(frame["gz_radps"]),
            "note": 7.0,
        }
    ).iloc[:3000].copy()
    out.loc[100, "ay_g"] = float("nan")
    out.loc[200, "gz_dps"] = float("inf")
    out.loc[300, "time_s"] = out.loc[299, "time_s"] - 1.0
    out.to_csv(target, index=False, na_rep="NaN")
    return pd.read_csv(target, float_precision="round_trip")


def _cli_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_a_dataframe_corrected_in_python_equals_spincal_correct_gyro_included(campaign_model, cli, tmp_path):
    model, recordings = campaign_model
    turning = next(p for p in recordings if p.name.startswith("run-"))
    source = tmp_path / "in.csv"
    frame = _frame_in_g_and_dps(turning, source)
    frame.index = frame.index * 10 + 5  # a user's own index: kept in the output
    cli_out = tmp_path / "cli.csv"
    done = cli("correct", "--model", model, source, "-o", cli_out, check=False)
    assert done.returncode == 3, done.stderr  # rows were refused
    rows = _cli_rows(cli_out)
    corrected = spincal.correct(model, frame)
    ours = frame.join(corrected.to_pandas())
    # The same columns, in the same order, as the CLI writes.
    assert list(ours.columns) == list(rows[0].keys())
    assert "gx_corrected_dps" in ours.columns and "ax_corrected_g" in ours.columns
    assert list(ours.index) == list(frame.index)
    refused = 0
    for k, (label, row) in enumerate(zip(ours.index, rows)):
        status = ours.at[label, "status"]
        if row["status"].startswith("refused"):
            refused += 1
            assert status.startswith(f"refused: row {label}: "), (k, status, row["status"])
            assert not ours.at[label, "valid"]
            continue
        assert status == row["status"], k
        assert bool(ours.at[label, "valid"]) == (row["valid"] == "1"), k
        for column in ours.columns:
            if "_corrected_" in column:
                # Bit for bit: the CLI prints the shortest text that reads back to the same double.
                assert float(row[column]) == ours.at[label, column], (k, column)
        if "predicted_better" in ours.columns:
            assert (row["predicted_better"] == "1") == bool(ours.at[label, "predicted_better"]), k
    assert refused == 2
    # A physical model from a campaign carries its covariance: every row has its error bar.
    if spincal.load_corrector(model).kind in ("physical", "physical_linear"):
        assert "ax_corrected_sd_g" in ours.columns and "predicted_better" in ours.columns
        assert corrected.predicted_sd is not None and np.all(corrected.predicted_sd[ours["valid"].to_numpy()] > 0)
    reasons = [corrected.refused[p] for p in sorted(corrected.refused)]
    assert "column ay_g: the value is NaN" in reasons[0]
    assert "column gz_dps: the value is inf" in reasons[1]
    # The physical model has no delays and no thermal lag: a row whose time goes back is corrected.
    assert rows[300]["status"] == "ok" and ours.iloc[300]["status"] == "ok"
    # The gyro really was corrected, and differs from the measurement.
    assert not np.array_equal(ours["gx_corrected_dps"].dropna(), frame["gx_dps"][ours["gx_corrected_dps"].notna()])


@pytest.mark.parametrize(
    "header, units",
    [
        (["t", "ax", "ay", "az", "gx", "gy", "gz"], ("mps2", "radps")),
        (
            ["time", "acc_x_mps2", "acc_y_mps2", "acc_z_mps2", "gyr_x_dps", "gyr_y_dps", "gyr_z_dps"],
            ("mps2", "dps"),
        ),
    ],
)
def test_the_cli_and_python_name_the_corrected_columns_alike(campaign_model, cli, tmp_path, header, units):
    """One rule, `<axis>_corrected_<unit>`, whatever the input's names: the CLI's header and
    Python's frame agree, column for column."""
    model, recordings = campaign_model
    source = pd.read_csv(next(p for p in recordings if p.name.startswith("run-")), float_precision="round_trip").iloc[:500]
    gyro = source[["gx_radps", "gy_radps", "gz_radps"]].to_numpy()
    if units[1] == "dps":
        gyro = np.degrees(gyro)
    frame = pd.DataFrame(
        np.column_stack([source["t_s"], source[["ax_mps2", "ay_mps2", "az_mps2"]].to_numpy(), gyro]), columns=header
    )
    path = tmp_path / "in.csv"
    frame.to_csv(path, index=False)
    frame = pd.read_csv(path, float_precision="round_trip")
    cli_out = tmp_path / "cli.csv"
    cli("correct", "--model", model, path, "-o", cli_out)
    cli_header = list(_cli_rows(cli_out)[0].keys())
    corrector = spincal.load_corrector(model)
    ours = frame.join(corrector.correct(frame).to_pandas())
    assert list(ours.columns) == cli_header
    accel, rate = units
    expected = [f"a{a}_corrected_{accel}" for a in corrector.axes] + [f"g{a}_corrected_{rate}" for a in "xyz"]
    if corrector.kind in ("physical", "physical_linear"):
        expected += [f"a{a}_corrected_sd_{accel}" for a in corrector.axes] + ["predicted_better"]
    assert cli_header[len(header) : -2] == expected


def test_polars_gives_the_same_rows_as_pandas(campaign_model, tmp_path):
    pl = pytest.importorskip("polars")
    model, recordings = campaign_model
    frame = _frame_in_g_and_dps(recordings[0], tmp_path / "in.csv")
    corrector = spincal.load_corrector(model)
    from_pandas = corrector.correct(frame).to_pandas()
    from_polars = corrector.correct(pl.from_pandas(frame)).to_polars()
    assert from_polars.columns == list(from_pandas.columns)
    for column in from_polars.columns:
        if column == "status":
            assert from_polars[column].to_list() == [str(s) for s in from_pandas[column]]
        else:
            np.testing.assert_array_equal(from_polars[column].to_numpy(), from_pandas[column].to_numpy())


def test_a_refused_row_never_reaches_the_corrector(campaign_model):
    model, recordings = campaign_model
    rec = spincal.read(recordings[-1])
    assert rec.gyro is not None
    corrector = spincal.load_corrector(model)
    accel = rec.accel.copy()
    accel[50, 1] = float("nan")
    marked = corrector.correct(accel, gyro=rec.gyro)
    assert marked.status[50].startswith("refused: row 50: column ay_mps2: the value is NaN")
    assert not marked.valid[50] and np.isnan(marked.accel[50]).all()
    # Every other row is what correcting the data without that row gives.
    keep = np.ones(len(rec), dtype=bool)
    keep[50] = False
    without = corrector.correct(rec.accel[keep], gyro=rec.gyro[keep])
    np.testing.assert_array_equal(marked.accel[keep], without.accel)
    assert marked.gyro is not None and without.gyro is not None
    np.testing.assert_array_equal(marked.gyro[keep], without.gyro)
    assert (marked.status[keep] == without.status).all()


def test_columns_are_found_by_the_clis_rules_or_named(simulated):
    path, rec, _ = simulated
    frame = pd.read_csv(path, float_precision="round_trip")
    # By the names the CLI knows, in any order, other columns ignored.
    shuffled = frame[["az_mps2", "t_s", "ax_mps2", "ay_mps2"]].assign(other=1.0)
    read = spincal.read(shuffled)
    np.testing.assert_array_equal(read.accel, rec.accel)
    np.testing.assert_array_equal(read.time, rec.time)
    assert read.format == "pandas DataFrame" and read.columns == ["t_s", "ax_mps2", "ay_mps2", "az_mps2"]
    # Named (or by 1-based position), units as keywords.
    renamed = pd.DataFrame({"clock": frame["t_s"] * 1000, "a": frame["ax_mps2"] / 9.80665, "b": frame["ay_mps2"] / 9.80665, "c": frame["az_mps2"] / 9.80665})
    named = spincal.read(renamed, columns=["clock", "a", "b", "c"], accel_unit="g", time_unit="ms")
    by_position = spincal.read(renamed, columns=[1, 2, 3, 4], accel_unit="g", time_unit="ms")
    np.testing.assert_array_equal(named.accel, by_position.accel)
    np.testing.assert_allclose(named.accel, rec.accel, rtol=1e-15)
    # No time column: the sample rate stands in, as `--sample-rate`.
    untimed = frame[["ax_mps2", "ay_mps2", "az_mps2"]]
    with pytest.raises(spincal.FormatError, match=r"columns=\[") as caught:
        spincal.read(untimed)
    assert "--columns" not in str(caught.value)  # Python's words, not the CLI's flag
    at_rate = spincal.read(untimed, sample_rate_hz=100.0)
    np.testing.assert_array_equal(at_rate.accel, rec.accel)
    assert at_rate.time[1] == 1 / 100.0 and at_rate.sample_rate_hz == pytest.approx(100.0)
    also = spincal.read(renamed, columns=[None, "a", "b", "c"], accel_unit="g", sample_rate_hz=100.0)
    np.testing.assert_array_equal(also.accel, named.accel)
    with pytest.raises(spincal.FormatError, match="no column 'nope'"):
        spincal.read(frame, columns=["t_s", "nope", "ay_mps2", "az_mps2"])


def test_polars_frames_are_read_as_pandas_ones(simulated):
    pl = pytest.importorskip("polars")
    path, rec, _ = simulated
    frame = pl.read_csv(path)
    read = spincal.read(frame)
    assert read.format == "polars DataFrame"
    np.testing.assert_array_equal(read.accel, rec.accel)
    np.testing.assert_array_equal(read.time, rec.time)


def test_not_a_number_is_refused_the_same_way_everywhere(tmp_path, small_corrector):
    t = np.arange(5) / 100.0
    a = np.tile([0.0, 0.0, 9.81], (5, 1))
    a[3, 1] = float("nan")
    # A whole recording cannot hold NaN: read() of a file or a frame, and recording(), refuse it
    # with the row (or line) and column.
    with pytest.raises(spincal.FormatError, match=r"row 3, column ay_mps2: the value is NaN") as caught:
        spincal.recording(t, a)
    assert (caught.value.row, caught.value.column_name) == (3, "ay_mps2")
    frame = pd.DataFrame({"t": t, "ax": a[:, 0], "ay": a[:, 1], "az": a[:, 2]})
    with pytest.raises(spincal.FormatError, match=r"<DataFrame>: row 3, column ay: the value is NaN") as caught:
        spincal.read(frame)
    assert (caught.value.row, caught.value.column, caught.value.column_name) == (3, 3, "ay")
    path = tmp_path / "nan.csv"
    frame.to_csv(path, index=False, na_rep="NaN")
    with pytest.raises(spincal.FormatError, match=r"nan.csv:5, column 3 \(ay\): the value is NaN") as caught:
        spincal.read(path)
    assert (caught.value.line, caught.value.column) == (5, 3)
    # NaN times no longer make a recording (its sample rate would be NaN).
    with pytest.raises(spincal.FormatError, match="column t: the value is NaN"):
        spincal.recording([0.0, float("nan"), 0.02], np.zeros((3, 3)))
    # Correction marks the row as `spincal correct` does and goes on.
    linear = small_corrector
    out = linear.correct(a)
    assert out.status.tolist()[3].startswith("refused: row 3: column ay_mps2: the value is NaN")
    assert not out.status[4].startswith("refused") and out.valid[2] == (out.status[2] == "ok")
    # A null in a pandas nullable column is the same as NaN.
    nullable = frame.astype({"ay": "Float64"})
    nullable.loc[3, "ay"] = pd.NA
    assert spincal.correct(linear, nullable).status[3].startswith("refused: row 3: column ay: the value is NaN")


def test_lists_and_tuples_are_arrays(small_corrector):
    rows = [[0.0, 0.0, 9.81]] * 4
    linear = small_corrector
    np.testing.assert_array_equal(linear.correct(rows).accel, linear.correct(np.array(rows)).accel)
    np.testing.assert_array_equal(linear.correct(tuple(map(tuple, rows))).accel, linear.correct(np.array(rows)).accel)
    rec = spincal.recording([0.0, 0.01, 0.02, 0.03], rows)
    assert len(rec) == 4 and rec.accel.dtype == np.float64
    with pytest.raises(spincal.UsageError, match="t has 3 rows, ax_mps2 has 4"):
        spincal.recording([0.0, 0.01, 0.02], rows)
    with pytest.raises(spincal.UsageError, match="gx_radps has 3 rows"):
        spincal.recording(None, rows, gyro=rows[:3], sample_rate_hz=100.0)
    with pytest.raises(spincal.UsageError, match=r"accel: expected an \(n, 3\) array"):
        linear.correct([1.0, 2.0, 3.0])
    noise = np.random.default_rng(2).normal(0.0, 0.01, (2000, 3))
    r = spincal.allan(noise.tolist(), dt_s=0.1)
    np.testing.assert_array_equal(r.adev, spincal.allan(noise, dt_s=0.1).adev)
    assert r.adev.shape == (len(r.tau_s), 3)


@pytest.fixture(scope="module")
def small_corrector(cli, tmp_path_factory):
    """A small network on x and y trained by the CLI on a simulated session against its turntable
    fit's reference."""
    rec, _ = spincal.simulate(seed=4, turntable={"duration_s": 20.0})
    folder = tmp_path_factory.mktemp("small")
    rec.write_csv(folder / "rec.csv", unit="mps2")
    cli("fit", folder / "rec.csv", "--radius", "0.1", "--reference-csv", folder / "ref.csv")
    cli("train", "--data", folder / "rec.csv", "--reference", folder / "ref.csv", "--hidden", "2", "--restarts", "1", "-o", folder / "model.json")
    return spincal.load_corrector(folder / "model.json")


def test_the_output_frame_keeps_the_index_and_the_status(small_corrector):
    rec, _ = spincal.simulate(seed=6, turntable={"duration_s": 10.0})
    corrector = small_corrector
    index = pd.date_range("2026-01-01", periods=len(rec), freq="10ms", name="when")
    frame = pd.DataFrame(rec.accel, columns=["acc_x", "acc_y", "acc_z"], index=index)
    out = corrector.correct(frame).to_pandas()
    assert out.index.equals(index)
    assert list(out.columns) == [f"a{a}_corrected_mps2" for a in corrector.axes] + ["valid", "status"]
    assert out["status"].dtype == "category" and set(out["status"].unique()) <= {"ok", "physics-only", "outside-range"}
    np.testing.assert_array_equal(out["ax_corrected_mps2"].to_numpy(), corrector.correct(rec.accel).accel[:, 0])
    assert not math.isnan(out["ay_corrected_mps2"].iloc[-1])


def test_a_thermal_model_corrects_a_frame_by_its_temperature_as_the_cli_does(cli, tmp_path):
    """A campaign that logged its temperature: the frame's `temp_c` column is read by the same
    rules, the causal die temperature is the CLI's, and rows without a temperature or outside the
    fitted range are marked alike."""
    sim = tmp_path / "warm"
    cli("simulate", "--thermal", sim, "--seed", "4")
    cli("calibrate", "--campaign", sim / "campaign.toml", "--out", tmp_path / "cal")
    model = tmp_path / "cal" / "model.json"
    corrector = spincal.load_corrector(model)
    assert corrector.has_thermal
    frame = pd.read_csv(sim / "held-out-40.csv", float_precision="round_trip")
    frame.loc[50, "temp_c"] = float("nan")
    frame.loc[60, "temp_c"] = 95.0
    source = tmp_path / "in.csv"
    frame.to_csv(source, index=False, na_rep="")
    frame = pd.read_csv(source, float_precision="round_trip")
    cli_out = tmp_path / "cli.csv"
    cli("correct", "--model", model, source, "-o", cli_out)
    rows = _cli_rows(cli_out)
    ours = frame.join(corrector.correct(frame).to_pandas())
    assert list(ours.columns) == list(rows[0].keys())
    for k, row in enumerate(rows):
        assert ours.at[k, "status"] == row["status"], k
        assert bool(ours.at[k, "valid"]) == (row["valid"] == "1"), k
        for column in ("ax_corrected_mps2", "ay_corrected_mps2", "az_corrected_mps2"):
            assert float(row[column]) == ours.at[k, column], (k, column)
    assert ours.at[50, "status"] == "no-temperature"
    # A lone 95 °C among warm rows is a glitch a die cannot make: kept out of the die estimate.
    assert ours.at[60, "status"] == "suspect-temperature"
    assert (ours["status"] == "ok").sum() == len(ours) - 2
    # Without the temperature every row is marked, with a warning.
    with pytest.warns(UserWarning, match="no temperature"):
        bare = corrector.correct(frame[["t_s", "ax_mps2", "ay_mps2", "az_mps2"]])
    assert set(bare.status) == {"no-temperature"}


def test_a_frames_temperature_column_is_read_in_its_unit():
    """`read` keeps a DataFrame's temperature as every reader does (°C, Kelvin by its suffix), and
    `recording` takes one in °C; a NaN temperature is refused like any other value."""
    t = np.arange(5) * 0.01
    frame = pd.DataFrame({"t": t, "ax": 0.0, "ay": 0.0, "az": 9.81, "temp_k": 300.15 + t})
    kelvin = spincal.read(frame).temperature
    assert kelvin is not None
    np.testing.assert_allclose(kelvin, 27.0 + t, atol=1e-12)
    celsius = spincal.recording(t, [[0.0, 0.0, 9.81]] * 5, temperature=[20.0] * 5).temperature
    assert celsius is not None and celsius.tolist() == [20.0] * 5
    frame.loc[2, "temp_k"] = float("nan")
    with pytest.raises(spincal.FormatError, match="temp_k"):
        spincal.read(frame)
