"""Writes the reference fixtures under crates/spincal/tests/fixtures/sysid/.

Run with bench/.venv-sysid (see bench/sysid/setup.sh). Deterministic: fixed numpy seeds; data is
written at full precision (%.17g) so the Rust tests read exactly the same numbers.
"""
import hashlib
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import peers  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
OUT = os.path.join(ROOT, "crates", "spincal", "tests", "fixtures", "sysid")
SHARED = os.environ.get("SPINCAL_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))


def scripts_sha256():
    """What made the fixtures; the Rust test fixture_scripts fails when these change unregenerated."""
    names = ["bench/sysid/make_fixtures.py", "bench/sysid/peers.py", "bench/sysid/setup.sh"]
    return {n: hashlib.sha256(open(os.path.join(ROOT, n), "rb").read()).hexdigest() for n in names}


def write_csv(path, header, cols):
    np.savetxt(path, np.column_stack(cols), delimiter=",", header=",".join(header), comments="", fmt="%.17g")


def arx_fixture():
    rng = np.random.default_rng(20240601)
    n = 2000
    u1 = rng.standard_normal(n)
    u2 = np.sign(rng.standard_normal(n))
    e = 0.1 * rng.standard_normal(n)
    y = np.zeros(n)
    for t in range(n):
        acc = e[t]
        for k, a in enumerate([-1.3, 0.6], start=1):
            if t >= k:
                acc -= a * y[t - k]
        for k, b in [(1, 0.8), (2, -0.2)]:
            if t >= k:
                acc += b * u1[t - k]
        if t >= 2:
            acc += 0.4 * u2[t - 2]
        y[t] = acc
    write_csv(os.path.join(OUT, "arx_data.csv"), ["u1", "u2", "y"], [u1, u2, y])
    cases = []
    for na, nb, nk in [(2, [2, 1], [1, 2]), (4, [3, 3], [1, 1]), (6, [8, 2], [1, 0])]:
        theta = peers.arx_numpy([u1, u2], y, na, nb, nk)
        cases.append({"na": na, "nb": nb, "nk": nk, "theta": theta.tolist()})
    return {"source": "numpy.linalg.lstsq " + np.__version__, "cases": cases}


def silverbox_fixture():
    path = os.path.join(SHARED, "sysid", "Silverbox_SNLS80mV.csv")
    if not os.path.exists(path):
        print(f"skipped Silverbox fixture: {path} absent")
        return None
    data = np.genfromtxt(path, delimiter=",", skip_header=1, usecols=(0, 1))
    u, y = data[:, 0], data[:, 1]
    tr = slice(40650, 127400)
    te = slice(0, 40575)
    na, nb, nk = 6, 8, 1
    theta = peers.arx_numpy([u[tr]], y[tr], na, [nb], [nk])
    ys = peers.arx_simulate(theta, u[te], y[te], na, nb, nk, 50)
    rmse = float(np.sqrt(np.mean((y[te][50:] - ys[50:]) ** 2)))
    return {
        "source": "numpy.linalg.lstsq " + np.__version__ + " on the CSV (5 significant digits)",
        "train": [40650, 127400],
        "test": [0, 40575],
        "init_samples": 50,
        "orders": [na, nb, nk],
        "theta": theta.tolist(),
        "test_simulation_rmse": rmse,
        "test_simulation_fit_percent": float(peers.fit_percent(y[te][50:], ys[50:])),
    }


def bj_fixture():
    n_train, n_val = 2000, 2000
    u, y = peers.bj_data(n_train + n_val, seed=7)
    write_csv(os.path.join(OUT, "bj_data.csv"), ["u", "y"], [u, y])
    tr, va = slice(0, n_train), slice(n_train, n_train + n_val)
    results = []
    for orders in [peers.BJ_TRUE_ORDERS, (4, 4, 4, 4, 1)]:
        entry = {"orders": list(orders), "peers": {}}
        for name, fn in [("pysib", peers.pysib_bj), ("sippy", peers.sippy_bj)]:
            t = time.perf_counter()
            try:
                m = fn(u[tr], y[tr], *orders)
            except Exception as exc:  # a peer failing is recorded, not hidden
                entry["peers"][name] = {"error": repr(exc)}
                continue
            sim, pred = peers.bj_scores(m, u[va], y[va])
            entry["peers"][name] = {
                # JSON has no NaN: a diverging simulation is recorded as null.
                "validation_simulation_fit_percent": float(sim) if np.isfinite(sim) else None,
                "validation_one_step_fit_percent": float(pred) if np.isfinite(pred) else None,
                "seconds": time.perf_counter() - t,
                "model": {k: v.tolist() for k, v in m.items()},
            }
            print(name, orders, "sim %.3f one-step %.3f" % (sim, pred))
        results.append(entry)
    import importlib.metadata as md

    return {
        "data": "bj_data.csv: first 2000 samples training, next 2000 validation; zero initial conditions",
        "one_step": "predictor D/C with C's roots outside the unit circle reflected inside (peers.minimum_phase)",
        "true": peers.BJ_TRUE,
        "versions": {p: md.version(p) for p in ["pysib", "sippy-unipi", "numpy", "scipy"]},
        "cases": results,
    }


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, fn in [("arx_lstsq.json", arx_fixture), ("silverbox_arx.json", silverbox_fixture), ("bj_peers.json", bj_fixture)]:
        value = fn()
        if value is not None:
            value["scripts_sha256"] = scripts_sha256()
            with open(os.path.join(OUT, name), "w") as f:
                json.dump(value, f, indent=1)
            print("wrote", name)


if __name__ == "__main__":
    main()
