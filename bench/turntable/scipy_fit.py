"""The turntable fit in scipy, on the same data, start, bounds and weights as spincal's fit JSON.

Model (crates/spincal/src/turntable/model.rs):
  a_x = w^2 r cos b +     g sin a sin(w t + p - b) + o_x + d_x (t - t_mid)
  a_y = w^2 r sin b + s * g sin a cos(w t + p - b) + o_y + d_y (t - t_mid)
  a_z = g cos a                                   + o_z + d_z (t - t_mid)
Residuals are weighted by 1 / noise per axis (spincal's noise_mps2). Prints both results, the
largest relative difference and the time ratio measured in this run.
"""
import json
import sys
import time

import numpy as np
from scipy.optimize import least_squares, minimize

csv_path, fit_path = sys.argv[1], sys.argv[2]
# spincal's timed runs (s), whole process each.
spincal_times = [float(v) for v in sys.argv[3].split(",")]
spincal_seconds = min(spincal_times)
fit = json.load(open(fit_path))
t0_read = time.perf_counter()
data = np.loadtxt(csv_path, delimiter=",", skiprows=1)
g_si = 9.80665
t = data[:, 0]
acc = data[:, 1:4] * g_si  # the file is in g (header ax_g…)
read_s = time.perf_counter() - t0_read

g = fit["gravity_mps2"]
names = [p["name"] for p in fit["params"]]
lower = np.array([p["lower"] for p in fit["params"]])
upper = np.array([p["upper"] for p in fit["params"]])
start = np.array(fit["start"])
weights = 1.0 / np.array(fit["noise_mps2"][0])
s = 1.0 if fit["recordings"][0]["session"]["direction"] == "ccw" else -1.0
axes = {"xyz": [0, 1, 2], "xy": [0, 1], "x": [0]}[fit["axes"]]
tr = t - t[0]
tm = t - 0.5 * (t[0] + t[-1])


def unpack(p):
    v = dict(zip(names, p))
    return (v.get("radius", 0.0), v["omega"], v["tilt"], v["phase"], v["beta"],
            [v.get("offset_" + a, 0.0) for a in "xyz"], [v.get("drift_" + a, 0.0) for a in "xyz"])


def residuals(p):
    r, w, a, ph, b, off, dr = unpack(p)
    u = w * tr + ph - b
    amp = g * np.sin(a)
    c = w * w * r
    model = (c * np.cos(b) + amp * np.sin(u) + off[0] + dr[0] * tm,
             c * np.sin(b) + s * amp * np.cos(u) + off[1] + dr[1] * tm,
             g * np.cos(a) + off[2] + dr[2] * tm + 0.0 * u)
    return np.concatenate([weights[k] * (model[k] - acc[:, k]) for k in axes])


def cost(p):
    e = residuals(p)
    return e @ e


def fit_once():
    nm = minimize(cost, start, method="Nelder-Mead", bounds=list(zip(lower, upper)),
                  options={"maxiter": 200 * len(start), "maxfev": 400 * len(start), "xatol": 1e-4,
                           "fatol": 1e-9 * cost(start)})
    ls = least_squares(residuals, np.clip(nm.x, lower, upper), bounds=(lower, upper), method="trf",
                       ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=2000)
    return nm, ls


# A warm-up, then as many identical fits as spincal's timed runs: best and median.
fit_once()
scipy_times = []
for _ in range(len(spincal_times)):
    t_start = time.perf_counter()
    nm, ls = fit_once()
    scipy_times.append(time.perf_counter() - t_start)
scipy_s = min(scipy_times)

ours = np.array([p["value"] for p in fit["params"]])
theirs = ls.x.copy()
for i, n in enumerate(names):  # spincal reports angles wrapped to (-pi, pi]
    if n.startswith("beta") or n.startswith("phase"):
        theirs[i] = (theirs[i] + np.pi) % (2 * np.pi) - np.pi
rel = np.abs(ours - theirs) / np.maximum(np.abs(theirs), 1e-12)
se = np.array([p["std_error"] or np.nan for p in fit["params"]])
print(f"{'parameter':<12} {'spincal':>20} {'scipy':>20} {'rel. diff':>10} {'diff/SE':>10}")
for n, a, b, d, e in zip(names, ours, theirs, rel, se):
    print(f"{n:<12} {a:>20.12g} {b:>20.12g} {d:>10.2e} {abs(a - b) / e:>10.2e}")
print(f"weighted SSE: spincal {fit['cost_final']:.10e}, scipy {2 * ls.cost:.10e}")
print(f"scipy: Nelder-Mead {nm.nit} iterations / {nm.nfev} evaluations, least_squares {ls.nfev} evaluations")
print(f"largest relative parameter difference: {rel.max():.2e} (goal 1e-6)")
median = lambda v: sorted(v)[len(v) // 2]
print(f"time (best / median of {len(spincal_times)} each, after a warm-up): spincal {spincal_seconds:.3f} / {median(spincal_times):.3f} s "
      f"(whole process: read, spectrum, NM, LM, errors), scipy {scipy_s:.3f} / {median(scipy_times):.3f} s "
      f"(fit only; reading took {read_s:.3f} s more)")
print(f"ratio scipy / spincal: best {scipy_s / spincal_seconds:.1f}x, median {median(scipy_times) / median(spincal_times):.1f}x (goal 20x)")
