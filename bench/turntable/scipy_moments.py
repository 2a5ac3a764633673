"""spincal's turntable-fit algorithm written in numpy/scipy: the same-algorithm row of the turntable
benchmark (scipy_fit.py is the row "scipy as users write it").

The algorithm, from the maths of crates/spincal/src/turntable/ (not a translation of its code):

1. Rotation rate from the spectrum: x and y detrended, Hann-windowed, power spectra summed
   (real FFT zero-padded to a power of two >= 2n), the highest bin in 5-600 rpm, refined by Newton
   steps on the windowed DTFT power P(f) with P' and P'' from the sums S_k = sum x t^k e^{-iwt}.
2. Starting values from a linear fit of 1, sin(wt'), cos(wt'), t - t_mid per axis at that rate;
   the residual standard deviation per axis gives the weights 1/noise; the sense of rotation is
   the sign of cos_y sin_x - sin_y cos_x.
3. Nelder-Mead (fminsearch's rules, fminsearchbnd's sin transform for the bounds) on the weighted
   squared error computed from precomputed moments: each axis is M + a q(u) + d tau with
   q = sin u or cos u, u = w t' + phase - beta, so its squared error needs only fixed sums
   (sum y, sum y^2, sum tau y) and trigonometric sums Z_g(hw) = sum g e^{ihwt'} for g = 1, tau,
   y_x, y_y (h = 1) and g = 1 (h = 2). w stays within +-3 % of the spectral estimate, so each Z is
   kept per block of samples (|2 dw tau_b| <= 1) as a 22-term Taylor series in dw = w - w_c:
   an evaluation costs ~60 blocks x 22 terms instead of 60,000 samples.
4. Levenberg-Marquardt polish on the weighted residuals with the analytic Jacobian: here scipy's
   least_squares(method="lm") (MINPACK), spincal's stopping rule being a relative cost change of
   1e-12 (ftol); MINPACK has no bounds, which are not active at this minimum (checked).
5. Standard errors from sigma^2 (J^T J)^-1 (column-scaled), sigma^2 = SSE / (rows - params).

Timed as spincal's process is (read the CSV, spectrum, start, moments, Nelder-Mead, LM, standard
errors), minus what spincal also does and this does not: process start-up, the saturation and
inspection report, correlations and identifiability, writing the JSON. Interpreter start-up and
imports are not timed here.

Usage: scipy_moments.py REC.csv SPINCAL_FIT.json SPINCAL_TIMES  (times: comma-separated seconds,
one per timed spincal process; as many timed runs are made here, after one warm-up run)
"""
import json
import sys
import time

import numpy as np
from scipy.optimize import least_squares, minimize

G_SI = 9.80665
TERMS = 22
TWO_PI = 2.0 * np.pi


def read_csv(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(0, 1, 2, 3))
    scale = G_SI if header[1].lower().endswith("_g") else 1.0
    return data[:, 0].copy(), [np.ascontiguousarray(data[:, 1 + a]) * scale for a in range(3)]


def sample_interval(t):
    """Median of (t[i+k] - t[i]) / k over non-overlapping windows of k <= 64 steps."""
    steps = len(t) - 1
    k = min(max(steps // 8, 1), 64)
    idx = np.arange(0, (steps // k + 1) * k, k)
    rates = np.diff(t[idx]) / k
    return np.partition(rates, len(rates) // 2)[len(rates) // 2]


def detrend(x):
    i = np.arange(len(x), dtype=float)
    di = i - (len(x) - 1) / 2.0
    xc = x - x.mean()
    return xc - (di @ xc) / (di @ di) * di


def rotation_rate(t, acc, min_rpm=5.0, max_rpm=600.0):
    n = len(t)
    rate_hz = 1.0 / sample_interval(t)
    window = 0.5 - 0.5 * np.cos(TWO_PI * np.arange(n) / (n - 1))
    prepared = [detrend(acc[a]) * window for a in (0, 1)]
    padded = 1 << int(np.ceil(np.log2(2 * n)))
    norm = window @ window
    power = sum(np.abs(np.fft.rfft(x, padded)) ** 2 for x in prepared) / norm
    bin_hz = rate_hz / padded
    lo = int(np.ceil(min_rpm / 60.0 / bin_hz))
    hi = min(int(np.floor(max_rpm / 60.0 / bin_hz)), len(power) - 2)
    peak = lo + int(np.argmax(power[lo:hi + 1]))
    tp = t - t[0]
    stacked = np.vstack(prepared)  # 2 x n

    def derivatives(f):
        e = np.exp(-1j * TWO_PI * f * tp)
        s0 = stacked @ e
        s1 = stacked @ (e * tp)
        s2 = stacked @ (e * tp * tp)
        # In w: P' = 2 Re(conj(X) (-i S1)), P'' = 2 (|S1|^2 - Re(conj(X) S2)); in f, 2 pi and (2 pi)^2.
        dp = TWO_PI * 2.0 * np.sum(s0.real * s1.imag - s0.imag * s1.real)
        ddp = TWO_PI ** 2 * 2.0 * np.sum(np.abs(s1) ** 2 - (s0.real * s2.real + s0.imag * s2.imag))
        return dp, ddp

    f, lo_hz, hi_hz = peak * bin_hz, (peak - 1) * bin_hz, (peak + 1) * bin_hz
    for _ in range(30):
        dp, ddp = derivatives(f)
        if not ddp < 0.0:
            raise RuntimeError("Newton met a convex point (spincal would use golden section here)")
        step = -dp / ddp
        f += step
        if not lo_hz <= f <= hi_hz:
            raise RuntimeError("Newton left the bracket (spincal would use golden section here)")
        if abs(step) <= 1e-13 * abs(f):
            return TWO_PI * f
    raise RuntimeError("Newton did not converge")


def sinusoid_start(t, acc, w):
    tp, tau = t - t[0], t - 0.5 * (t[0] + t[-1])
    a = np.column_stack([np.ones_like(t), np.sin(w * tp), np.cos(w * tp), tau])
    coef = np.linalg.solve(a.T @ a, a.T @ np.column_stack(acc))  # 4 x 3
    resid = np.column_stack(acc) - a @ coef
    noise = np.maximum(np.sqrt(np.sum(resid ** 2, axis=0) / (len(t) - 4.0)), 1e-6)
    return coef[0], coef[1], coef[2], noise


def wrap(x):
    y = np.mod(x, TWO_PI)
    return np.where(y > np.pi, y - TWO_PI, y)


class Problem:
    """The paper's model with offsets held at zero and drift fitted, all three axes (the
    benchmark's `spincal fit --no-offsets`): parameters beta, radius, omega, tilt, phase,
    drift_x, drift_y, drift_z."""

    names = ["beta", "radius", "omega", "tilt", "phase", "drift_x", "drift_y", "drift_z"]

    def __init__(self, t, acc, gravity=G_SI):
        self.t, self.acc, self.g = t, acc, gravity
        self.tp = t - t[0]
        self.tau = t - 0.5 * (t[0] + t[-1])
        w = rotation_rate(t, acc)
        mean, sin, cos, noise = sinusoid_start(t, acc, w)
        self.omega0 = w
        self.noise = noise
        self.weights = 1.0 / noise
        self.s = 1.0 if cos[1] * sin[0] - sin[1] * cos[0] >= 0.0 else -1.0
        beta0 = np.arctan2(mean[1], mean[0])
        radius0 = np.clip(np.hypot(mean[0], mean[1]) / w ** 2, 0.002, 0.49)
        amplitude = 0.5 * (np.hypot(sin[0], cos[0]) + np.hypot(sin[1], cos[1]))
        tilt0 = np.arcsin(np.clip(amplitude / gravity, 0.0, 0.49))
        phase0 = float(wrap(np.arctan2(cos[0], sin[0]) + beta0))
        span = t[-1] - t[0]
        drift = 0.2 * gravity / span
        self.start = np.array([beta0, radius0, w, tilt0, phase0, 0.0, 0.0, 0.0])
        self.lower = np.array([-TWO_PI, 0.0, 0.97 * w, 0.0, -TWO_PI, -drift, -drift, -drift])
        self.upper = np.array([TWO_PI, 0.5, 1.03 * w, np.radians(30.0), TWO_PI, drift, drift, drift])
        self.moments = Moments(t, acc, 0.5 * (self.lower[2] + self.upper[2]),
                               0.5 * (self.upper[2] - self.lower[2]))

    def unpack(self, p):
        beta, r, w, tilt, phase, dx, dy, dz = p
        return beta, r, w, tilt, phase, (dx, dy, dz)

    def cost(self, p):
        return self.moments.cost(p, self.g, self.s, self.weights)

    def residuals(self, p):
        beta, r, w, tilt, phase, d = self.unpack(p)
        u = w * self.tp + phase - beta
        amp, c = self.g * np.sin(tilt), w * w * r
        su, cu = np.sin(u), np.cos(u)
        wx, wy, wz = self.weights
        return np.concatenate([
            wx * (c * np.cos(beta) + amp * su + d[0] * self.tau - self.acc[0]),
            wy * (c * np.sin(beta) + self.s * amp * cu + d[1] * self.tau - self.acc[1]),
            wz * (self.g * np.cos(tilt) + d[2] * self.tau - self.acc[2]),
        ])

    def jacobian(self, p):
        beta, r, w, tilt, phase, d = self.unpack(p)
        n, s, g = len(self.t), self.s, self.g
        u = w * self.tp + phase - beta
        su, cu = np.sin(u), np.cos(u)
        amp, c = g * np.sin(tilt), w * w * r
        cb, sb = np.cos(beta), np.sin(beta)
        j = np.zeros((3 * n, 8))
        x, y, z = slice(0, n), slice(n, 2 * n), slice(2 * n, 3 * n)
        # a_x = w^2 r cos b + A sin u + d_x tau;  a_y = w^2 r sin b + s A cos u + d_y tau;
        # a_z = g cos(tilt) + d_z tau;  u = w t' + phase - b,  A = g sin(tilt).
        j[x, 0] = -c * sb - amp * cu
        j[y, 0] = c * cb + s * amp * su
        j[x, 1] = w * w * cb
        j[y, 1] = w * w * sb
        j[x, 2] = 2.0 * w * r * cb + amp * cu * self.tp
        j[y, 2] = 2.0 * w * r * sb - s * amp * su * self.tp
        j[x, 3] = g * np.cos(tilt) * su
        j[y, 3] = s * g * np.cos(tilt) * cu
        j[z, 3] = -amp
        j[x, 4] = amp * cu
        j[y, 4] = -s * amp * su
        j[x, 5] = self.tau
        j[y, 6] = self.tau
        j[z, 7] = self.tau
        j[x] *= self.weights[0]
        j[y] *= self.weights[1]
        j[z] *= self.weights[2]
        return j


class Moments:
    """Per-block Taylor moments of the trigonometric sums, for w within centre +- half_width."""

    def __init__(self, t, acc, centre, half_width):
        self.centre, self.n = centre, float(len(t))
        t0, t_mid = t[0], 0.5 * (t[0] + t[-1])
        tau = t - t_mid
        self.axis_centre = np.array([a.mean() for a in acc])
        yc = [acc[a] - self.axis_centre[a] for a in range(3)]
        self.sum_y = np.array([v.sum() for v in yc])
        self.sum_y2 = np.array([v @ v for v in yc])
        self.sum_tau_y = np.array([tau @ v for v in yc])
        self.sum_tau, self.sum_tau2 = tau.sum(), tau @ tau
        span = 1.0 / (2.0 * half_width)  # half a block: |2 dw tau_b| <= 1
        tp = t - t0
        centres, blocks = [], []
        powers = np.arange(TERMS)
        start = 0
        while start < len(t):
            end = int(np.searchsorted(t, t[start] + 2.0 * span, side="right"))
            c = 0.5 * (t[start] + t[end - 1]) - t0
            local = tp[start:end] - c
            e1 = np.exp(1j * centre * local)
            g = np.vstack([e1, tau[start:end] * e1, yc[0][start:end] * e1, yc[1][start:end] * e1, e1 * e1])
            blocks.append(g @ (local[:, None] ** powers))  # 5 x TERMS
            centres.append(c)
            start = end
        self.block_centres = np.array(centres)
        self.m = np.array(blocks)  # blocks x 5 x TERMS
        self.harmonic = np.array([1, 1, 1, 1, 2])
        self.factorial = np.cumprod(np.concatenate([[1.0], np.arange(1, TERMS)]))

    def sums(self, w):
        delta = w - self.centre
        # series[s, k] = (i h_s delta)^k / k!
        series = (1j * self.harmonic * delta)[:, None] ** np.arange(TERMS) / self.factorial
        inner = np.einsum("bsk,sk->bs", self.m, series)
        anchor = np.exp(1j * w * self.block_centres)
        return np.sum(inner * anchor[:, None] ** self.harmonic[None, :], axis=0)

    def cost(self, p, g, s, weights):
        beta, r, w, tilt, phase, dx, dy, dz = p
        z = self.sums(w)
        turn = np.exp(1j * (phase - beta))
        rot = z[:4] * turn
        z_two = (z[4] * turn * turn).real
        amp = g * np.sin(tilt)
        c = w * w * r
        means = (c * np.cos(beta), c * np.sin(beta), g * np.cos(tilt))
        # (amplitude, sum q, sum q^2, sum tau q, sum y q) per axis; q = sin u, s cos u, none.
        osc = ((amp, rot[0].imag, 0.5 * (self.n - z_two), rot[1].imag, rot[2].imag),
               (s * amp, rot[0].real, 0.5 * (self.n + z_two), rot[1].real, rot[3].real),
               (0.0, 0.0, 0.0, 0.0, 0.0))
        total = 0.0
        for a, (d, (q, sq, sq2, stq, syq)) in enumerate(zip((dx, dy, dz), osc)):
            m = means[a] - self.axis_centre[a]
            sse = (self.n * m * m + q * q * sq2 + d * d * self.sum_tau2 + self.sum_y2[a]
                   + 2.0 * m * q * sq + 2.0 * m * d * self.sum_tau - 2.0 * m * self.sum_y[a]
                   + 2.0 * q * d * stq - 2.0 * q * syq - 2.0 * d * self.sum_tau_y[a])
            total += weights[a] ** 2 * sse
        return max(total, 0.0)


def bounded_nelder_mead(cost, start, lower, upper):
    """fminsearch (scipy's Nelder-Mead: same simplex rules, initial simplex and stopping test) on
    fminsearchbnd's transform x = lo + (hi - lo)(sin z + 1)/2, z0 = 2 pi + asin(...)."""
    span = upper - lower

    def to_x(z):
        return np.clip(lower + span * (np.sin(z) + 1.0) / 2.0, lower, upper)

    z0 = TWO_PI + np.arcsin(np.clip(2.0 * (np.clip(start, lower, upper) - lower) / span - 1.0, -1.0, 1.0))
    n = len(z0)
    simplex = np.tile(z0, (n + 1, 1))
    for k in range(n):
        simplex[k + 1, k] = 1.05 * z0[k] if z0[k] != 0.0 else 0.00025
    f_start = cost(start)
    res = minimize(lambda z: cost(to_x(z)), z0, method="Nelder-Mead",
                   options={"initial_simplex": simplex, "xatol": 1e-4, "fatol": 1e-9 * f_start,
                            "maxiter": 200 * n, "maxfev": 10 ** 9, "adaptive": False})
    return to_x(res.x), res


def fit(path):
    """The whole pipeline; returns the result and the seconds each stage took."""
    marks = [time.perf_counter()]
    t, acc = read_csv(path)
    marks.append(time.perf_counter())
    prob = Problem(t, acc)  # spectrum, start, moments
    marks.append(time.perf_counter())
    x_nm, nm = bounded_nelder_mead(prob.cost, prob.start, prob.lower, prob.upper)
    marks.append(time.perf_counter())
    ls = least_squares(prob.residuals, x_nm, jac=prob.jacobian, method="lm",
                       ftol=1e-12, xtol=1e-12, gtol=1e-15, max_nfev=2000)
    marks.append(time.perf_counter())
    j = ls.jac
    sse = 2.0 * ls.cost
    dof = j.shape[0] - j.shape[1]
    jtj = j.T @ j
    scale = 1.0 / np.sqrt(np.diag(jtj))
    cov = np.linalg.inv(jtj * np.outer(scale, scale)) * np.outer(scale, scale) * sse / dof
    se = np.sqrt(np.diag(cov))
    marks.append(time.perf_counter())
    stages = dict(zip(["read", "spectrum+start+moments", "nelder-mead", "lm", "errors"], np.diff(marks)))
    return prob, x_nm, nm, ls, se, stages


def main():
    csv_path, fit_path = sys.argv[1], sys.argv[2]
    spincal_times = [float(v) for v in sys.argv[3].split(",")]
    ref = json.load(open(fit_path))
    fit(csv_path)  # warm-up
    times, results = [], None
    for _ in range(len(spincal_times)):
        started = time.perf_counter()
        results = fit(csv_path)
        times.append(time.perf_counter() - started)
    prob, x_nm, nm, ls, se, stages = results

    names = [p["name"] for p in ref["params"]]
    assert names == Problem.names, f"this script fits {Problem.names}, spincal's fit has {names}"
    start_rel = np.max(np.abs(prob.start - np.array(ref["start"])) / np.maximum(np.abs(ref["start"]), 1e-12))
    noise_rel = np.max(np.abs(prob.noise - np.array(ref["noise_mps2"][0])) / np.array(ref["noise_mps2"][0]))
    ours = np.array([p["value"] for p in ref["params"]])
    theirs = ls.x.copy()
    theirs[[0, 4]] = wrap(theirs[[0, 4]])
    rel = np.abs(ours - theirs) / np.maximum(np.abs(theirs), 1e-12)
    ref_se = np.array([p["std_error"] or np.nan for p in ref["params"]])
    at_bound = np.any((ls.x <= prob.lower) | (ls.x >= prob.upper))
    print(f"same-algorithm numpy/scipy: start vs spincal's {start_rel:.1e} relative, weights {noise_rel:.1e}, "
          f"direction {'ccw' if prob.s > 0 else 'cw'} (spincal {ref['recordings'][0]['session']['direction']}); "
          f"Nelder-Mead {nm.nit} iterations / {nm.nfev} evaluations (spincal {ref['nelder_mead_iterations']} iterations), "
          f"NM cost {nm.fun:.10e} (spincal {ref['cost_nelder_mead']:.10e}); "
          f"LM {ls.nfev} residual / {ls.njev} Jacobian evaluations (spincal {ref['lm_iterations']} iterations); "
          f"a bound active: {bool(at_bound)}")
    print(f"  weighted SSE {2 * ls.cost:.10e} (spincal {ref['cost_final']:.10e}); largest relative parameter "
          f"difference {rel.max():.2e} ({names[int(np.argmax(rel))]}), largest difference / SE "
          f"{np.nanmax(np.abs(ours - theirs) / ref_se):.1e}; standard errors within {np.nanmax(np.abs(se / ref_se - 1)):.1e} relative")
    median = lambda v: sorted(v)[len(v) // 2]
    fit_only = [stages["nelder-mead"] + stages["lm"]]
    print("  stages of the last run (s): " + ", ".join(f"{k} {v:.3f}" for k, v in stages.items()))
    print(f"  time (best / median of {len(times)} each, after a warm-up): spincal {min(spincal_times):.3f} / "
          f"{median(spincal_times):.3f} s (whole process), numpy/scipy same algorithm {min(times):.3f} / {median(times):.3f} s "
          f"(read, spectrum, start, moments, NM, LM, errors; NM + LM alone {fit_only[0]:.3f} s in the last run)")
    print(f"  ratio same algorithm / spincal: best {min(times) / min(spincal_times):.1f}x, "
          f"median {median(times) / median(spincal_times):.1f}x")


if __name__ == "__main__":
    main()
