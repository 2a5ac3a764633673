"""Times numpy lstsq, spincal's ARX algorithm in numpy (QR of [Phi | y]), pysib and SIPPY on the benchmark data written by run.sh; prints one JSON line
per peer and case with the best and median of RUNS timed fits after one warm-up fit (the rule
spincal's side follows in examples/sysid_bench.rs).

Usage: bench_peers.py ARX_CSV BJ_CSV [RUNS]   (default 3)
"""
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import peers  # noqa: E402


def timed(fn, runs):
    """(result, times): one warm-up call, then `runs` timed calls (fit only, wall time)."""
    result = fn()
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return result, times


def line(peer, case, times, **extra):
    s = sorted(times)
    print(json.dumps({"peer": peer, "case": case, "runs": len(times), "seconds": s[0],
                      "median_seconds": s[len(s) // 2], **extra}), flush=True)


def main(arx_csv, bj_csv, runs):
    d = np.loadtxt(arx_csv, delimiter=",", skiprows=1)
    u, y = d[:, 0], d[:, 1]
    theta, times = timed(lambda: peers.arx_numpy([u], y, 6, [8], [1]), runs)
    line("numpy-lstsq", "arx", times, theta=np.asarray(theta).tolist())
    theta, times = timed(lambda: peers.arx_numpy_qr([u], y, 6, [8], [1]), runs)
    line("numpy-qr", "arx", times, theta=np.asarray(theta).tolist())
    import pysib

    (th, _), times = timed(lambda: pysib.arx(u, y, 6, 8, 1), runs)
    line("pysib", "arx", times, theta=np.asarray(th).ravel().tolist())
    from sippy_unipi import system_identification

    _, times = timed(lambda: system_identification(y, u, "ARX", ARX_orders=[6, 8, 1]), runs)
    line("sippy", "arx", times)

    d = np.loadtxt(bj_csv, delimiter=",", skiprows=1)
    u, y = d[:, 0], d[:, 1]
    n = len(y)
    tr, va = slice(0, n // 2), slice(n // 2, n)
    for name, fn in [("pysib", peers.pysib_bj), ("sippy", peers.sippy_bj)]:
        m, times = timed(lambda: fn(u[tr], y[tr], 4, 4, 4, 4, 1), runs)
        sim, pred = peers.bj_scores(m, u[va], y[va])
        line(name, "bj", times, validation_simulation_fit_percent=sim if np.isfinite(sim) else None,
             validation_one_step_fit_percent=pred if np.isfinite(pred) else None)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 3)
