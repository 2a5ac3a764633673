"""Times pysib and SIPPY on the benchmark data written by run.sh; prints one JSON line per case."""
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import peers  # noqa: E402


def main(arx_csv, bj_csv):
    d = np.loadtxt(arx_csv, delimiter=",", skiprows=1)
    u, y = d[:, 0], d[:, 1]
    t = time.perf_counter()
    theta = peers.arx_numpy([u], y, 6, [8], [1])
    print(json.dumps({"peer": "numpy-lstsq", "case": "arx", "seconds": time.perf_counter() - t, "theta": theta.tolist()}))
    import pysib

    t = time.perf_counter()
    th, _ = pysib.arx(u, y, 6, 8, 1)
    print(json.dumps({"peer": "pysib", "case": "arx", "seconds": time.perf_counter() - t, "theta": np.asarray(th).ravel().tolist()}))
    from sippy_unipi import system_identification

    t = time.perf_counter()
    system_identification(y, u, "ARX", ARX_orders=[6, 8, 1])
    print(json.dumps({"peer": "sippy", "case": "arx", "seconds": time.perf_counter() - t}))

    d = np.loadtxt(bj_csv, delimiter=",", skiprows=1)
    u, y = d[:, 0], d[:, 1]
    n = len(y)
    tr, va = slice(0, n // 2), slice(n // 2, n)
    for name, fn in [("pysib", peers.pysib_bj), ("sippy", peers.sippy_bj)]:
        t = time.perf_counter()
        m = fn(u[tr], y[tr], 4, 4, 4, 4, 1)
        sec = time.perf_counter() - t
        sim, pred = peers.bj_scores(m, u[va], y[va])
        print(json.dumps({"peer": name, "case": "bj", "seconds": sec, "validation_simulation_fit_percent": sim if np.isfinite(sim) else None, "validation_one_step_fit_percent": pred if np.isfinite(pred) else None}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
