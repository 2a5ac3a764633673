"""Benchmarks of the Python package (run by bench/python/run.sh)."""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time

import numpy as np

import spincal


def untimed(value):
    """Results without their timings (the only fields that differ between runs)."""
    if isinstance(value, dict):
        return {k: untimed(v) for k, v in value.items() if "seconds" not in k}
    if isinstance(value, list):
        return [untimed(v) for v in value]
    return value


def timed(fn, reps):
    fn()  # warm-up
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times), statistics.median(times)


def timed_interleaved(fns, reps):
    """Each function once per round, round after round (after one warm-up round), so that a
    change of the machine's load falls on all of them alike; (best, median) of each."""
    for fn in fns:
        fn()
    times = [[] for _ in fns]
    for _ in range(reps):
        for k, fn in enumerate(fns):
            t = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t)
    return [(min(ts), statistics.median(ts)) for ts in times]


def bench_correct(args):
    out = os.path.join(args.out, "correct")
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    rows = args.rows
    # A network corrector from a quick calibration of a simulated session.
    rec, _ = spincal.simulate(seed=1)
    cal = spincal.calibrate([rec], radius_m=0.1, hidden=[10, 6], restarts=1)
    model = os.path.join(out, "model.json")
    cal.corrector.save(model)
    # 10^6 rows: the session repeated, time continued (m/s² columns).
    reps_needed = -(-rows // len(rec))
    accel = np.tile(rec.accel, (reps_needed, 1))[:rows]
    t = np.arange(rows) / rec.sample_rate_hz
    big = spincal.recording(t, accel, name="big")
    csv = os.path.join(out, "big.csv")
    big.write_csv(csv, unit="mps2")
    corrector = spincal.load_corrector(model)
    cpu = ["taskset", "-c", str(args.cpu)]
    os.sched_setaffinity(0, {args.cpu})

    array = big.accel  # (n, 3), Fortran-ordered view
    contiguous = np.ascontiguousarray(array)
    best_file, med_file = timed(lambda: corrector.correct(csv), args.reps)
    cli_out = os.path.join(out, "cli.csv")
    best_cli, med_cli = timed(
        lambda: subprocess.run(cpu + [args.cli, "correct", "--model", model, csv, "-o", cli_out], check=True), args.reps
    )
    # DataFrame in, DataFrame out (the output frame built, the status per row included) against
    # array in, arrays out: the frame's columns are handed over as arrays, never as text.
    import pandas as pd

    # Timed in alternation with the array path (the same rounds), against the same rows.
    import polars as pl

    frame = pd.DataFrame({"t_s": t, "ax_mps2": array[:, 0], "ay_mps2": array[:, 1], "az_mps2": array[:, 2]})
    polars_frame = pl.from_pandas(frame)
    (best_arr, med_arr), (best_c, med_c), (best_df, med_df), (best_pl, med_pl) = timed_interleaved(
        [
            lambda: corrector.correct(array),
            lambda: corrector.correct(contiguous),
            lambda: corrector.correct(frame).to_pandas(),
            lambda: corrector.correct(polars_frame).to_polars(),
        ],
        args.reps,
    )
    framed = corrector.correct(frame).to_pandas()
    # The numbers agree to the last bit.
    py = corrector.correct(array).accel
    frame_equal = all(np.array_equal(framed[f"a{a}_corrected_mps2"].to_numpy(), py[:, i]) for i, a in enumerate("xy"))
    got = np.genfromtxt(cli_out, delimiter=",", names=True)
    diff = max(float(np.max(np.abs(got[f"a{a}_corrected_mps2"] - py[:, i]))) for i, a in enumerate("xy"))
    # The CLI's time to read and write the same rows without a model: what it spends beyond correcting.
    result = {
        "rows": rows,
        "python_array_fortran_s": [best_arr, med_arr],
        "python_array_c_s": [best_c, med_c],
        "python_file_s": [best_file, med_file],
        "python_pandas_frame_to_frame_s": [best_df, med_df],
        "python_polars_frame_to_frame_s": [best_pl, med_pl],
        "pandas_frame_over_array_best_median": [best_df / best_arr, med_df / med_arr],
        "polars_frame_over_array_best_median": [best_pl / best_arr, med_pl / med_arr],
        "pandas_frame_over_c_array_best_median": [best_df / best_c, med_df / med_c],
        "polars_frame_over_c_array_best_median": [best_pl / best_c, med_pl / med_c],
        "frame_equals_array_bit_for_bit": frame_equal,
        "cli_file_to_file_s": [best_cli, med_cli],
        "python_array_rows_per_s": rows / best_arr,
        "python_file_rows_per_s": rows / best_file,
        "cli_rows_per_s": rows / best_cli,
        "largest_difference_vs_cli": diff,
    }
    print(json.dumps(result, indent=2))
    os.sched_setaffinity(0, set(range(os.cpu_count())))
    return result


def bench_ray(args):
    import ray
    import spincal.ray as sray

    results = {}
    t = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, object_store_memory=200 * 1024 * 1024, log_to_driver=False)

    @ray.remote(num_cpus=1)
    def noop(x):
        return x

    ray.get(noop.remote(0))
    results["ray_start_s"] = time.perf_counter() - t
    # Per-task overhead: a no-op round trip, and 1000 no-op tasks in flight.
    best, med = timed(lambda: ray.get(noop.remote(0)), 20)
    results["noop_round_trip_s"] = [best, med]
    best, med = timed(lambda: ray.get([noop.remote(i) for i in range(1000)]), args.reps)
    results["noop_1000_tasks_s"] = [best, med]
    payload = b"x" * 4_000_000
    best, med = timed(lambda: ray.get(noop.remote(payload)), args.reps)
    results["ship_4MB_round_trip_s"] = [best, med]

    campaign = spincal.simulation_defaults()["campaign"]
    for run in campaign["runs"]:
        run["duration_s"] = 30.0
    for units in args.units:
        folder = os.path.join(args.out, f"fleet-{units}")
        shutil.rmtree(folder, ignore_errors=True)
        folders, _ = spincal.simulate_fleet(folder, seed=2026, setup={"units": units, "faulty": [min(5, units - 1)], "campaign": campaign})
        _, _, files = sray.unit_payload(folders[0])
        bytes_per_unit = sum(len(v) for v in files.values())
        reps = args.reps if units <= 8 else 1
        os.sched_setaffinity(0, {args.cpu})
        loop = []
        for _ in range(reps):
            t = time.perf_counter()
            local = [spincal.calibrate_unit(f) for f in folders]
            loop.append(time.perf_counter() - t)
        os.sched_setaffinity(0, set(range(os.cpu_count())))
        dist = []
        for _ in range(reps):
            fleet = sray.calibrate_fleet(folders)
            dist.append(fleet.seconds)
        same = all(untimed(json.loads(u._results_json)) == untimed(l.result.to_dict()) for u, l in zip(fleet.units, local))
        task_seconds = [u.seconds for u in fleet.units]
        results[f"fleet_{units}"] = {
            "reps": reps,
            "loop_one_process_s": [min(loop), statistics.median(loop)],
            "ray_2cpu_s": [min(dist), statistics.median(dist)],
            "speedup_best": min(loop) / min(dist),
            "efficiency_best": min(loop) / min(dist) / 2,
            "task_seconds_mean": statistics.mean(task_seconds),
            "bytes_shipped_per_unit": bytes_per_unit,
            "results_equal_loop": same,
            "flagged": fleet.flagged_units,
        }
        print(json.dumps(results[f"fleet_{units}"], indent=2), flush=True)

    # One calibration's network sweep (the small grid, 20 architectures × 3 restarts, on a
    # 2-minute recording): here on one thread against its 60 jobs as Ray tasks on 2 CPUs.
    rec, _ = spincal.simulate(seed=3, turntable={"duration_s": 120.0})
    settings = dict(radius_m=0.10, sweep="small", restarts=3, seed=1)
    os.sched_setaffinity(0, {args.cpu})
    local_times, spread_times = [], []
    for _ in range(args.reps):
        t = time.perf_counter()
        local = spincal.calibrate([rec], **settings)
        local_times.append(time.perf_counter() - t)
    os.sched_setaffinity(0, set(range(os.cpu_count())))
    for _ in range(args.reps):
        t = time.perf_counter()
        spread = sray.calibrate([rec], jobs_per_task=1, **settings)
        spread_times.append(time.perf_counter() - t)
    stage = lambda cal: next(s["seconds"] for s in cal.result.to_dict()["stage_seconds"] if s["stage"] == "network sweep")
    results["sweep_small_grid"] = {
        "reps": args.reps,
        "calibration_one_thread_s": [min(local_times), statistics.median(local_times)],
        "calibration_ray_2cpu_s": [min(spread_times), statistics.median(spread_times)],
        "sweep_stage_one_thread_s": stage(local),
        "sweep_stage_ray_s": stage(spread),
        "sweep_speedup": stage(local) / stage(spread),
        "results_equal": untimed(local.result.to_dict()) == untimed(spread.result.to_dict()),
    }
    print(json.dumps(results["sweep_small_grid"], indent=2), flush=True)
    ray.shutdown()
    print(json.dumps(results, indent=2))
    return results


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--cli", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--cpu", type=int, default=1)
    p.add_argument("--rows", type=int, default=1_000_000)
    p.add_argument("--units", type=int, nargs="*", default=[8, 32])
    p.add_argument("--skip-correct", action="store_true")
    p.add_argument("--skip-ray", action="store_true")
    args = p.parse_args()
    summary = {}
    if not args.skip_correct:
        summary["correct"] = bench_correct(args)
    if not args.skip_ray:
        summary["ray"] = bench_ray(args)
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)


if __name__ == "__main__":
    sys.exit(main())
