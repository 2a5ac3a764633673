"""SIPPY BJ option sets on the benchmark data (run from the repo root after bench/sysid/run.sh):
theta = nk - 1 (SIPPY delays are on top of one sample), with and without stab_cons, at
[4 4 4 4 1] and the true orders. One JSON line per run; see RESULTS.md, "SIPPY's BJ"."""
import sys, time, json
import numpy as np
sys.path.insert(0, "bench/sysid")
import peers
from sippy_unipi.io_opt import GEN_id
d = np.loadtxt("bench/out/sysid/bj_5000.csv", delimiter=",", skiprows=1)
u, y = d[:, 0], d[:, 1]
n = len(y); tr, va = slice(0, n // 2), slice(n // 2, n)
for orders in [(4,4,4,4,1), (2,1,2,2,1)]:
    nb, nc, nd, nf, nk = orders
    for stab in [False, True]:
        t = time.perf_counter()
        num, den, numh, denh, _, _ = GEN_id("BJ", y[tr], u[tr], 0, nb, nc, nd, nf, nk - 1, 200, 1.0, stab)
        sec = time.perf_counter() - t
        # SIPPY's tf has numerator one shorter than denominator: B(q^-1) = [0, NUM...]
        m = {"B": np.concatenate([[0.0], np.atleast_1d(num)]), "F": np.atleast_1d(den), "C": np.atleast_1d(numh), "D": np.atleast_1d(denh)}
        sim, pred = peers.bj_scores(m, u[va], y[va])
        print(json.dumps({"orders": orders, "stab_cons": stab, "theta": nk - 1, "seconds": sec, "sim": sim, "pred": pred, "B": m["B"].tolist(), "F": m["F"].tolist()}), flush=True)
