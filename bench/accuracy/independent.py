"""An independent check of what a campaign calibration saves.

Written from first principles in numpy, sharing nothing with `spincal::simulate`: a ±2 g
consumer accelerometer (bias, scale, a general 3x3 misalignment, a quadratic up to 0.4 % of the
reading at 1 g, white noise 0.02 m/s²) recorded as a user with a breakout board records it:
one CSV per still pose (time from 0 in each), four turntable runs, a campaign file with the
datasheet's range and nonlinearity and no truth keys. With `--session-sd`, each file (or, with
`--sessions K`, each of K power-on sessions of consecutive recordings, named in the campaign file
with `--session-keys`) carries its own bias offset; every held-out file has one of its own. Held out: still poses at new random
orientations and runs at new speeds, radii and mountings.

    python independent.py generate OUT SEED POSES [--one-file] [--session-sd MPS2] [--ruler-sd M] [--q QX,QY,QZ]
                                  [--sessions K [--session-keys]] [--datasheet]
    python independent.py generate OUT SEED POSES --phone [--datasheet]   (phone.py: a phone's phyphox zips)
    python independent.py evaluate OUT          (after `spincal calibrate` and `spincal correct`)

`--datasheet` also states the bounds draw_sensor draws within as the datasheet's zero-g offset,
sensitivity tolerance and cross-axis sensitivity (DATASHEET_BOUNDS).

`evaluate` prints, per held-out file and axis, the RMS of corrected − truth over the RMS of the
oracle's (the true model inverted on the same samples), and the still poses' systematic error.
"""

import json
import os
import sys

import numpy as np

G = 9.80665
RATE_HZ = 100.0
NOISE = 0.02


def random_rotation(rng):
    """A rotation drawn uniformly (a random unit quaternion)."""
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def small_rotation(angles):
    """exp([angles]x), for small angles (rad)."""
    theta = np.linalg.norm(angles)
    if theta == 0:
        return np.eye(3)
    k = np.array(angles) / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * kx @ kx


# The datasheet figures draw_sensor's bounds give, as a campaign file states them (--datasheet):
# the zero-g offset 0.2 m/s² in mg, the sensitivity tolerance 2 %, the cross-axis sensitivity 1 %.
DATASHEET_BOUNDS = ["zero_g_offset_mg = %.2f" % (0.2 / G * 1000), "sensitivity_tolerance_pct = 2", "cross_axis_pct = 1"]


def draw_sensor(rng):
    bias = rng.uniform(-0.2, 0.2, 3)
    scale = rng.uniform(-0.02, 0.02, 3)
    # The sensor's frame is defined by its axes, as every calibration without an external
    # attitude reference must: x along the x axis, y in the plane of x and y. Its axes in that
    # frame: unit x, y tilted towards x, z tilted towards x and y (a lower triangle).
    cross = np.tril(rng.uniform(-0.01, 0.01, (3, 3)), -1)
    k = np.diag(1 + scale) @ (np.eye(3) + cross)
    quadratic = rng.uniform(-1, 1, 3) * 0.004 / G  # 0.4 % of the reading at 1 g, at most
    return {"bias": bias, "k": k, "q": quadratic}


def read(sensor, f, rng, offset):
    """The sensor's reading of specific force f (n x 3, m/s²)."""
    v = f @ sensor["k"].T
    return sensor["bias"] + offset + v + sensor["q"] * v * v + rng.normal(0, NOISE, f.shape)


def oracle(sensor, y, offset):
    """The true model inverted on readings y: v + q v² = y − b, solved for the root near y − b."""
    c = y - sensor["bias"] - offset
    q = sensor["q"]
    v = np.where(np.abs(q) > 0, (-1 + np.sqrt(np.maximum(1 + 4 * q * c, 0))) / (2 * np.where(q == 0, 1, q)), c)
    return v @ np.linalg.inv(sensor["k"]).T


AXES = {"+x": (0, 1), "-x": (0, -1), "+y": (1, 1), "-y": (1, -1), "+z": (2, 1), "-z": (2, -1)}


def axis_vector(name):
    a, s = AXES[name]
    v = np.zeros(3)
    v[a] = s
    return v


def still(rng, seconds):
    """Gravity's direction in the sensor frame for a random orientation, held `seconds`."""
    up = random_rotation(rng).T @ np.array([0, 0, 1.0])
    n = int(seconds * RATE_HZ)
    return np.arange(n) / RATE_HZ, np.tile(G * up, (n, 1))


def run(rng, rpm, radius, out, up, seconds):
    """A turntable run: centripetal force toward the spindle plus gravity through the platter's
    tilt, in the frame turning with the platter, then the sensor's small tilt on its mount."""
    n = int(seconds * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    omega = rpm * (1 + rng.uniform(-0.005, 0.005)) * 2 * np.pi / 60
    tilt = np.radians(rng.uniform(0.05, 0.4))
    tilt_direction = rng.uniform(0, 2 * np.pi)
    theta = omega * t + rng.uniform(0, 2 * np.pi)
    # World up in the turning platter frame (out, tangential, spindle).
    phase = tilt_direction - theta
    up_world = np.stack(
        [np.sin(tilt) * np.cos(phase), np.sin(tilt) * np.sin(phase), np.full(n, np.cos(tilt))], axis=1
    )
    f_platter = G * up_world
    f_platter[:, 0] -= omega**2 * radius
    e_out, e_up = axis_vector(out), axis_vector(up)
    e_tan = np.cross(e_up, e_out)
    basis = np.stack([e_out, e_tan, e_up], axis=1)  # columns: platter axes in sensor coordinates
    mount = small_rotation(rng.normal(0, np.radians(0.5), 3))
    return t, (f_platter @ basis.T) @ mount.T


def write_csv(path, t, accel):
    with open(path, "w") as f:
        f.write("t_s,ax_mps2,ay_mps2,az_mps2\n")
        for row in np.column_stack([t, accel]):
            f.write("%.4f,%.6f,%.6f,%.6f\n" % tuple(row))


TRAIN_RUNS = [(33.333, 0.09, "+x", "+z"), (45.0, 0.09, "+x", "+z"), (33.333, 0.06, "+y", "+z"), (45.0, 0.06, "-y", "+z")]
HELD_OUT_RUNS = [(45.0, 0.12, "-x", "+z"), (33.333, 0.075, "+x", "-z")]
HELD_OUT_POSES = 8


def generate(out, seed, poses, one_file, session_sd, ruler_sd, quadratic=None, sessions=0, session_keys=False, datasheet=False):
    rng = np.random.default_rng(seed)
    # The radius as a ruler reads it: its own stream, so the recordings stay those of ruler_sd = 0.
    ruler = np.random.default_rng(seed + 1_000_000)
    sensor = draw_sensor(rng)
    if quadratic is not None:
        # A set nonlinearity (the terms rule's experiment), drawn values discarded.
        sensor["q"] = np.asarray(quadratic, dtype=float)
    os.makedirs(os.path.join(out, "held_out"), exist_ok=True)
    lines = ['unit = "independent-%d"' % seed, "range_g = 2", "nonlinearity_pct_fs = 0.5"] + (DATASHEET_BOUNDS if datasheet else []) + [""]
    truth = {"sensor": {k: np.asarray(v).tolist() for k, v in sensor.items()}, "held_out": []}

    def offset():
        return rng.normal(0, session_sd, 3) if session_sd > 0 else np.zeros(3)

    # With `sessions` > 0 the training recordings (poses, then runs, in order) fall into that many
    # power-on sessions of consecutive recordings, each with one offset; without, each file has its own.
    training = poses + len(TRAIN_RUNS)
    session_offsets = [offset() for _ in range(sessions)]

    def session_of(i):
        return i * sessions // training

    def training_offset(i):
        return session_offsets[session_of(i)] if sessions > 0 else offset()

    def session_line(i):
        return ['session = "power-on-%d"' % (session_of(i) + 1)] if sessions > 0 and session_keys else []

    if one_file:
        parts_t, parts_a, t0 = [], [], 0.0
        o = offset()
        for p in range(poses):
            t, f = still(rng, 8.0)
            parts_t.append(t + t0)
            # Turned by hand between poses: a 3 s move (gravity swept between the two directions).
            parts_a.append(read(sensor, f, rng, o))
            t0 += 8.0 + 3.0
            if p + 1 < poses:
                tm = np.arange(int(3 * RATE_HZ)) / RATE_HZ
                parts_t.append(tm + t0 - 3.0)
                wobble = f[-1] + rng.normal(0, 3.0, (len(tm), 3))
                parts_a.append(read(sensor, wobble, rng, o))
        write_csv(os.path.join(out, "still.csv"), np.concatenate(parts_t), np.concatenate(parts_a))
        lines += ["[[recording]]", 'file = "still.csv"', 'kind = "static"', ""]
    else:
        for p in range(poses):
            t, f = still(rng, 8.0)
            name = "pose-%02d.csv" % (p + 1)
            write_csv(os.path.join(out, name), t, read(sensor, f, rng, training_offset(p)))
            lines += ["[[recording]]", 'file = "%s"' % name, 'kind = "static"'] + session_line(p) + [""]
    for i, (rpm, radius, out_axis, up_axis) in enumerate(TRAIN_RUNS):
        t, f = run(rng, rpm, radius, out_axis, up_axis, 60.0)
        name = "run-%d.csv" % (i + 1)
        write_csv(os.path.join(out, name), t, read(sensor, f, rng, training_offset(poses + i)))
        lines += [
            "[[recording]]",
            'file = "%s"' % name,
            'kind = "turntable"',
        ] + session_line(poses + i) + [
            "rpm = %s" % rpm,
            "radius_m = %.5f" % (radius + ruler.normal(0, ruler_sd)),
            "radius_tol_m = 0.002",
            'out = "%s"' % out_axis,
            'up = "%s"' % up_axis,
            "",
        ]
    with open(os.path.join(out, "campaign.toml"), "w") as f:
        f.write("\n".join(lines))
    held = [("pose-%d" % (p + 1), still(rng, 8.0)) for p in range(HELD_OUT_POSES)]
    held += [("run-%d" % (i + 1), run(rng, *r, 30.0)) for i, r in enumerate(HELD_OUT_RUNS)]
    for name, (t, f) in held:
        o = offset()
        y = read(sensor, f, rng, o)
        write_csv(os.path.join(out, "held_out", name + ".csv"), t, y)
        np.save(os.path.join(out, "held_out", name + ".truth.npy"), f)
        # The oracle knows the sensor, not the held-out file's own offset (no corrector can).
        np.save(os.path.join(out, "held_out", name + ".oracle.npy"), oracle(sensor, y, np.zeros(3)))
        truth["held_out"].append(name)
    with open(os.path.join(out, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)


def evaluate(out):
    truth = json.load(open(os.path.join(out, "truth.json")))
    rows = []
    for name in truth["held_out"]:
        f = np.load(os.path.join(out, "held_out", name + ".truth.npy"))
        o = np.load(os.path.join(out, "held_out", name + ".oracle.npy"))
        phone = truth.get("mode") == "phone"
        if phone:
            raw = np.load(os.path.join(out, "held_out", name + ".raw.npy"))
        else:
            raw = np.loadtxt(os.path.join(out, "held_out", name + ".csv"), delimiter=",", skiprows=1)[:, 1:4]
        path = os.path.join(out, "corrected", name + ".csv")
        sd = None
        if os.path.exists(path):
            with open(path) as fh:
                header = fh.readline().strip().split(",")
            table = np.atleast_2d(np.genfromtxt(path, delimiter=",", skip_header=1))
            if phone:
                # A zip's two sensors are written on the accelerometer's stamps, those outside the
                # gyro's span dropped: each corrected row is matched to its true force by time.
                stamps = np.load(os.path.join(out, "held_out", name + ".time.npy"))
                t = table[:, header.index("t_s")]
                after = np.clip(np.searchsorted(stamps, t), 1, len(stamps) - 1)
                near = np.where(np.abs(stamps[after] - t) < np.abs(stamps[after - 1] - t), after, after - 1)
                if np.max(np.abs(stamps[near] - t)) > 1e-6:
                    raise SystemExit("%s: corrected rows whose time is no accelerometer stamp" % path)
                f, o, raw = f[near], o[near], raw[near]
            # A model that saved the gyro alone leaves the accelerometer as read (no columns).
            if "ax_corrected_mps2" in header:
                data = table[:, [header.index(c) for c in ("ax_corrected_mps2", "ay_corrected_mps2", "az_corrected_mps2")]]
            else:
                data = raw
            if "ax_corrected_sd_mps2" in header:
                sd = table[:, [header.index("a%s_corrected_sd_mps2" % a) for a in "xyz"]]
                better = table[:, header.index("predicted_better")]
        else:
            data = raw
        for k in range(3):
            oracle_rms = np.sqrt(np.mean((o[:, k] - f[:, k]) ** 2))
            err = data[:, k] - f[:, k]
            rows.append(
                {
                    "file": name,
                    "axis": "xyz"[k],
                    "ratio": float(np.sqrt(np.mean(err**2)) / oracle_rms),
                    "mse": float(np.mean(err**2)),
                    "oracle_mse": float(oracle_rms**2),
                    "raw_ratio": float(np.sqrt(np.mean((raw[:, k] - f[:, k]) ** 2)) / oracle_rms),
                    "systematic_mps2": float(np.mean(err)),
                    # The oracle's mean error on the same samples: the file's own noise (and drift)
                    # averaged, which no correction's sd holds.
                    "oracle_systematic_mps2": float(np.mean(o[:, k] - f[:, k])),
                    # The predicted sd of the correction (the parameters' part of the error).
                    "predicted_sd_mps2": None if sd is None else float(np.mean(sd[:, k])),
                    # The share of the file's rows `correct` flags as predicted to beat no correction.
                    "predicted_better_share": None if sd is None else float(np.mean(better)),
                }
            )
    worst = max(r["ratio"] for r in rows)
    worse_than_raw = sum(r["ratio"] > r["raw_ratio"] for r in rows)
    # The per-row flag against truth: among file-axes corrected worse than raw, the share of rows
    # still flagged as predicted better (should be low).
    flagged = [r["predicted_better_share"] for r in rows if r["ratio"] > r["raw_ratio"] and r.get("predicted_better_share") is not None]
    # Per axis over every held-out file: RMS error against the oracle's, pooled (the measure of an
    # offset the oracle cannot know either, where one file's small offset makes its own ratio large).
    pooled = [
        float(np.sqrt(sum(r["mse"] for r in rows if r["axis"] == a) / sum(r["oracle_mse"] for r in rows if r["axis"] == a)))
        for a in "xyz"
    ]
    # What the saved model's own covariance predicts for that pooled ratio: each file's oracle error
    # plus its predicted variance (the information the campaign left, if the covariance is right).
    predicted_pooled = (
        [
            float(np.sqrt(sum(r["oracle_mse"] + r["predicted_sd_mps2"] ** 2 for r in rows if r["axis"] == a) / sum(r["oracle_mse"] for r in rows if r["axis"] == a)))
            for a in "xyz"
        ]
        if all(r["predicted_sd_mps2"] is not None for r in rows)
        else None
    )
    summary = {"pooled_ratio": pooled, "predicted_pooled_ratio": predicted_pooled, "worse_than_raw_flagged_better": float(np.mean(flagged)) if flagged else None, "worst_ratio": worst, "mean_ratio": float(np.mean([r["ratio"] for r in rows])), "worse_than_raw": worse_than_raw, "rows": rows}
    results = os.path.join(out, "cal", "results.json")
    error_map = json.load(open(results)).get("error_map") if os.path.exists(results) else None
    if error_map is not None and all(r["predicted_sd_mps2"] is not None for r in rows):
        noise = error_map["noise_sd_mps2"]
        # Per held-out file: inside the region the verdict calls determined when every axis's
        # predicted sd is within the threshold times that axis's noise.
        inside = {
            name
            for name in truth["held_out"]
            if all(r["predicted_sd_mps2"] <= error_map["threshold"] * noise["xyz".index(r["axis"])] for r in rows if r["file"] == name)
        }
        # A held-out file's systematic error holds its own session's offset, which the correction's
        # sd leaves out: the model's session spread adds in quadrature (0 where it saw none).
        model = json.load(open(os.path.join(out, "cal", "model.json")))
        spread = model["corrector"].get("uncertainty", {}).get("session_spread_mps2") or 0.0
        z = [r["systematic_mps2"] / np.hypot(r["predicted_sd_mps2"], spread) for r in rows if r["predicted_sd_mps2"] > 0]
        z_correction = [r["systematic_mps2"] / r["predicted_sd_mps2"] for r in rows if r["predicted_sd_mps2"] > 0]
        summary.update(
            {
                "share_determined": error_map["share_determined"],
                "poses_outside": sum(p["worst_sd_over_noise"] > error_map["threshold"] for p in error_map["poses"]),
                "held_out_inside": len(inside),
                "worst_ratio_inside": max((r["ratio"] for r in rows if r["file"] in inside), default=None),
                "session_spread_mps2": spread,
                "z_sum_squares": float(np.sum(np.square(z))),
                "z_correction_sum_squares": float(np.sum(np.square(z_correction))),
                "z_count": len(z),
            }
        )
    if "placements" in truth and os.path.exists(results):
        # The chip's radius per placement, found from the runs (no radius stated) against the truth.
        found = {p["label"]: p for p in json.load(open(results)).get("placements", [])}
        summary["placements"] = {
            label: {"true_m": t["radius_m"], "found_m": found[label]["radius_m"] if label in found else None, "se_m": found[label]["radius_se_m"] if label in found else None}
            for label, t in truth["placements"].items()
        }
    print(json.dumps(summary))


def follow(unit, to, seed, name="pose-next.csv"):
    """The campaign of `unit` with the pose its verdict advises next (results.json's
    error_map.next_pose) recorded as a file of its own, `name`, 8 s, by the same sensor
    (truth.json), written to `to` with the held-out files copied: calibrated again, it shows
    whether the advice widened the trusted region as predicted. Returns False where no pose was
    advised."""
    import shutil

    results = json.load(open(os.path.join(unit, "cal", "results.json")))
    next_pose = (results.get("error_map") or {}).get("next_pose")
    if not next_pose:
        return False
    if os.path.exists(to):
        shutil.rmtree(to)
    shutil.copytree(unit, to, ignore=shutil.ignore_patterns("cal", "corrected", "score.json", "calibrate.log"))
    truth = json.load(open(os.path.join(unit, "truth.json")))
    sensor = {k: np.asarray(v) for k, v in truth["sensor"].items()}
    rng = np.random.default_rng([seed, 2, sum(map(ord, name))])
    n = int(8.0 * RATE_HZ)
    f = np.tile(G * np.asarray(next_pose["pose_direction"]), (n, 1))
    write_csv(os.path.join(to, name), np.arange(n) / RATE_HZ, read(sensor, f, rng, np.zeros(3)))
    with open(os.path.join(to, "campaign.toml"), "a") as fh:
        fh.write('\n[[recording]]\nfile = "%s"\nkind = "static"\n' % name)
    return True


if __name__ == "__main__":
    if sys.argv[1] == "follow":
        sys.exit(0 if follow(sys.argv[2], sys.argv[3], int(sys.argv[4]), *sys.argv[5:6]) else 3)
    if sys.argv[1] == "generate":
        args = sys.argv[2:]
        sd = float(args[args.index("--session-sd") + 1]) if "--session-sd" in args else 0.0
        ruler_sd = float(args[args.index("--ruler-sd") + 1]) if "--ruler-sd" in args else 0.0
        q = [float(v) for v in args[args.index("--q") + 1].split(",")] if "--q" in args else None
        sessions = int(args[args.index("--sessions") + 1]) if "--sessions" in args else 0
        if "--phone" in args:
            import phone

            truth = phone.generate(args[0], int(args[1]), int(args[2]), "--datasheet" in args)
            with open(os.path.join(args[0], "truth.json"), "w") as f:
                json.dump(truth, f, indent=1)
        else:
            generate(args[0], int(args[1]), int(args[2]), "--one-file" in args, sd, ruler_sd, q, sessions, "--session-keys" in args, "--datasheet" in args)
    else:
        evaluate(sys.argv[2])
