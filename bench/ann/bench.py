"""LM epoch benchmark and pyrenn peer check for spincal's network trainer (see run.sh).
Times are CPU time of the calling thread (time.thread_time), as on the Rust side, so other
processes on a shared machine do not inflate them.

Subcommands:
  peer EXPORT.json EPOCHS FIXTURE.json   train pyrenn from spincal's initial weights, write fixture
  epoch RUST_TIMES.json FAERGEMM.json ROUNDS PYRENN_ROUNDS K EXPORT.json...
                                         time pyrenn and numpy epochs, compare with spincal's
"""
import hashlib
import json
import os
import sys
import time

import numpy as np
import pyrenn

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


# ---------------------------------------------------------------- weights and data

def to_pyrenn_weights(ours, sizes):
    """spincal: per layer W row-major (unit x input) then b; pyrenn: W column-major then b."""
    out, at = [], 0
    for n_in, n_out in zip(sizes[:-1], sizes[1:]):
        w = np.asarray(ours[at:at + n_in * n_out]).reshape(n_out, n_in)
        at += n_in * n_out
        out.extend(w.flatten("F"))
        out.extend(ours[at:at + n_out])
        at += n_out
    return np.array(out)


def unpack(ours, sizes):
    layers, at = [], 0
    for n_in, n_out in zip(sizes[:-1], sizes[1:]):
        w = np.asarray(ours[at:at + n_in * n_out]).reshape(n_out, n_in)
        at += n_in * n_out
        b = np.asarray(ours[at:at + n_out])
        at += n_out
        layers.append((w, b))
    return layers


def load_export(path):
    with open(path) as f:
        e = json.load(f)
    sizes = e["sizes"]
    x = np.asarray(e["inputs"]).reshape(-1, sizes[0])
    t = np.asarray(e["targets"]).reshape(-1, sizes[-1])
    return e, sizes, x, t


def pyrenn_net(sizes, ours_weights):
    net = pyrenn.CreateNN(list(sizes))
    net["w"] = to_pyrenn_weights(ours_weights, sizes)
    net["w0"] = net["w"].copy()
    return net


def pyrenn_mse(net, x, t):
    y = pyrenn.NNOut(x.T, net)
    y = np.asarray(y).reshape(t.shape[1], -1)
    return float(np.mean((t.T - y) ** 2))


# ---------------------------------------------------------------- vectorised numpy epoch

def forward(layers, x):
    acts = [x]
    a = x
    for i, (w, b) in enumerate(layers):
        z = a @ w.T + b
        a = z if i == len(layers) - 1 else np.tanh(z)
        acts.append(a)
    return acts


def jacobian(layers, acts):
    """Rows sample-major then output, columns in spincal's weight layout (dy/dw)."""
    n = acts[0].shape[0]
    n_out = layers[-1][0].shape[0]
    n_params = sum(w.size + b.size for w, b in layers)
    j = np.zeros((n, n_out, n_params))
    offsets, at = [], 0
    for w, b in layers:
        offsets.append(at)
        at += w.size + b.size
    last = len(layers) - 1
    for k in range(n_out):
        # Output layer: row k sees the last hidden activations.
        w, b = layers[last]
        n_in = w.shape[1]
        at = offsets[last]
        j[:, k, at + k * n_in:at + (k + 1) * n_in] = acts[last]
        j[:, k, at + w.size + k] = 1.0
        delta = np.broadcast_to(w[k], (n, n_in)) * (1.0 - acts[last] ** 2)
        for l in range(last - 1, -1, -1):
            w, b = layers[l]
            at = offsets[l]
            j[:, k, at:at + w.size] = (delta[:, :, None] * acts[l][:, None, :]).reshape(n, -1)
            j[:, k, at + w.size:at + w.size + b.size] = delta
            if l > 0:
                delta = (delta @ w) * (1.0 - acts[l] ** 2)
    return j.reshape(n * n_out, n_params)


def numpy_epoch(flat, sizes, x, t, mu):
    layers = unpack(flat, sizes)
    acts = forward(layers, x)
    e = (t - acts[-1]).reshape(-1)
    sse = e @ e
    j = jacobian(layers, acts)
    jtj = j.T @ j
    jte = j.T @ e
    while True:
        c = np.linalg.cholesky(jtj + mu * np.eye(len(flat)))
        step = np.linalg.solve(c.T, np.linalg.solve(c, jte))
        trial = flat + step
        y = forward(unpack(trial, sizes), x)[-1]
        new_sse = np.sum((t - y) ** 2)
        if new_sse < sse:
            return trial, new_sse, mu * 0.1
        mu *= 10.0


# ---------------------------------------------------------------- commands

def peer(export_path, epochs, fixture_path):
    e, sizes, x, t = load_export(export_path)
    net = pyrenn_net(sizes, e["initial_weights"])
    start_mse = pyrenn_mse(net, x, t)
    started = time.thread_time()
    # trainlm's rules: mu starts at 0.001 and moves by factors of 10.
    net = pyrenn.train_LM(x.T, t.T, net, k_max=epochs, E_stop=0.0, dampfac=1e-3, dampconst=10.0)
    seconds = time.thread_time() - started
    final_mse = pyrenn_mse(net, x, t)
    history = [float(v) / t.size for v in net["ErrorHistory"]]
    fixture = {
        "description": "pyrenn train_LM from spincal's Nguyen-Widrow weights on spincal's scaled training data; "
        "written by bench/ann/run.sh (bench/ann/bench.py peer)",
        "pyrenn_version": "0.1",
        "numpy_version": np.__version__,
        "epochs": epochs,
        "mu_initial": 1e-3,
        "mu_factor": 10.0,
        "sizes": sizes,
        "seed": e["seed"],
        "initial_weights": e["initial_weights"],
        "inputs": e["inputs"],
        "targets": e["targets"],
        "pyrenn_initial_mse": start_mse,
        "pyrenn_final_mse": final_mse,
        "pyrenn_mse_history": history,
        "pyrenn_seconds": seconds,
        # What made it; the Rust test fixture_scripts fails when these change unregenerated.
        "scripts_sha256": {
            n: hashlib.sha256(open(os.path.join(ROOT, n), "rb").read()).hexdigest()
            for n in ["bench/ann/bench.py", "bench/ann/run.sh"]
        },
    }
    with open(fixture_path, "w") as f:
        json.dump(fixture, f)
    print(json.dumps({"pyrenn_initial_mse": start_mse, "pyrenn_final_mse": final_mse, "epochs": epochs,
                      "seconds": seconds}))


def time_pyrenn_train(sizes, weights, x, t, epochs):
    """CPU seconds of one pyrenn train_LM call of `epochs` epochs from the given weights."""
    net = pyrenn_net(sizes, weights)
    started = time.thread_time()
    pyrenn.train_LM(x.T, t.T, net, k_max=epochs, E_stop=0.0, dampfac=1e-3, dampconst=10.0)
    return time.thread_time() - started


def time_numpy_epoch(sizes, weights, x, t, rounds):
    """CPU seconds of one numpy epoch per round (after one warm-up epoch)."""
    flat = np.asarray(weights, dtype=float)
    numpy_epoch(flat, sizes, x, t, 1e-3)
    times = []
    for _ in range(rounds):
        started = time.thread_time()
        numpy_epoch(flat, sizes, x, t, 1e-3)
        times.append(time.thread_time() - started)
    return times


def median(v):
    """The upper median (the middle value for odd counts), as ann_epoch takes it."""
    return sorted(v)[len(v) // 2]


def numpy_dgemm_gflops():
    n = 2000
    rng = np.random.default_rng(1)
    a, b = rng.random((n, n)), rng.random((n, n))
    best = float("inf")
    for _ in range(3):
        started = time.thread_time()
        a @ b
        best = min(best, time.thread_time() - started)
    return 2.0 * n ** 3 / best / 1e9


def epoch(rust_times_path, faer_path, rounds, pyrenn_rounds, epochs, exports):
    """Times numpy and pyrenn epochs on each export and compares them with spincal's.

    Repetition rule, the same on every side: a warm-up, then `rounds` timed runs (pyrenn:
    `pyrenn_rounds`, each of its runs being seconds long); best and median are both reported.
    pyrenn's train_LM computes the Jacobian once before the first epoch and once after every
    epoch, so train_LM(k_max=1) does two Jacobians' work: its epoch is taken as
    (T(k_max=K) − T(k_max=1)) / (K − 1), best from the two bests and median from the two
    medians; spincal's marginal epoch is taken by the same rule (ann_epoch time --epochs K).
    """
    rust = {}
    with open(rust_times_path) as f:
        for line in f:
            if line.strip():
                r = json.loads(line)
                rust[r["n"]] = r
    with open(faer_path) as f:
        faer_gflops = json.load(f)["faer_dgemm_gflops"]
    numpy_gflops = numpy_dgemm_gflops()
    peak = max(faer_gflops, numpy_gflops)
    results = {"faer_dgemm_gflops": faer_gflops, "numpy_dgemm_gflops": numpy_gflops,
               "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"), "rounds": rounds,
               "pyrenn_rounds": pyrenn_rounds, "marginal_epochs": epochs, "sizes": []}
    for path in exports:
        e, sizes, x, t = load_export(path)
        n = x.shape[0]
        r = rust[n]
        assert r["marginal_epochs"] == epochs, "spincal's marginal epoch must use the same K"
        w = e["initial_weights"]
        numpy_times = time_numpy_epoch(sizes, w, x, t, rounds)
        time_pyrenn_train(sizes, w, x[:200], t[:200], 1)  # warm-up (imports, first calls)
        one, many = [], []
        for _ in range(pyrenn_rounds):  # interleaved, so a slow spell hits both alike
            one.append(time_pyrenn_train(sizes, w, x, t, 1))
            many.append(time_pyrenn_train(sizes, w, x, t, epochs))
        pyrenn_best = (min(many) - min(one)) / (epochs - 1)
        pyrenn_median = (median(many) - median(one)) / (epochs - 1)
        sp_best, sp_median = r["seconds_per_epoch"], r["seconds_per_epoch_median"]
        spm_best, spm_median = r["marginal_seconds_per_epoch"], r["marginal_seconds_per_epoch_median"]
        bound_s = r["flops"] / (peak * 1e9)
        row = {
            "n": n,
            "params": r["params"],
            "spincal_s": sp_best, "spincal_s_median": sp_median,
            "spincal_marginal_s": spm_best, "spincal_marginal_s_median": spm_median,
            "numpy_s": min(numpy_times), "numpy_s_median": median(numpy_times),
            "pyrenn_s": pyrenn_best, "pyrenn_s_median": pyrenn_median,
            "pyrenn_kmax1_s": min(one), "pyrenn_kmax1_s_median": median(one),
            "pyrenn_kmax_s": min(many), "pyrenn_kmax_s_median": median(many),
            "pyrenn_over_spincal": pyrenn_best / spm_best,
            "pyrenn_over_spincal_median": pyrenn_median / spm_median,
            "numpy_over_spincal": min(numpy_times) / sp_best,
            "numpy_over_spincal_median": median(numpy_times) / sp_median,
            "flops": r["flops"],
            "factored_product_flops": r["factored_product_flops"],
            "factored_product_flops_unpadded": r["factored_product_flops_unpadded"],
            "syrk_flops": r["syrk_flops"],
            "flop_bound_s": bound_s,
            "spincal_over_bound": sp_best / bound_s,
            "spincal_over_bound_median": sp_median / bound_s,
            "spincal_marginal_over_bound": spm_best / bound_s,
            "spincal_marginal_over_bound_median": spm_median / bound_s,
            "spincal_s_by_block_samples": r["seconds_by_block_samples"],
        }
        results["sizes"].append(row)
        print(f"N={n} (best / median):")
        print(f"  spincal one epoch {sp_best*1e3:.2f} / {sp_median*1e3:.2f} ms; marginal epoch "
              f"((K={epochs}) - (K=1)) / {epochs - 1} {spm_best*1e3:.2f} / {spm_median*1e3:.2f} ms "
              f"({r['rounds']} rounds of >= 1 s each)")
        print(f"  numpy one epoch {min(numpy_times)*1e3:.2f} / {median(numpy_times)*1e3:.2f} ms ({rounds} runs): "
              f"{row['numpy_over_spincal']:.2f}x / {row['numpy_over_spincal_median']:.2f}x spincal's one epoch")
        print(f"  pyrenn train_LM k_max=1 {min(one):.3f} / {median(one):.3f} s, k_max={epochs} "
              f"{min(many):.3f} / {median(many):.3f} s ({pyrenn_rounds} runs each) -> epoch "
              f"{pyrenn_best:.3f} / {pyrenn_median:.3f} s: {row['pyrenn_over_spincal']:.0f}x / "
              f"{row['pyrenn_over_spincal_median']:.0f}x spincal's marginal epoch "
              f"(k_max=1 over spincal's one epoch, the old rule: {min(one) / sp_best:.0f}x)")
        print(f"  FLOP bound {bound_s*1e3:.3f} ms at {peak:.1f} GFLOP/s: spincal's one epoch at "
              f"{row['spincal_over_bound']:.3f}x / {row['spincal_over_bound_median']:.3f}x the bound (goal 1.4x); "
              f"marginal epoch at {spm_best / bound_s:.3f}x / {spm_median / bound_s:.3f}x")
        print(f"  the bound counts JtJ over the rows of J ({r['syrk_flops']/1e6:.1f} MFLOP, as numpy and pyrenn form it); "
              f"spincal forms JtJ and Jte from Kronecker factors: {r['factored_product_flops']/1e6:.1f} MFLOP in "
              f"its products ({r['factored_product_flops_unpadded']/1e6:.1f} without tile padding)")
    print(f"DGEMM 2000x2000 one thread (best of 3): faer {faer_gflops:.2f} GFLOP/s, numpy {numpy_gflops:.2f} GFLOP/s")
    print(json.dumps(results))


if __name__ == "__main__":
    cmd = sys.argv[1]
    if cmd == "peer":
        peer(sys.argv[2], int(sys.argv[3]), sys.argv[4])
    elif cmd == "epoch":
        epoch(sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6]), sys.argv[7:])
    else:
        sys.exit(__doc__)
