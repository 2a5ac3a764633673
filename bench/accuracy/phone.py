"""The phone variant of independent.py (`generate … --phone`): a smartphone on a record player,
every recording a phyphox simple-experiment zip as the Android app writes it.

From first principles in numpy, nothing shared with `spincal::simulate`:
- Sensors: independent.py's ±2 g accelerometer draw (bias, scale, misalignment, q up to 0.4 % at
  1 g, noise 0.02 m/s²) and a phone gyro m = b + K ω + noise (b within ±0.01 rad/s, K within 1 %
  of one on the diagonal and 5 mrad off it, noise 0.002 rad/s). The phone stays on: one bias for
  every recording, held-out ones included, and every campaign entry in one `session`.
- Clocks: each sensor samples on its own clock, 100 Hz nominal with the gyro's rate 2 % either
  side, its first sample a few ms after START, each stamp jittered (sd 10 % of an interval,
  clipped at 30 %). The true force is taken at the stamps as printed.
- Still poses (8 s each, as independent.py's): the first half (up to six) are faces, screen
  up, screen down, the left edge down (+x up), the bottom edge down (+y up), then the right and
  top edges down, each off level by a degree or two (a table, a book); the rest are tilted 45° ±
  5° from a random face about a random axis perpendicular to it. For 7: four faces and three
  45° poses; for 12: six and six.
- Runs (45 s each): 33⅓ and 45 rpm, the platter turning clockwise from above (as record players
  do) 1 % fast, its spindle tilted 0.05–0.4°, in two placements: A, the phone flat, screen up,
  its top (+y) away from the spindle, turned ±3° about the spindle by eye and tilted ~0.5° on
  its mat; B, the same turned end for end (180° about the spindle's direction through the
  phone's centre), re-placed with a new small tilt. The phone's centre at 95–105 mm; the chip
  30 mm at most off it in x and y, 4 mm in z. No radius in the campaign file; `placement =
  "A"`/`"B"`.
- Held out: eight still poses at uniformly random orientations and one 30 s run at 78 rpm (a
  speed the campaign never saw) in placement A as its training runs left it.
Earth's rotation (7e-5 rad/s) and the platter's wow are left out.

The zip (phyphox-android DataExport.java `CsvFormat`, comma and decimal point, the default):
one member per export set, `Accelerometer.csv` and `Gyroscope.csv` (SimpleExperimentCreator's
set names, header `"Time (s)","Acceleration x (m/s^2)",…` and `"Gyroscope x (rad/s)"`), a quoted
header joined by the separator, numbers as Java's DecimalFormat("0.000000000E0"), each line
ending "\\n"; then `meta/device.csv` (`"property","value"` rows) and `meta/time.csv`
(`"event","experiment time","system time","system time text"`, the system time in s with three
decimals).
"""

import os
import zipfile

import numpy as np

import independent as ind

RATE_HZ = 100.0
GYRO_NOISE = 0.002
STILL_S = 8.0
RUN_S = 45.0
HELD_OUT_RUN_S = 30.0
HELD_OUT_POSES = 8
HELD_OUT_RPM = 78.0
FAST = 1.01  # the platter's speed over its nominal
FACES = ["+z", "-z", "+x", "+y", "-x", "-y"]
ACCEL_HEADER = ["Time (s)", "Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)"]
GYRO_HEADER = ["Time (s)", "Gyroscope x (rad/s)", "Gyroscope y (rad/s)", "Gyroscope z (rad/s)"]


def java_number(v):
    """Java's DecimalFormat("0.000000000E0") in Locale.ENGLISH: ten significant digits, the
    exponent without sign padding (1.234567890E-3, -2.000000000E0)."""
    mantissa, exponent = ("%.9e" % v).split("e")
    return "%sE%d" % (mantissa, int(exponent))


def printed(values):
    """The values as the app's text carries them (what a reader gets back)."""
    return np.vectorize(lambda v: float(java_number(v)))(values)


def draw_gyro(rng):
    bias = rng.uniform(-0.01, 0.01, 3)
    k = rng.uniform(-0.005, 0.005, (3, 3))
    k[np.diag_indices(3)] = 1 + rng.uniform(-0.01, 0.01, 3)
    return {"bias": bias, "k": k}


def read_gyro(gyro, w, rng):
    return gyro["bias"] + w @ gyro["k"].T + rng.normal(0, GYRO_NOISE, w.shape)


def stamps(rng, seconds, rate_hz):
    """A sensor clock: its own rate, a first sample a few ms after START, jittered stamps."""
    n = int(seconds * rate_hz)
    jitter = np.clip(rng.normal(0, 0.1, n), -0.3, 0.3)
    return printed(rng.uniform(0.002, 0.02) + (np.arange(n) + jitter) / rate_hz)


def clocks(rng, seconds):
    return stamps(rng, seconds, RATE_HZ), stamps(rng, seconds, RATE_HZ * (1 + rng.uniform(-0.02, 0.02)))


def rotation_about(axis, angle):
    return ind.small_rotation(np.asarray(axis) / np.linalg.norm(axis) * angle)


def design(rng, poses):
    """Up in the phone's frame for each training pose: faces first, then 45° tilts."""
    n_faces = min(6, (poses + 1) // 2)
    ups = []
    for i in range(poses):
        face = ind.axis_vector(FACES[i % 6] if i < n_faces else FACES[rng.integers(6)])
        if i < n_faces:
            ups.append(ind.small_rotation(rng.normal(0, np.radians(1.0), 3)) @ face)
            continue
        # A random axis perpendicular to the face, and a turn of 45° ± 5° about it.
        axis = np.cross(face, rng.normal(size=3))
        ups.append(rotation_about(axis, np.radians(45 + rng.uniform(-5, 5))) @ face)
    return ups


class Placement:
    """The phone on the platter. `m` turns phone-frame vectors into the platter frame (radial,
    tangential, spindle); the chip sits at `centre` (radial) plus m·chip."""

    def __init__(self, rng, turned, chip):
        # Phone +y radial (away from the spindle), +z up; turned end for end: −y radial.
        m0 = np.array([[0, 1.0, 0], [-1.0, 0, 0], [0, 0, 1.0]])
        if turned:
            m0 = np.diag([-1.0, -1.0, 1.0]) @ m0
        yaw = rotation_about([0, 0, 1], rng.uniform(-0.05, 0.05))
        self.m = yaw @ m0 @ ind.small_rotation(rng.normal(0, np.radians(0.5), 3))
        self.centre = rng.uniform(0.095, 0.105)
        self.chip = chip
        self.out = "-y" if turned else "+y"

    def chip_in_platter(self):
        return np.array([self.centre, 0.0, 0.0]) + self.m @ self.chip

    def radius(self):
        return float(np.hypot(*self.chip_in_platter()[:2]))

    def run(self, rng, rpm, seconds):
        """(accelerometer stamps, specific force there; gyro stamps, rotation rate there)."""
        omega = FAST * rpm * 2 * np.pi / 60
        tilt = np.radians(rng.uniform(0.05, 0.4))
        tilt_direction = rng.uniform(0, 2 * np.pi)
        theta0 = rng.uniform(0, 2 * np.pi)
        p = self.chip_in_platter()
        ta, tg = clocks(rng, seconds)
        # Record players turn clockwise seen from above: the platter's angle about up is −ω t, and
        # world up's tilt, seen from the platter, turns the other way.
        phase = tilt_direction + theta0 + omega * ta
        up = np.stack([np.sin(tilt) * np.cos(phase), np.sin(tilt) * np.sin(phase), np.full(len(ta), np.cos(tilt))], axis=1)
        f_platter = ind.G * up
        f_platter[:, :2] -= omega**2 * p[:2]
        w_phone = self.m.T @ np.array([0, 0, -omega])
        return ta, f_platter @ self.m, tg, np.tile(w_phone, (len(tg), 1))


def csv_text(header, t, values):
    lines = [",".join('"%s"' % h for h in header)]
    for row in np.column_stack([t, values]):
        lines.append(",".join(java_number(v) for v in row))
    return "\n".join(lines) + "\n"


DEVICE = [
    ("version", "1.2.0"),
    ("build", "1020009"),
    ("fileFormat", "1.19"),
    ("deviceModel", "Pixel 7"),
    ("deviceManufacturer", "Google"),
    ("deviceBrand", "google"),
    ("deviceBoard", "panther"),
    ("deviceBaseOS", ""),
    ("deviceCodename", "REL"),
    ("deviceRelease", "14"),
    ("accelerometer Name", "LSM6DSV Accelerometer"),
    ("accelerometer Vendor", "STMicro"),
    ("gyroscope Name", "LSM6DSV Gyroscope"),
    ("gyroscope Vendor", "STMicro"),
]


def write_zip(path, ta, accel, tg, gyro, start_unix_s):
    """One simple-experiment export: both sets, meta/device.csv and meta/time.csv."""
    device = '"property","value"\n' + "".join('"%s","%s"\n' % kv for kv in DEVICE)
    ms = int(round(start_unix_s * 1000))
    text = np.datetime_as_string(np.datetime64(ms, "ms"), unit="ms").replace("T", " ")
    time = '"event","experiment time","system time","system time text"\n"START",%s,%.3f,"%s UTC+00:00"\n' % (
        java_number(0.0),
        ms / 1000,
        text,
    )
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("Accelerometer.csv", csv_text(ACCEL_HEADER, ta, accel))
        z.writestr("Gyroscope.csv", csv_text(GYRO_HEADER, tg, gyro))
        z.writestr("meta/device.csv", device)
        z.writestr("meta/time.csv", time)


def generate(out, seed, poses, datasheet=False):
    rng = np.random.default_rng(seed)
    sensor = ind.draw_sensor(rng)
    gyro = draw_gyro(rng)
    os.makedirs(os.path.join(out, "held_out"), exist_ok=True)
    lines = ['unit = "phone-%d"' % seed, "range_g = 2", "nonlinearity_pct_fs = 0.5"] + (ind.DATASHEET_BOUNDS if datasheet else []) + [""]
    clock = [1.8e9 + rng.uniform(0, 1e6)]  # Unix time of the next START

    def record(path, ta, f, tg, w):
        """Reads both sensors, writes the zip; returns the accelerometer's readings as printed."""
        y = printed(ind.read(sensor, f, rng, np.zeros(3)))
        write_zip(path, ta, y, tg, printed(read_gyro(gyro, w, rng)), clock[0])
        clock[0] += ta[-1] + rng.uniform(20, 60)
        return y

    def still(up, seconds):
        ta, tg = clocks(rng, seconds)
        return ta, np.tile(ind.G * up, (len(ta), 1)), tg, np.zeros((len(tg), 3))

    for p, up in enumerate(design(rng, poses)):
        name = "pose-%02d.zip" % (p + 1)
        record(os.path.join(out, name), *still(up, STILL_S))
        lines += ["[[recording]]", 'file = "%s"' % name, 'kind = "static"', 'session = "phone"', ""]
    chip = np.array([rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), rng.uniform(-0.004, 0.004)])
    placements = {"A": Placement(rng, False, chip), "B": Placement(rng, True, chip)}
    for label, placement in placements.items():
        for rpm in (33.333, 45.0):
            name = "run-%s-%d.zip" % (label, rpm)
            record(os.path.join(out, name), *placement.run(rng, rpm, RUN_S))
            lines += [
                "[[recording]]",
                'file = "%s"' % name,
                'kind = "turntable"',
                "rpm = %s" % rpm,
                'out = "%s"' % placement.out,
                'up = "+z"',
                'placement = "%s"' % label,
                'session = "phone"',
                "",
            ]
    with open(os.path.join(out, "campaign.toml"), "w") as f:
        f.write("\n".join(lines))
    truth = {
        "mode": "phone",
        "sensor": {k: np.asarray(v).tolist() for k, v in sensor.items()},
        "gyro": {k: np.asarray(v).tolist() for k, v in gyro.items()},
        "chip_offset_m": chip.tolist(),
        "placements": {k: {"radius_m": p.radius(), "centre_radius_m": p.centre} for k, p in placements.items()},
        "held_out": [],
    }
    held = [("pose-%d" % (p + 1), still(ind.random_rotation(rng).T @ np.array([0, 0, 1.0]), STILL_S)) for p in range(HELD_OUT_POSES)]
    held.append(("run-A-%d" % HELD_OUT_RPM, placements["A"].run(rng, HELD_OUT_RPM, HELD_OUT_RUN_S)))
    for name, (ta, f, tg, w) in held:
        y = record(os.path.join(out, "held_out", name + ".zip"), ta, f, tg, w)
        base = os.path.join(out, "held_out", name)
        np.save(base + ".time.npy", ta)
        np.save(base + ".raw.npy", y)
        np.save(base + ".truth.npy", f)
        np.save(base + ".oracle.npy", ind.oracle(sensor, y, np.zeros(3)))
        truth["held_out"].append(name)
    return truth
