#!/usr/bin/env python3
"""The thermal fit of spincal (`fit_thermal`, lag and orders fixed) with scipy.optimize.least_squares.

Usage: scipy_thermal.py OUT_DIR [--reps N] [--methods lm,trf] [--jac analytic|2-point]

Reads OUT_DIR/windows.csv and OUT_DIR/spincal_fit.json written by the `thermal_bench` example.
First rebuilds the windows from the CSV files of the data folder with numpy (the die temperature
from the reported one: dequantised, a 60 s centred straight line, plus lag x slope; recordings on
one clock merged into one track) and checks them against windows.csv. Then fits, on the windows
spincal cut (so both sides solve the same problem):

    m_k = b_k + beta_k(dT) + (1 + s_k)(1 + rho_k(dT)) ((I + M) f)_k,   dT = T_die - T_ref

with beta and rho of order 2 (no constant term), f = g u_r, u_r each recording's gravity direction
as two angles (a, b): u = (u0 + a e1 + b e2) / |...|, u0 the direction of the recording's mean
window reading, e1 = unit(u0 x h) with h = x unless |u0_x| >= 0.6 (then y), e2 = u0 x e1. All
parameters start at zero, as spincal's. Times each method REPS times after a warm-up (best,
median) and prints the largest difference from spincal's fitted sensor parameters.
"""
import argparse
import json
import os
import statistics
import time

import numpy as np
from scipy.optimize import least_squares


# ---------------------------------------------------------------- windows rebuilt from the CSVs
def read_csv(path):
    a = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return a[:, 0], a[:, 1:4], a[:, 4]


def dequantised(t, rep):
    """A temperature reported in coarse steps as the line through the midpoints of its steps."""
    n = len(t)
    changes = np.flatnonzero(rep[1:] != rep[:-1]) + 1
    if len(changes) == 0 or len(changes) * 10 > n:
        return None
    kt = (t[changes - 1] + t[changes]) / 2
    kv = (rep[changes - 1] + rep[changes]) / 2
    step = np.min(np.abs(rep[changes] - rep[changes - 1]))

    def slope(i, j):
        return (kv[j] - kv[i]) / (kt[j] - kt[i]) if kt[j] > kt[i] else 0.0

    first = slope(0, 1) if len(kt) > 1 else 0.0
    last = slope(len(kt) - 2, len(kt) - 1) if len(kt) > 1 else 0.0
    k = np.searchsorted(kt, t, side="right")  # knots at or before each sample
    out = np.empty(n)
    before, after = k == 0, k == len(kt)
    inner = ~before & ~after
    lo = rep - step / 2
    hi = rep + step / 2
    out[before] = np.clip(kv[0] + first * (t[before] - kt[0]), lo[before], hi[before])
    out[after] = np.clip(kv[-1] + last * (t[after] - kt[-1]), lo[after], hi[after])
    a, b = k[inner] - 1, k[inner]
    dt = kt[b] - kt[a]
    sl = np.where(dt > 0, (kv[b] - kv[a]) / np.where(dt > 0, dt, 1.0), 0.0)
    out[inner] = kv[a] + sl * (t[inner] - kt[a])
    return out


def die_temperature(t, rep, lag, smoothing):
    """Value plus lag x slope of a least-squares line over a centred window of the reported values."""
    v = dequantised(t, rep)
    v = rep if v is None else v
    tr = t - t[0]
    sums = np.zeros((len(t) + 1, 5))
    sums[1:] = np.cumsum(np.stack([np.ones_like(tr), tr, tr * tr, v, tr * v], axis=1), axis=0)
    half = smoothing / 2
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right")
    c, st, stt, sv, stv = (sums[hi] - sums[lo]).T
    mt, mv = st / c, sv / c
    var = stt / c - mt * mt
    ok = (c >= 3) & (var > 1e-12)
    sl = np.where(ok, (stv / c - mt * mv) / np.where(ok, var, 1.0), 0.0)
    return mv + sl * (tr - mt) + lag * sl


def rebuild_windows(data_dir, files, lag, smoothing, window_s):
    recs = [read_csv(os.path.join(data_dir, f)) for f in files]
    order = sorted(range(len(recs)), key=lambda i: recs[i][0][0])
    tracks, track = [], []
    for i in order:
        if track:
            gap = recs[i][0][0] - recs[track[-1]][0][-1]
            if not (0 < gap <= smoothing):
                tracks.append(track)
                track = []
        track.append(i)
    tracks.append(track)
    dies = [None] * len(recs)
    for tr in tracks:
        t = np.concatenate([recs[i][0] for i in tr])
        rep = np.concatenate([recs[i][2] for i in tr])
        d = die_temperature(t, rep, lag, smoothing)
        at = 0
        for i in tr:
            dies[i] = d[at:at + len(recs[i][0])]
            at += len(recs[i][0])
    rows = []
    for r, ((t, acc, _), die) in enumerate(zip(recs, dies)):
        start = 0
        while start < len(t):
            end = start + int(np.searchsorted(t[start:], t[start] + window_s, side="left"))
            if end == len(t) and t[end - 1] - t[start] < 0.9 * window_s:
                break
            rows.append([r, *acc[start:end].mean(axis=0), die[start:end].mean()])
            start = end
    return np.array(rows)


# ---------------------------------------------------------------- the model
class Thermal:
    def __init__(self, rec, reading, die, reference, gravity, kb=2, ks=2):
        self.rec, self.m, self.g = rec.astype(int), reading, gravity
        self.kb, self.ks = kb, ks
        self.n_rec = self.rec.max() + 1
        self.n_sensor = 9 + 3 * (kb + ks)
        dt = die - reference
        self.pw = np.stack([dt ** (j + 1) for j in range(max(kb, ks))], axis=1)  # windows x order
        frames = []
        for r in range(self.n_rec):
            s = reading[self.rec == r].sum(axis=0)
            u = s / np.linalg.norm(s)
            h = np.array([1.0, 0, 0]) if abs(u[0]) < 0.6 else np.array([0, 1.0, 0])
            e1 = np.cross(u, h)
            e1 /= np.linalg.norm(e1)
            frames.append([u, e1, np.cross(u, e1)])
        self.frames = np.array(frames)  # rec x 3 x 3

    def n_params(self):
        return self.n_sensor + 2 * self.n_rec

    def unpack(self, p):
        kb, ks = self.kb, self.ks
        beta = p[9:9 + 3 * kb].reshape(3, kb)
        rho = p[9 + 3 * kb:self.n_sensor].reshape(3, ks)
        return p[0:3], p[3:6], p[6:9], beta, rho

    def directions(self, p):
        ang = p[self.n_sensor:].reshape(self.n_rec, 2)
        w = self.frames[:, 0] + ang[:, :1] * self.frames[:, 1] + ang[:, 1:] * self.frames[:, 2]
        norm = np.linalg.norm(w, axis=1, keepdims=True)
        return w / norm, norm

    def parts(self, p):
        b, s, mis, beta, rho = self.unpack(p)
        u, norm = self.directions(p)
        f = self.g * u[self.rec]  # windows x 3
        v = f.copy()
        v[:, 1] += mis[0] * f[:, 0]
        v[:, 2] += mis[1] * f[:, 0] + mis[2] * f[:, 1]
        bchange = self.pw[:, :self.kb] @ beta.T  # windows x 3
        rchange = self.pw[:, :self.ks] @ rho.T
        return b, s, mis, u, norm, f, v, bchange, rchange

    def residuals(self, p):
        b, s, mis, u, norm, f, v, bc, rc = self.parts(p)
        pred = b + bc + (1 + s) * (1 + rc) * v
        return (self.m - pred).ravel()

    def jacobian(self, p):
        kb, ks, ns = self.kb, self.ks, self.n_sensor
        b, s, mis, u, norm, f, v, bc, rc = self.parts(p)
        nw = len(self.m)
        J = np.zeros((nw, 3, self.n_params()))
        gain = (1 + s) * (1 + rc)  # windows x 3
        for k in range(3):
            J[:, k, k] = -1
            J[:, k, 3 + k] = -(1 + rc[:, k]) * v[:, k]
            J[:, k, 9 + k * kb:9 + (k + 1) * kb] = -self.pw[:, :kb]
            J[:, k, 9 + 3 * kb + k * ks:9 + 3 * kb + (k + 1) * ks] = -(1 + s[k]) * self.pw[:, :ks] * v[:, k:k + 1]
        J[:, 1, 6] = -gain[:, 1] * f[:, 0]
        J[:, 2, 7] = -gain[:, 2] * f[:, 0]
        J[:, 2, 8] = -gain[:, 2] * f[:, 1]
        skew = np.array([[1, 0, 0], [mis[0], 1, 0], [mis[1], mis[2], 1]])
        for a in range(2):
            e = self.frames[:, 1 + a]  # rec x 3
            du = (e - u * (u * e).sum(axis=1, keepdims=True)) / norm  # rec x 3
            dv = (du @ skew.T)[self.rec]  # windows x 3
            cols = ns + 2 * self.rec + a
            J[np.arange(nw)[:, None], np.arange(3)[None, :], cols[:, None]] = -gain * self.g * dv
        return J.reshape(3 * nw, -1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--methods", default="lm,trf")
    ap.add_argument("--jac", default="analytic", choices=["analytic", "2-point"])
    a = ap.parse_args()
    sp = json.load(open(os.path.join(a.out, "spincal_fit.json")))
    model, st = sp["model"], sp["settings"]
    win = np.loadtxt(os.path.join(a.out, "windows.csv"), delimiter=",", skiprows=1, ndmin=2)

    # The windows rebuilt from the CSVs with numpy, against the example's.
    t0 = time.perf_counter()
    mine = rebuild_windows(sp["data_dir"], sp["still_files"], st["lags_s"][0], st["smoothing_s"], st["window_s"])
    t_win = time.perf_counter() - t0
    same_shape = mine.shape == win.shape and np.array_equal(mine[:, 0], win[:, 0])
    dr = np.max(np.abs(mine[:, 1:4] - win[:, 1:4])) if same_shape else float("nan")
    dd = np.max(np.abs(mine[:, 4] - win[:, 4])) if same_shape else float("nan")
    print(f"windows rebuilt in numpy ({t_win:.3f} s, once): {len(mine)} against spincal's {len(win)}, "
          f"largest difference {dr:.1e} m/s2 in the mean reading, {dd:.1e} C in the die temperature")

    prob = Thermal(win[:, 0], win[:, 1:4], win[:, 4], model["reference_c"], sp["gravity_mps2"])
    x0 = np.zeros(prob.n_params())
    ours = np.concatenate([model["bias_mps2"], model["scale_error"], model["misalignment_rad"],
                           np.ravel(model["bias_per_c"]), np.ravel(model["scale_per_c"])])
    se = np.concatenate([np.ravel(sp["bias_per_c_se"]), np.ravel(sp["scale_per_c_se"])])
    names = ["b", "s", "M", "beta", "rho"]
    groups = [slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 15), slice(15, 21)]
    jac = prob.jacobian if a.jac == "analytic" else "2-point"
    for method in a.methods.split(","):
        run = lambda: least_squares(prob.residuals, x0, jac=jac, method=method)
        res = run()  # warm-up
        times = []
        for _ in range(a.reps):
            t = time.perf_counter()
            res = run()
            times.append(time.perf_counter() - t)
        d = np.abs(res.x[:21] - ours)
        rel = d / np.maximum(np.abs(ours), 1e-300)
        rms = np.sqrt(np.mean(res.fun ** 2))
        out = dict(method=method, jac=a.jac, best_s=min(times), median_s=statistics.median(times),
                   repetitions=a.reps, nfev=int(res.nfev), njev=None if res.njev is None else int(res.njev),
                   status=int(res.status), residual_rms=rms,
                   spincal_residual_rms=sp["residual_rms_mps2"],
                   max_abs_diff={n: float(d[g].max()) for n, g in zip(names, groups)},
                   max_diff_over_se=float((d[9:21] / se).max()),
                   max_rel_diff=float(rel.max()),
                   params=res.x[:21].tolist(),
                   windows_check=dict(count=len(mine), max_reading_diff=float(dr), max_die_diff=float(dd)))
        json.dump(out, open(os.path.join(a.out, f"scipy_{method}_{a.jac}.json"), "w"), indent=1)
        print(f"scipy {method}/{a.jac}: best {min(times):.4f} s, median {statistics.median(times):.4f} s of {a.reps}; "
              f"nfev {res.nfev}, njev {res.njev}, status {res.status}; residual RMS {rms:.9e} (spincal "
              f"{sp['residual_rms_mps2']:.9e}); largest |diff| from spincal: "
              + ", ".join(f"{n} {d[g].max():.1e}" for n, g in zip(names, groups))
              + f"; beta/rho largest |diff|/SE {out['max_diff_over_se']:.1e}")


if __name__ == "__main__":
    main()
