#!/usr/bin/env python3
"""The flight stacks' thermal method in numpy/scipy, judged on the held-out poses against spincal's
corrector and the oracle.

Usage: flight_stack.py OUT_DIR

Reads OUT_DIR/spincal_fit.json and OUT_DIR/spincal_held_out.csv (the `thermal_bench` example) and
the data folder they name (warmup-00.csv, pose-NN.csv, held-out-NN.csv, their .truth.csv and
truth.json, as `spincal simulate --thermal` writes them).

The method (ArduPilot / PX4 style, written here from its description, not from their code):
  1. per axis, a cubic of the warm-up's 2 s mean reading against the 2 s mean *reported*
     temperature, in (T - T_ref) with T_ref spincal's reference temperature; the change it predicts
     relative to T_ref (the constant term dropped) is subtracted from every reading;
  2. a static calibration of the compensated poses: their 2 s window means fitted with
     scipy.optimize.least_squares (trf, 2-point Jacobian) by m = b + (1 + s) * ((I + M) g u_r),
     M lower triangular (m_yx, m_zx, m_zy), one gravity direction per pose as two spherical angles.
The held-out readings are compensated with the cubic at their reported temperature, then corrected
by the static model.

Error, as crates/spincal/tests/thermal.rs computes it: the held-out samples in 1 s blocks; blocks
whose middle sample's true die temperature lies in the coldest or hottest fifth of all held-out
samples' true die temperatures; RMS over those blocks and the three axes of the block's mean
(corrected - true force). The oracle corrects with the true model (truth.json) at the true die
temperature. Printed: the three errors and the excess ratio
sqrt(e_spincal^2 - e_oracle^2) / sqrt(e_flight^2 - e_oracle^2).
"""
import json
import os
import sys

import numpy as np
from scipy.optimize import least_squares


def read_csv(path):
    a = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return a[:, 0], a[:, 1:4], a[:, 4]


def block_means(t, x, seconds):
    """Means of consecutive blocks of `seconds` (whole blocks only) from the first sample."""
    per = int(round(seconds / np.median(np.diff(t))))
    n = (len(t) - 1) // per  # as the test: starts 0, per, ... strictly below len - per
    return x[: n * per].reshape(n, per, *x.shape[1:]).mean(axis=1)


def windows(t, x, seconds):
    """spincal's still windows: from each window's first sample to before t + seconds; a last one
    shorter than 0.9 of that dropped."""
    out, start = [], 0
    while start < len(t):
        end = start + int(np.searchsorted(t[start:], t[start] + seconds, side="left"))
        if end == len(t) and t[end - 1] - t[start] < 0.9 * seconds:
            break
        out.append(x[start:end].mean(axis=0))
        start = end
    return np.array(out)


def correct(m, b, s, mis, bias_change=0.0, gain_change=0.0):
    """Inverse of m = b + beta + (1 + s)(1 + rho)(I + M) f for rows of m."""
    v = (m - b - bias_change) / ((1 + s) * (1 + gain_change))
    x = v[:, 0]
    y = v[:, 1] - mis[0] * x
    z = v[:, 2] - mis[1] * x - mis[2] * y
    return np.stack([x, y, z], axis=1)


def poly(coeffs, dt):
    """sum_j c_j dT^(j+1), coeffs per axis (3 x order), dT per sample -> samples x 3."""
    coeffs = np.asarray(coeffs, dtype=float).reshape(3, -1)
    return sum(np.outer(dt ** (j + 1), coeffs[:, j]) for j in range(coeffs.shape[1]))


def band_error(die_per_file, err_per_file, rate):
    temps = np.sort(np.concatenate(die_per_file))
    cold, hot = temps[len(temps) // 5], temps[len(temps) * 4 // 5]
    means = []
    for die, err in zip(die_per_file, err_per_file):
        for start in range(0, len(die), rate):
            end = min(start + rate, len(die))
            mid = die[(start + end) // 2]
            if end - start < rate or cold < mid < hot:
                continue
            means.append(err[start:end].mean(axis=0))
    return float(np.sqrt(np.mean(np.square(means))))


def main():
    out = sys.argv[1]
    sp = json.load(open(os.path.join(out, "spincal_fit.json")))
    data = sp["data_dir"]
    truth = json.load(open(os.path.join(data, "truth.json")))
    g = sp["gravity_mps2"]
    t_ref = sp["model"]["reference_c"]
    window_s = sp["settings"]["window_s"]

    # 1. The cubic per axis on the warm-up against the reported temperature.
    t, acc, rep = read_csv(os.path.join(data, "warmup-00.csv"))
    temp2 = block_means(t, rep, 2.0)
    acc2 = block_means(t, acc, 2.0)
    cubic = [np.polyfit(temp2 - t_ref, acc2[:, k], 3) for k in range(3)]  # highest power first

    def change(reported):
        dt = reported - t_ref
        return np.stack([np.polyval(c, dt) - c[-1] for c in cubic], axis=1)

    # 2. Static calibration of the compensated poses.
    poses = [f for f in sp["still_files"] if f.startswith("pose-")]
    means, owner = [], []
    for r, f in enumerate(poses):
        t, acc, rep = read_csv(os.path.join(data, f))
        w = windows(t, acc - change(rep), window_s)
        means.append(w)
        owner += [r] * len(w)
    means, owner = np.concatenate(means), np.array(owner)
    start_dir = np.array([means[owner == r].mean(axis=0) for r in range(len(poses))])
    start_dir /= np.linalg.norm(start_dir, axis=1, keepdims=True)
    theta0 = np.arccos(np.clip(start_dir[:, 2], -1, 1))
    phi0 = np.arctan2(start_dir[:, 1], start_dir[:, 0])

    def residuals(p):
        b, s, mis = p[0:3], p[3:6], p[6:9]
        th, ph = p[9::2], p[10::2]
        u = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=1)[owner]
        f = g * u
        v = np.stack([f[:, 0], f[:, 1] + mis[0] * f[:, 0], f[:, 2] + mis[1] * f[:, 0] + mis[2] * f[:, 1]], axis=1)
        return (means - (b + (1 + s) * v)).ravel()

    x0 = np.concatenate([np.zeros(9), np.stack([theta0, phi0], axis=1).ravel()])
    fit = least_squares(residuals, x0, method="trf", jac="2-point")
    b, s, mis = fit.x[0:3], fit.x[3:6], fit.x[6:9]

    # 3. The held-out poses: the three correctors.
    ours_rows = np.loadtxt(os.path.join(out, "spincal_held_out.csv"), delimiter=",", skiprows=1,
                           usecols=(1, 2, 3, 4), ndmin=2)
    tm = truth["model"]
    errs = {"oracle": [], "spincal": [], "flight stacks": []}
    dies, at, rate = [], 0, None
    for f in sp["held_out_files"]:
        t, acc, rep = read_csv(os.path.join(data, f))
        _, force, die = read_csv(os.path.join(data, f.replace(".csv", ".truth.csv")))
        rate = rate or int(round(1 / np.median(np.diff(t))))
        dies.append(die)
        dt = die - tm["reference_c"]
        oracle = correct(acc, np.array(tm["bias_mps2"]), np.array(tm["scale_error"]), tm["misalignment_rad"],
                         poly(tm["bias_per_c"], dt), poly(tm["scale_per_c"], dt))
        peer = correct(acc - change(rep), b, s, mis)
        rows = ours_rows[at:at + len(t)]
        assert np.array_equal(rows[:, 0], np.arange(len(t))), "spincal_held_out.csv out of step"
        at += len(t)
        errs["oracle"].append(oracle - force)
        errs["flight stacks"].append(peer - force)
        errs["spincal"].append(rows[:, 1:4] - force)
    e = {k: band_error(dies, v, rate) for k, v in errs.items()}
    ex = lambda x: np.sqrt(max(x * x - e["oracle"] ** 2, 0.0))
    ratio = ex(e["spincal"]) / ex(e["flight stacks"])
    mine = sp["held_out"]
    print(f"flight stacks' static fit: {len(means)} windows of {len(poses)} poses, trf/2-point, nfev {fit.nfev}, "
          f"residual RMS {np.sqrt(np.mean(fit.fun ** 2)):.6f} m/s2; cubic on {len(temp2)} 2 s means of the warm-up")
    print("held-out band RMS of 1 s means (m/s2): oracle %.6f, spincal %.6f, flight stacks %.6f" % (
        e["oracle"], e["spincal"], e["flight stacks"]))
    print("spincal/oracle %.3f, flight stacks/oracle %.3f, excess ratio spincal/flight stacks %.3f" % (
        e["spincal"] / e["oracle"], e["flight stacks"] / e["oracle"], ratio))
    print("check against the example's own figures: spincal %.1e, oracle %.1e (absolute differences, m/s2)" % (
        abs(e["spincal"] - mine["spincal_band_rms_mps2"]), abs(e["oracle"] - mine["oracle_band_rms_mps2"])))
    json.dump(dict(errors=e, excess_ratio=ratio, static_fit=dict(b=b.tolist(), s=s.tolist(), m=mis.tolist()),
                   cubic=[c.tolist() for c in cubic]),
              open(os.path.join(out, "flight_stack.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
