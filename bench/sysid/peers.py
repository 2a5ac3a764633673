"""Shared helpers for the sysid fixture and benchmark scripts: data generation, numpy ARX,
and the two peers (pysib, SIPPY = PyPI `sippy-unipi`) behind one interface returning idpoly
polynomials (B with nk leading zeros)."""
import numpy as np
from scipy.signal import lfilter

# True Box-Jenkins system used for the peer comparison: y = B/F u + C/D e.
BJ_TRUE = dict(B=[0.0, 0.5, 0.3], F=[1.0, -1.5, 0.7], C=[1.0, 0.6], D=[1.0, -0.9, 0.2])
BJ_TRUE_ORDERS = (2, 1, 2, 2, 1)  # nb nc nd nf nk
NOISE_STD = 0.3


def bj_data(n, seed):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    e = NOISE_STD * rng.standard_normal(n)
    t = BJ_TRUE
    y = lfilter(t["B"], t["F"], u) + lfilter(t["C"], t["D"], e)
    return u, y


def arx_regressors(u_list, y, na, nb_list, nk_list):
    t0 = max([na] + [nb + nk - 1 for nb, nk in zip(nb_list, nk_list)])
    n = len(y)
    cols = [-y[t0 - k : n - k] for k in range(1, na + 1)]
    for u, nb, nk in zip(u_list, nb_list, nk_list):
        cols += [u[t0 - nk - j : n - nk - j] for j in range(nb)]
    return np.column_stack(cols), y[t0:]


def arx_numpy(u_list, y, na, nb_list, nk_list):
    phi, target = arx_regressors(u_list, y, na, nb_list, nk_list)
    theta, *_ = np.linalg.lstsq(phi, target, rcond=None)
    return theta


def arx_numpy_qr(u_list, y, na, nb_list, nk_list):
    """spincal's algorithm in numpy: Householder QR of [Phi | y] (LAPACK dgeqrf, Phi built whole
    rather than streamed in blocks), theta from the triangle by back substitution."""
    from scipy.linalg import solve_triangular

    phi, target = arx_regressors(u_list, y, na, nb_list, nk_list)
    p = phi.shape[1]
    r = np.linalg.qr(np.column_stack([phi, target]), mode="r")
    return solve_triangular(r[:p, :p], r[:p, p])


def arx_simulate(theta, u, y, na, nb, nk, n_init):
    """Simulation from the first n_init measured outputs (SISO)."""
    a = theta[:na]
    b = theta[na:]
    ys = np.zeros(len(y))
    ys[:n_init] = y[:n_init]
    for t in range(n_init, len(y)):
        acc = 0.0
        for k in range(1, na + 1):
            if t - k >= 0:
                acc -= a[k - 1] * ys[t - k]
        for j in range(nb):
            if t - nk - j >= 0:
                acc += b[j] * u[t - nk - j]
        ys[t] = acc
    return ys


def fit_percent(y, yh):
    return 100.0 * (1.0 - np.linalg.norm(y - yh) / np.linalg.norm(y - y.mean()))


def minimum_phase(c):
    """The monic polynomial with C's roots outside the unit circle reflected inside (r -> 1/conj r):
    the same noise spectrum up to its variance, and the one whose predictor D/C is stable. A no-op
    on a minimum-phase C (pysib's, spincal's); SIPPY's C can leave the unit circle (RESULTS.md)."""
    c = np.trim_zeros(np.asarray(c, dtype=float), "b")
    roots = np.roots(c)
    if np.all(np.abs(roots) < 1.0):
        return c
    roots = np.where(np.abs(roots) > 1.0, 1.0 / np.conj(roots), roots)
    return np.real(np.poly(roots))


def bj_scores(m, u, y):
    """Simulation and one-step fit % of an idpoly BJ model from zero initial conditions; the
    one-step predictor uses C's minimum-phase factor (see minimum_phase)."""
    sim = lfilter(m["B"], m["F"], u)
    # e = D/C (y - B/F u), prediction = y - e
    e = lfilter(m["D"], minimum_phase(m["C"]), y - sim)
    pred = y - e
    return fit_percent(y, sim), fit_percent(y, pred)


def pysib_bj(u, y, nb, nc, nd, nf, nk):
    import pysib

    _, m = pysib.bj(u, y, nb, nc, nd, nf, nk)
    return {k: np.asarray(m[k], dtype=float).ravel() for k in "BCDF"}


def sippy_bj(u, y, nb, nc, nd, nf, nk):
    from sippy_unipi.io_opt import GEN_id

    # GEN_id(id_method, y, u, na, nb, nc, nd, nf, theta, max_iterations, stab_marg, stab_cons).
    # SIPPY's delay `theta` is in addition to one sample: its regressor is
    # u(k-theta-1) .. u(k-theta-nb) (functionset_OPT.opt_id), and its returned numerator is one
    # coefficient shorter than the denominator (a tf in powers of z), i.e. B(q^-1) = [0, NUM...].
    # So MATLAB/idpoly nk maps to theta = nk - 1, and B gets a leading zero. stab_cons=False
    # (SIPPY's default): with True its IPOPT run diverged to an unstable model on this data.
    num, den, numh, denh, _, _ = GEN_id("BJ", np.asarray(y), np.asarray(u), 0, nb, nc, nd, nf, nk - 1, 200, 1.0, False)
    return {
        "B": np.concatenate([[0.0], np.atleast_1d(np.asarray(num, dtype=float))]),
        "F": np.atleast_1d(np.asarray(den, dtype=float)),
        "C": np.atleast_1d(np.asarray(numh, dtype=float)),
        "D": np.atleast_1d(np.asarray(denh, dtype=float)),
    }
