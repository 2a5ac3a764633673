#!/usr/bin/env python3
"""The joint campaign fit of spincal (campaign::joint) in numpy, solved with
scipy.optimize.least_squares, on the problem written by the `joint_fit_bench` example.

Usage: scipy_joint.py DIR [--reps N] [--methods trf,lm] [--jac 2-point|analytic]
                     [--fixture PATH --command TEXT]

DIR holds problem.json and spincal_fit.json from `joint_fit_bench SEED DIR`. The script does
what fit_joint does after its starting values:

  pass 1: weights = each run's first-difference noise per axis, each pose's standard error of
          the mean; solve;
  reweight: each run by its residual RMS per axis, each still session's poses by a variance
          component: the larger of r²/(1 − h) − σ² averaged over the session's poses (h the
          pose row's leverage under the pass-1 weights) and the bias random walk's D·T/15 over
          the session's span T (D from the poses' half-to-half differences, pooled over axes);
  spread: when the settings ask for it (estimate_bias_spread), the bias offsets' prior width
          sigma by the marginal likelihood at pass 1's solution under the new weights (the
          Laplace approximation, campaign/joint/spread.rs): a grid of 24 log-spaced values over
          1e-5 g .. 0.05 g, then scipy's bounded Brent search about the grid's best;
  pass 2: solve again from pass 1's solution, the offsets' priors at that sigma.

Both fits start from the example's starting vector (checked there to equal fit_joint's own).
The starting values (the demodulation: a coarse scan over blocks, then Newton's method) are
also computed here in numpy and timed separately, so that "start + fit" is the same work as fit_joint; the robust sandwich covariance
fit_joint also forms (one more pass over the data plus a 90x90 inverse) is not redone here.

The residual function is the documented model (module doc of campaign/joint.rs), vectorised
over the samples of each run; priors enter as residuals:
  (r - r_nominal)/tol, eps1/sigma_mount, eps2/sigma_mount, run offsets delta/sigma_bias,
  session offsets delta_s/sigma_bias, session drift rates d_s/(sigma_bias/100 s), each free
  sensor term/its datasheet width.
Runs tied to a power-on session or to a placement's radius (campaign keys the bench's
simulated campaign does not use) are not implemented: the script stops on them.

--fixture PATH writes, besides the usual output, a small JSON of the last method's fitted
parameters with the standard errors spincal reported (the test suite's joint_scipy fixture;
made by crates/spincal/tests/fixtures/joint_scipy/make.sh, whose command is --command).
"""
import argparse
import datetime
import hashlib
import json
import os
import statistics
import sys
import time

import numpy as np
import scipy
from scipy.optimize import least_squares

SENSOR = 12
RUN = 15
POSE = 2
SESSION = 6
MIN_KEPT_VARIANCE = 0.05  # the least share of a pose residual's variance the fit leaves it
# A still session's drift rate has a prior of the bias instability per this many seconds
# (campaign/joint.rs SESSION_DRIFT_S, a private constant: not in the exported settings).
SESSION_DRIFT_S = 100.0
# The marginal likelihood's search range for the offsets' spread, as multiples of g, and its grid
# (campaign/joint/spread.rs SEARCH_G and GRID).
SPREAD_SEARCH_G = (1e-5, 0.05)
SPREAD_GRID = 24


def rot_x(e):
    s, c = np.sin(e), np.cos(e)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(e):
    s, c = np.sin(e), np.cos(e)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(e):
    s, c = np.sin(e), np.cos(e)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class Problem:
    def __init__(self, prob):
        st = prob["settings"]
        self.g = prob["gravity_mps2"]
        self.bias_sigma = st["bias_instability_mps2"]
        self.mount_sigma = st["mount_tilt_rad"]
        self.sensor_sd = np.repeat(np.asarray(st.get("sensor_prior_sd", [np.inf] * 4), float), 3)
        terms = st["terms"]
        free = [terms["bias_scale"]] * 6 + [terms["misalignment"]] * 3 + [terms["nonlinearity"]] * 3
        self.sensor_free = np.array(free)
        self.estimate_spread = bool(st.get("estimate_bias_spread", False))
        self.runs = []
        for r in prob["runs"]:
            if r.get("session") is not None or r.get("placement") is not None or r["radius_m"] is None:
                sys.exit(f"{r['name']}: a run tied to a session or placement, or without a stated "
                         "radius: not implemented in this peer")
            t = np.asarray(r["time_s"], float)
            keep = np.asarray(r["keep"], bool)
            mid = 0.5 * (t[0] + t[-1])  # over all samples, kept or not
            self.runs.append(
                dict(
                    tau=(t - mid)[keep],
                    meas=np.asarray(r["accel_mps2"], float)[:, keep],
                    q=np.asarray(r["mounting"], float),
                    sigma=float(r["direction"]),
                    r_nom=r["radius_m"],
                    r_tol=r["radius_tol_m"],
                    w1=np.asarray(r["first_pass_sigma_mps2"], float),
                    diff_sigma=self.difference_noise(np.asarray(r["accel_mps2"], float), keep),
                )
            )
        poses = prob["poses"]
        self.n_runs, self.n_poses = len(self.runs), len(poses)
        self.n_sessions = max((p["session"] for p in poses), default=-1) + 1
        self.pose_mean = np.array([p["mean_mps2"] for p in poses], float)
        self.pose_sem = np.array([p["sigma_mean_mps2"] for p in poses], float)
        self.pose_session = np.array([p["session"] for p in poses], int)
        times = np.array([p["time_s"] for p in poses], float)
        self.pose_time = times
        self.walk = random_walk(poses)
        self.pose_tau = np.empty(self.n_poses)
        for s in range(self.n_sessions):
            m = self.pose_session == s
            self.pose_tau[m] = times[m] - 0.5 * (times[m].min() + times[m].max())
        # Pose frames: w0 the measured direction, e1/e2 a tangent basis from the least aligned axis.
        w0 = self.pose_mean / np.linalg.norm(self.pose_mean, axis=1, keepdims=True)
        k = np.argmin(np.abs(w0), axis=1)
        a = np.eye(3)[k]
        e1 = a - np.sum(a * w0, axis=1, keepdims=True) * w0
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        self.w0, self.e1, self.e2 = w0, e1, np.cross(w0, e1)
        self.n = SENSOR + RUN * self.n_runs + POSE * self.n_poses + SESSION * self.n_sessions
        self.pose_o = SENSOR + RUN * self.n_runs
        self.session_o = self.pose_o + POSE * self.n_poses
        self.m = sum(3 * len(r["tau"]) for r in self.runs) + 3 * self.n_poses
        self.m += 6 * self.n_runs + 6 * self.n_sessions + int(self.sensor_free.sum())
        self.set_weights([r["w1"] for r in self.runs], self.pose_sem)

    @staticmethod
    def difference_noise(a, keep):
        d = np.diff(a, axis=1)[:, keep[1:] & keep[:-1]]
        return np.maximum(np.sqrt(np.sum(d * d, axis=1) / max(d.shape[1], 1) / 2.0), 1e-6)

    def set_weights(self, run_sigma, pose_sigma):
        self.run_w = [1.0 / np.asarray(s, float) for s in run_sigma]
        self.pose_w = 1.0 / np.asarray(pose_sigma, float)

    # --- the model -------------------------------------------------------------------------
    @staticmethod
    def sensor_apply(p, f, delta):
        """h(b + delta + D (I + M) f); f, delta: (3, N)."""
        b, s, mis, quad = p[0:3], p[3:6], p[6:9], p[9:12]
        sk = np.stack([f[0], f[1] + mis[0] * f[0], f[2] + mis[1] * f[0] + mis[2] * f[1]])
        u = b[:, None] + delta + (1.0 + s)[:, None] * sk
        return u + quad[:, None] * u * u

    def run_force(self, i, rp):
        run = self.runs[i]
        r, w, alpha, phase, beta, e1, e2, wc, ws = rp[:9]
        qr = run["q"] @ rot_x(e1) @ rot_y(e2) @ rot_z(beta)
        tau, sig, g = run["tau"], run["sigma"], self.g
        s1, c1 = np.sin(w * tau), np.cos(w * tau)
        mod = wc * c1 + ws * s1
        quad = -wc * s1 + ws * c1
        rate = w * (1.0 + mod)
        rate_dot = w * w * quad
        angle = w * tau + wc * s1 - ws * c1
        th = phase - sig * angle
        amp = g * np.sin(alpha)
        fp = np.stack(
            [-rate * rate * r + amp * np.cos(th), amp * np.sin(th) + sig * r * rate_dot,
             np.full_like(tau, g * np.cos(alpha))]
        )
        return qr @ fp

    def run_residual(self, p, i):
        """Unweighted model − measured of run i, (3, N)."""
        o = SENSOR + RUN * i
        rp = p[o:o + RUN]
        tau = self.runs[i]["tau"]
        delta = rp[9:12, None] + rp[12:15, None] * tau
        return self.sensor_apply(p, self.run_force(i, rp), delta) - self.runs[i]["meas"]

    def pose_residual(self, p):
        """Unweighted model − measured mean of each pose, (P, 3)."""
        ab = p[self.pose_o:self.session_o].reshape(-1, 2)
        w = self.w0 + ab[:, :1] * self.e1 + ab[:, 1:] * self.e2
        f = self.g * w / np.linalg.norm(w, axis=1, keepdims=True)
        sess = p[self.session_o:].reshape(-1, SESSION)[self.pose_session]
        delta = sess[:, :3] + sess[:, 3:] * self.pose_tau[:, None]
        return self.sensor_apply(p, f.T, delta.T).T - self.pose_mean

    def residuals(self, p):
        parts = []
        for i in range(self.n_runs):
            parts.append((self.run_residual(p, i) * self.run_w[i][:, None]).ravel())
        parts.append((self.pose_residual(p) * self.pose_w).ravel())
        pri = []
        for i, run in enumerate(self.runs):
            o = SENSOR + RUN * i
            pri += [(p[o] - run["r_nom"]) / run["r_tol"], p[o + 5] / self.mount_sigma,
                    p[o + 6] / self.mount_sigma]
            pri += list(p[o + 9:o + 12] / self.bias_sigma)
        for s in range(self.n_sessions):
            so = self.session_o + SESSION * s
            pri += list(p[so:so + 3] / self.bias_sigma)
            pri += list(p[so + 3:so + 6] / (self.bias_sigma / SESSION_DRIFT_S))
        parts.append(np.asarray(pri))
        parts.append((p[:SENSOR] / self.sensor_sd)[self.sensor_free])
        return np.concatenate(parts)

    # --- analytic Jacobian (second row) ---------------------------------------------------
    def jacobian(self, p):
        J = np.zeros((self.m, self.n))
        b, s, mis, quad = p[0:3], p[3:6], p[6:9], p[9:12]
        row = 0

        def sensor_rows(f, dfs, delta, w, cols_extra):
            """Rows for one block: f (3,N), dfs list of (col, df (3,N)), delta (3,N), w (3,)."""
            nonlocal row
            nn = f.shape[1]
            sk = np.stack([f[0], f[1] + mis[0] * f[0], f[2] + mis[1] * f[0] + mis[2] * f[1]])
            u = b[:, None] + delta + (1.0 + s)[:, None] * sk
            slope = (1.0 + 2.0 * quad[:, None] * u) * w[:, None]  # (3, N)
            # Rows are laid out as the residuals: (3, N).ravel(), axis k in rows k*N .. (k+1)*N.
            # A pose is one block with N = 1 (its 3 rows in axis order).
            for k in range(3):
                R = slice(row + k * nn, row + (k + 1) * nn)
                sl = slope[k]
                J[R, k] = sl
                J[R, 3 + k] = sl * sk[k]
                J[R, 9 + k] = w[k] * u[k] * u[k]
                if k == 1:
                    J[R, 6] = sl * (1.0 + s[1]) * f[0]
                if k == 2:
                    J[R, 7] = sl * (1.0 + s[2]) * f[0]
                    J[R, 8] = sl * (1.0 + s[2]) * f[1]
                for col, df in dfs:
                    skd = [df[0], df[1] + mis[0] * df[0], df[2] + mis[1] * df[0] + mis[2] * df[1]][k]
                    J[R, col] += sl * (1.0 + s[k]) * skd
                for col, kk, factor in cols_extra:
                    if kk == k:
                        J[R, col] += sl * factor
            row += 3 * nn

        g = self.g
        for i, run in enumerate(self.runs):
            o = SENSOR + RUN * i
            r, w, alpha, phase, beta, e1, e2, wc, ws = p[o:o + 9]
            tau, sig = run["tau"], run["sigma"]
            Rx, Ry, Rz = rot_x(e1), rot_y(e2), rot_z(beta)
            c, sn = np.cos, np.sin
            dRx = np.array([[0, 0, 0], [0, -sn(e1), -c(e1)], [0, c(e1), -sn(e1)]])
            dRy = np.array([[-sn(e2), 0, c(e2)], [0, 0, 0], [-c(e2), 0, -sn(e2)]])
            dRz = np.array([[-sn(beta), -c(beta), 0], [c(beta), -sn(beta), 0], [0, 0, 0]])
            Q = run["q"]
            qr = Q @ Rx @ Ry @ Rz
            s1, c1 = np.sin(w * tau), np.cos(w * tau)
            mod = wc * c1 + ws * s1
            mq = -wc * s1 + ws * c1
            rate = w * (1 + mod)
            rate_dot = w * w * mq
            angle = w * tau + wc * s1 - ws * c1
            th = phase - sig * angle
            S, C = np.sin(th), np.cos(th)
            A = g * np.sin(alpha)
            zero = np.zeros_like(tau)
            fp = np.stack([-rate * rate * r + A * C, A * S + sig * r * rate_dot, np.full_like(tau, g * np.cos(alpha))])
            d_rate = (1 + mod) + w * tau * mq
            d_angle = tau * (1 + mod)
            d_rate_dot = 2 * w * mq - w * w * tau * mod
            dp = {
                0: np.stack([-rate * rate, sig * rate_dot, zero]),
                1: np.stack([-2 * rate * r * d_rate + A * S * sig * d_angle,
                             -A * C * sig * d_angle + sig * r * d_rate_dot, zero]),
                2: np.stack([g * np.cos(alpha) * C, g * np.cos(alpha) * S, np.full_like(tau, -g * np.sin(alpha))]),
                3: np.stack([-A * S, A * C, zero]),
                7: np.stack([-2 * rate * r * w * c1 + A * S * sig * s1,
                             -A * C * sig * s1 - sig * r * w * w * s1, zero]),
                8: np.stack([-2 * rate * r * w * s1 - A * S * sig * c1,
                             A * C * sig * c1 + sig * r * w * w * c1, zero]),
            }
            dfs = [(o + j, qr @ dp[j]) for j in (0, 1, 2, 3, 7, 8)]
            dfs += [(o + 4, (Q @ Rx @ Ry @ dRz) @ fp), (o + 5, (Q @ dRx @ Ry @ Rz) @ fp),
                    (o + 6, (Q @ Rx @ dRy @ Rz) @ fp)]
            f = qr @ fp
            delta = p[o + 9:o + 12, None] + p[o + 12:o + 15, None] * tau
            extra = [(o + 9 + k, k, 1.0) for k in range(3)] + [(o + 12 + k, k, tau) for k in range(3)]
            sensor_rows(f, dfs, delta, self.run_w[i], extra)
        # Poses: residual layout (P, 3).ravel(): pose-major. Build per pose (3 rows each).
        ab = p[self.pose_o:self.session_o].reshape(-1, 2)
        for pi in range(self.n_poses):
            a_, b_ = ab[pi]
            wv = self.w0[pi] + a_ * self.e1[pi] + b_ * self.e2[pi]
            nrm = np.linalg.norm(wv)
            hat = wv / nrm
            f = (g * hat)[:, None]
            d1 = g * (self.e1[pi] - hat @ self.e1[pi] * hat) / nrm
            d2 = g * (self.e2[pi] - hat @ self.e2[pi] * hat) / nrm
            so = self.session_o + SESSION * self.pose_session[pi]
            dt = self.pose_tau[pi]
            delta = (p[so:so + 3] + p[so + 3:so + 6] * dt)[:, None]
            o = self.pose_o + POSE * pi
            extra = [(so + k, k, 1.0) for k in range(3)] + [(so + 3 + k, k, dt) for k in range(3)]
            sensor_rows(f, [(o, d1[:, None]), (o + 1, d2[:, None])], delta, self.pose_w[pi], extra)
        for i, run in enumerate(self.runs):
            o = SENSOR + RUN * i
            J[row, o] = 1 / run["r_tol"]
            J[row + 1, o + 5] = 1 / self.mount_sigma
            J[row + 2, o + 6] = 1 / self.mount_sigma
            for k in range(3):
                J[row + 3 + k, o + 9 + k] = 1 / self.bias_sigma
            row += 6
        for s in range(self.n_sessions):
            so = self.session_o + SESSION * s
            for k in range(3):
                J[row + k, so + k] = 1 / self.bias_sigma
                J[row + 3 + k, so + 3 + k] = SESSION_DRIFT_S / self.bias_sigma
            row += 6
        for k in np.flatnonzero(self.sensor_free):
            J[row, k] = 1 / self.sensor_sd[k]
            row += 1
        assert row == self.m
        return J

    # --- fit_joint's procedure ------------------------------------------------------------
    def reweight(self, p):
        run_sigma = []
        for i in range(self.n_runs):
            r = self.run_residual(p, i)
            run_sigma.append(np.maximum(np.sqrt(np.mean(r * r, axis=1)), 1e-6))
        pose_sigma = self.pose_sem.copy()
        rp = self.pose_residual(p)
        # Leverage of each pose row under the pass-1 weights: h = j (J^T J)^-1 j^T.
        J = self.jacobian(p)
        cov = np.linalg.inv(J.T @ J)
        first = self.m - 3 * self.n_poses - 6 * self.n_runs - 6 * self.n_sessions - int(self.sensor_free.sum())
        rows = J[first:first + 3 * self.n_poses]
        lev = np.einsum("ij,jk,ik->i", rows, cov, rows).reshape(self.n_poses, 3)
        kept = np.maximum(1.0 - lev, MIN_KEPT_VARIANCE)
        for s in range(self.n_sessions):
            mem = np.flatnonzero(self.pose_session == s)
            if len(mem) < 2:
                continue
            span = self.pose_time[mem].max() - self.pose_time[mem].min()
            walked = self.walk * span / 15.0 if self.walk is not None else 0.0
            extra = np.sum(rp[mem] ** 2 / kept[mem] - self.pose_sem[mem] ** 2, axis=0)
            comp = np.maximum(extra / len(mem), walked)
            pose_sigma[mem] = np.sqrt(self.pose_sem[mem] ** 2 + comp)
        self.set_weights(run_sigma, pose_sigma)
        return run_sigma, pose_sigma

    def offset_columns(self):
        """The bias offsets' parameters and their prior precision in units of 1/sigma^2: each
        run's offset, each still session's offset, and its drift rate (SESSION_DRIFT_S^2)."""
        cols, weight = [], []
        for i in range(self.n_runs):
            o = SENSOR + RUN * i
            cols += [o + 9, o + 10, o + 11]
            weight += [1.0] * 3
        for s in range(self.n_sessions):
            so = self.session_o + SESSION * s
            cols += list(range(so, so + 6))
            weight += [1.0] * 3 + [SESSION_DRIFT_S ** 2] * 3
        return np.asarray(cols), np.asarray(weight)

    def offset_rows(self):
        """Rows of the residual vector that are the offsets' priors (see residuals())."""
        first = self.m - 6 * self.n_runs - 6 * self.n_sessions - int(self.sensor_free.sum())
        rows = [first + 6 * i + 3 + k for i in range(self.n_runs) for k in range(3)]
        so = first + 6 * self.n_runs
        rows += list(range(so, so + 6 * self.n_sessions))
        return np.asarray(rows, int)

    def spread(self, p):
        """The offsets' spread sigma maximising the marginal likelihood about p (the Laplace
        approximation with the Gauss-Newton Hessian):
        log L = -1/2 min_d S(p + d; sigma) - 1/2 log det(J'J + Lambda) + 1/2 log det Lambda,
        Lambda = diag(weight)/sigma^2 on the offsets. Returns (sigma, 2 (log L - log L(lower end)))."""
        from scipy.optimize import minimize_scalar

        keep = np.ones(self.m, bool)
        keep[self.offset_rows()] = False
        r0 = self.residuals(p)[keep]
        J0 = self.jacobian(p)[keep]
        H = J0.T @ J0
        g0 = J0.T @ r0
        base = float(r0 @ r0)
        cols, weight = self.offset_columns()

        def log_l(x):
            lam = weight * np.exp(-2.0 * x)
            A = H.copy()
            A[cols, cols] += lam
            b = g0.copy()
            b[cols] += lam * p[cols]
            c = np.linalg.cholesky(A)
            y = np.linalg.solve(c, b)
            min_sse = base + float(np.sum(lam * p[cols] ** 2)) - float(y @ y)
            log_det = 2.0 * float(np.sum(np.log(np.diag(c))))
            return -0.5 * min_sse - 0.5 * log_det - len(cols) * x

        lo, hi = np.log(SPREAD_SEARCH_G[0] * self.g), np.log(SPREAD_SEARCH_G[1] * self.g)
        grid = np.linspace(lo, hi, SPREAD_GRID)
        values = [log_l(x) for x in grid]
        k = int(np.argmax(values))
        step = grid[1] - grid[0]
        found = minimize_scalar(lambda x: -log_l(x), bounds=(max(grid[k] - step, lo), min(grid[k] + step, hi)),
                                method="bounded", options=dict(xatol=1e-12))
        x = float(found.x) if -found.fun >= values[k] else float(grid[k])
        return float(np.exp(x)), max(2.0 * (log_l(x) - values[0]), 0.0)


def random_walk(poses):
    """The bias's random-walk rate from the poses' half-to-half differences, pooled over axes:
    sum(d^2 - 4 sigma^2 / n) / sum(duration), floored at 0; None from fewer than three poses."""
    seen = [p["wander"] for p in poses if p.get("wander")]
    if len(seen) < 3:
        return None
    weight = sum(w["duration_s"] for w in seen)
    if not weight > 0:
        return None
    excess = sum(
        d * d - 4.0 * n * n / w["samples"]
        for w in seen
        for d, n in zip(w["half_difference_mps2"], w["noise_sd_mps2"])
    )
    return max(excess / weight, 0.0)


# --- starting values, as fit_joint forms them (timed, for the same work both sides) ---------
def demodulate(t, hor, nominal):
    """Rotation rate and sense that best demodulate the horizontal readings, as
    campaign/joint/start.rs: |F(w)| = |sum z exp(i sigma w tau)| on a grid of 0.5/span within
    ±25 % of the nominal rate, from the readings turned down by the nominal rate and summed over
    blocks of at most 0.5 / (0.25 nominal) s; then Newton's method on the exact |F|^2 from the
    best grid rate (golden section over ±one step where Newton fails)."""
    n = max(len(t), 1)
    mid = 0.5 * (t[0] + t[-1])
    tau = t - mid
    z = (hor[:, 0] - hor[:, 0].mean()) + 1j * (hor[:, 1] - hor[:, 1].mean())

    def exact(w, sigma):
        e = z * np.exp(1j * sigma * w * tau)
        return e.sum(), 1j * sigma * (tau * e).sum(), -(tau * tau * e).sum()

    span = t[-1] - t[0] if t[-1] > t[0] else 1.0
    step = 0.5 / span
    lo, hi = 0.75 * nominal, 1.25 * nominal
    grid = []
    w = lo
    while w <= hi:  # the same accumulated grid as the scan
        grid.append(w)
        w += step
    grid = np.asarray(grid)
    # Blocks of time: each sample's phase error in the scan is at most 0.5 rad.
    t0, t1 = tau.min(), tau.max()
    length = 0.5 / (0.25 * abs(nominal)) if nominal != 0 else np.inf
    blocks = min(int((t1 - t0) / length) + 1, len(tau)) if np.isfinite(length) and t1 > t0 else 1
    idx = np.minimum(((tau - t0) / ((t1 - t0) / blocks)).astype(int), blocks - 1) if blocks > 1 \
        else np.zeros(len(tau), int)
    count = np.bincount(idx, minlength=blocks)
    used = count > 0
    times = (np.bincount(idx, tau, minlength=blocks)[used]) / count[used]
    best = (0.0, nominal, 1.0)
    for sigma in (1.0, -1.0):
        y = z * np.exp(1j * sigma * nominal * tau)
        sums = (np.bincount(idx, y.real, minlength=blocks) + 1j * np.bincount(idx, y.imag, minlength=blocks))[used]
        amps = np.abs(np.exp(1j * sigma * np.outer(grid - nominal, times)) @ sums) / n
        k = int(np.argmax(amps))
        if amps[k] > best[0]:
            best = (amps[k], grid[k], sigma)
    _, w0, sigma = best
    a, b = w0 - step, w0 + step
    w, ok = w0, False
    for _ in range(8):
        f, d1, d2 = exact(w, sigma)
        slope = (np.conj(f) * d1).real
        curvature = abs(d1) ** 2 + (np.conj(f) * d2).real
        if not curvature < 0:
            break
        nxt = w - slope / curvature
        if not a <= nxt <= b:
            break
        moved, w = abs(nxt - w), nxt
        if moved <= 1e-12 * max(abs(w), 1e-12):
            ok = True
            break
    if not ok:
        ratio = 0.5 * (5 ** 0.5 - 1.0)
        for _ in range(40):
            c = b - ratio * (b - a)
            d = a + ratio * (b - a)
            if abs(exact(c, sigma)[0]) > abs(exact(d, sigma)[0]):
                b = d
            else:
                a = c
        w = 0.5 * (a + b)
    f = exact(w, sigma)[0]
    return w, sigma, abs(f) / n, np.arctan2(f.imag, f.real)


def start_values(prob_json):
    """The starting vector (runs' geometry; everything else 0) and the rotation senses."""
    g = prob_json["gravity_mps2"]
    x0 = np.zeros(prob_json["n_params"])
    senses = []
    for i, r in enumerate(prob_json["runs"]):
        keep = np.asarray(r["keep"], bool)
        t = np.asarray(r["time_s"], float)[keep]
        a = np.asarray(r["accel_mps2"], float)[:, keep]
        m = np.asarray(r["mounting"], float).T @ a  # readings along out, up x out, up
        hor = m[:2].T
        w, sigma, amp, psi = demodulate(t, hor, r["rpm"] * 2.0 * np.pi / 60.0)
        cx, cy = hor[:, 0].mean(), hor[:, 1].mean()
        tilt = np.arcsin(np.clip(amp / g, 0.0, 0.5))
        beta = np.arctan2(-cy, -cx) if np.hypot(cx, cy) > 1e-3 else 0.0
        o = SENSOR + RUN * i
        x0[o:o + 5] = [r["radius_m"], w, max(tilt, 1e-4), psi - beta, beta]
        senses.append(sigma)
    return x0, senses


def solve(prob, x0, method, jac, tol):
    kw = dict(method=method, x_scale="jac", ftol=tol["ftol"], xtol=tol["xtol"], gtol=tol["gtol"])
    if jac == "analytic":
        kw["jac"] = prob.jacobian
    return least_squares(prob.residuals, x0, **kw)


def fit(prob_json, start, method, jac, tol):
    prob = Problem(prob_json)
    t0 = time.perf_counter()
    r1 = solve(prob, start, method, jac, tol)
    prob.reweight(r1.x)
    if prob.estimate_spread:
        prob.bias_sigma, prob.spread_lr = prob.spread(r1.x)
    r2 = solve(prob, r1.x, method, jac, tol)
    elapsed = time.perf_counter() - t0
    return prob, r1, r2, elapsed


def polish(prob, x, se_all, rounds=20):
    """Undamped Gauss-Newton steps with the analytic Jacobian until the step is below 1e-10
    standard errors: the minimum to the precision the arithmetic allows."""
    for _ in range(rounds):
        J = prob.jacobian(x)
        d = np.linalg.solve(J.T @ J, -J.T @ prob.residuals(x))
        x = x + d
        if np.max(np.abs(d) / se_all) < 1e-10:
            break
    return x


def reference(prob_json, start, tol):
    """fit_joint's procedure solved to the arithmetic's precision: pass 1 (trf, analytic
    Jacobian, then Gauss-Newton polish), reweight, pass 2 likewise."""
    prob = Problem(prob_json)
    r1 = solve(prob, start, "trf", "analytic", tol)
    J = prob.jacobian(r1.x)
    se_all = np.sqrt(np.diag(np.linalg.inv(J.T @ J)))
    x1 = polish(prob, r1.x, se_all)
    prob.reweight(x1)
    if prob.estimate_spread:
        prob.bias_sigma, prob.spread_lr = prob.spread(x1)
    r2 = solve(prob, x1, "trf", "analytic", tol)
    J = prob.jacobian(r2.x)
    se_all = np.sqrt(np.diag(np.linalg.inv(J.T @ J)))
    x2 = polish(prob, r2.x, se_all)
    return prob, x2


ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
# What made the fixture; tests/fixture_scripts.rs fails when one changes without a re-run.
FIXTURE_SCRIPTS = [
    "bench/campaign/scipy_joint.py",
    "crates/spincal/tests/fixtures/joint_scipy/make.sh",
    "crates/spincal/examples/joint_fit_bench.rs",
    "crates/spincal/tests/common/joint_bench.rs",
]


def write_fixture(a, pj, sp, prob, x, summary):
    """The test suite's fixture: scipy's parameters by name, with spincal's standard errors (the
    test's unit), the spread, and how they were made. Small: no data (the test rebuilds it)."""
    n = len(sp["values"])
    fixture = dict(
        what="spincal's joint campaign fit re-implemented in numpy and solved by "
             "scipy.optimize.least_squares on the joint_fit_bench example's campaign; "
             "values: scipy's after both passes; std_errors: spincal's robust ones at the time",
        made_by=a.command,
        date_utc=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M"),
        versions=dict(numpy=np.__version__, scipy=scipy.__version__, python=sys.version.split()[0]),
        seed=pj["seed"],
        solver=dict(method=summary["method"], jac=summary["jac"], tolerances=summary["tolerances"],
                    nfev=summary["nfev"], status=summary["status"]),
        chi2=dict(scipy=summary["chi2"], spincal=sp["chi2"]),
        measured=dict(
            max_abs_diff_over_se_spincal_vs_scipy=summary["max_abs_diff_over_se"],
            worst_param=summary["worst_param_se"],
            distance_from_exact_minimiser_over_se=summary["distance_from_exact_minimiser_over_se"],
        ),
        names=sp["names"],
        values=[float(v) for v in x[:n]],
        std_errors=sp["std_errors"],
        scripts_sha256={f: hashlib.sha256(open(os.path.join(ROOT, f), "rb").read()).hexdigest()
                        for f in FIXTURE_SCRIPTS},
    )
    if prob.estimate_spread:
        fixture["bias_spread_sd_mps2"] = dict(scipy=prob.bias_sigma,
                                              spincal=sp.get("bias_spread", {}).get("sd_mps2"))
    os.makedirs(os.path.dirname(os.path.abspath(a.fixture)), exist_ok=True)
    with open(a.fixture, "w") as f:
        json.dump(fixture, f, indent=1)
        f.write("\n")
    print(f"wrote {a.fixture}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--methods", default="trf")
    ap.add_argument("--jac", default="2-point", help="2-point (scipy's default) or analytic")
    ap.add_argument("--ftol", type=float, default=1e-12)
    ap.add_argument("--xtol", type=float, default=1e-10)
    ap.add_argument("--gtol", type=float, default=1e-15)
    ap.add_argument("--out", default=None, help="JSON summary (default DIR/scipy_<method>_<jac>.json)")
    ap.add_argument("--fixture", default=None, help="also write the test suite's small fixture here")
    ap.add_argument("--command", default=None, help="the command that made the fixture, recorded in it")
    a = ap.parse_args()
    pj = json.load(open(f"{a.dir}/problem.json"))
    sp = json.load(open(f"{a.dir}/spincal_fit.json"))
    start = np.asarray(pj["start"], float)
    tol = dict(ftol=a.ftol, xtol=a.xtol, gtol=a.gtol)
    print(f"numpy {np.__version__}, scipy {scipy.__version__}, python {sys.version.split()[0]}")
    prob0 = Problem(pj)
    w_check = max(
        float(np.max(np.abs(r["diff_sigma"] / r["w1"] - 1.0))) for r in prob0.runs
    )
    print(f"first-pass weights: numpy vs spincal's (example) max relative difference {w_check:.1e}")
    print(f"problem: {prob0.n} parameters, {prob0.m} residuals")
    # Starting values in numpy (the demodulation fit_joint runs first): timed, checked
    # against the example's vector, which both fits below start from.
    st_times = []
    for _ in range(a.reps):
        t0 = time.perf_counter()
        x_start, senses = start_values(pj)
        st_times.append(time.perf_counter() - t0)
    d_start = float(np.max(np.abs(x_start - start)))
    same_senses = senses == [r["direction"] for r in pj["runs"]]
    print(f"start values (numpy demodulation): best {min(st_times):.3f} s, median "
          f"{statistics.median(st_times):.3f} s; max |difference| from spincal's start {d_start:.1e}; "
          f"same rotation senses: {same_senses}")
    ref_prob, x_ref = reference(pj, start, dict(ftol=1e-15, xtol=1e-15, gtol=1e-15))
    ref = np.asarray(sp["values"], float)
    se = np.array([np.nan if e is None else e for e in sp["std_errors"]], float)
    names = sp["names"]
    for method in a.methods.split(","):
        times = []
        for rep in range(a.reps):
            prob, r1, r2, el = fit(pj, start, method, a.jac, tol)
            times.append(el)
            print(f"  {method}/{a.jac} rep {rep + 1}: {el:.3f} s "
                  f"(pass 1: nfev {r1.nfev} njev {r1.njev} status {r1.status}; "
                  f"pass 2: nfev {r2.nfev} njev {r2.njev} status {r2.status})", flush=True)
        x = r2.x
        chi2 = float(np.sum(prob.residuals(x) ** 2))
        d = np.abs(x[:len(ref)] - ref)
        scale = np.maximum(np.abs(ref), se)
        rel_scale = d / scale
        rel_se = d / se
        worst = int(np.nanargmax(rel_scale))
        worst_se = int(np.nanargmax(rel_se))
        # spincal's point in this script's cost: its 84 exposed parameters, the still session's 6
        # (not exposed) re-solved with the others held.
        x_sp = x.copy()
        x_sp[:len(ref)] = ref
        free = np.arange(len(ref), prob.n)

        def sub(z):
            y = x_sp.copy()
            y[free] = z
            return prob.residuals(y)

        rs = least_squares(sub, x_sp[free], method="lm", ftol=1e-15, xtol=1e-15, gtol=1e-15)
        chi2_at_spincal = float(2 * rs.cost)
        # How far each point is from the minimum: the Gauss-Newton step J'J d = -J'r (analytic J)
        # in standard errors. A cost-based stopping rule cannot see the difference between points
        # a few 1e-6 SE apart (the cost changes by ~(1e-6)^2, far below eps * chi2).
        def gn_step(y):
            Jy = prob.jacobian(y)
            d = np.linalg.solve(Jy.T @ Jy, -Jy.T @ prob.residuals(y))
            return float(np.nanmax(np.abs(d[:len(ref)]) / se))
        x_sp[free] = rs.x
        gn_scipy, gn_spincal = gn_step(x), gn_step(x_sp)
        # Distance of each side from the exact minimiser of the whole procedure.
        from_ref_scipy = float(np.nanmax(np.abs(x[:len(ref)] - x_ref[:len(ref)]) / se))
        from_ref_spincal = float(np.nanmax(np.abs(ref - x_ref[:len(ref)]) / se))
        best, med = min(times), statistics.median(times)
        summary = dict(
            method=method, jac=a.jac, tolerances=tol, reps=a.reps, times_s=times, best_s=best,
            median_s=med, nfev=[int(r1.nfev), int(r2.nfev)],
            njev=[None if r1.njev is None else int(r1.njev), None if r2.njev is None else int(r2.njev)],
            status=[int(r1.status), int(r2.status)], chi2=chi2, chi2_spincal=sp["chi2"],
            chi2_here_at_spincal_params=chi2_at_spincal,
            max_abs_diff_over_scale=float(rel_scale[worst]), worst_param=names[worst],
            max_abs_diff_over_se=float(rel_se[worst_se]), worst_param_se=names[worst_se],
            gauss_newton_step_over_se=dict(scipy=gn_scipy, spincal=gn_spincal),
            distance_from_exact_minimiser_over_se=dict(scipy=from_ref_scipy, spincal=from_ref_spincal),
            start_values_s=dict(best=min(st_times), median=statistics.median(st_times),
                                max_abs_diff_from_spincal_start=d_start),
            total_with_start_s=dict(best=min(times) + min(st_times),
                                    median=statistics.median(times) + statistics.median(st_times)),
            params=x.tolist(),
        )
        print(f"{method}/{a.jac}: best {best:.3f} s, median {med:.3f} s of {a.reps}")
        print(f"  chi2: scipy {chi2:.10e}, spincal {sp['chi2']:.10e}, "
              f"this script's chi2 at spincal's parameters {chi2_at_spincal:.10e}")
        print(f"  agreement (84 exposed parameters): max |Δ|/max(|p|, SE) = {rel_scale[worst]:.2e} "
              f"({names[worst]}); max |Δ|/SE = {rel_se[worst_se]:.2e} ({names[worst_se]})")
        print(f"  remaining Gauss-Newton step, max |d|/SE: at scipy's point {gn_scipy:.1e}, "
              f"at spincal's point {gn_spincal:.1e}")
        print(f"  distance from the exact minimiser of the procedure (Gauss-Newton polished, "
              f"both passes), max |Δ|/SE: scipy {from_ref_scipy:.1e}, spincal {from_ref_spincal:.1e}")
        order = np.argsort(-np.nan_to_num(rel_scale))[:5]
        for k in order:
            print(f"    {names[k]:42s} spincal {ref[k]: .12e} scipy {x[k]: .12e} |Δ|/scale {rel_scale[k]:.1e} |Δ|/SE {rel_se[k]:.1e}")
        spread_sp = sp.get("bias_spread", {}).get("sd_mps2")
        if prob.estimate_spread:
            summary["bias_spread_sd_mps2"] = dict(scipy=prob.bias_sigma, spincal=spread_sp)
            print(f"  bias offsets' spread: scipy {prob.bias_sigma:.12e}, spincal {spread_sp:.12e} m/s^2 "
                  f"(relative difference {abs(prob.bias_sigma / spread_sp - 1.0):.1e}); "
                  f"likelihood ratio {prob.spread_lr:.3f}")
        out = a.out or f"{a.dir}/scipy_{method}_{a.jac}.json"
        json.dump(summary, open(out, "w"), indent=1)
        if a.fixture:
            write_fixture(a, pj, sp, prob, x, summary)


if __name__ == "__main__":
    main()
