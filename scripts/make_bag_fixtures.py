#!/usr/bin/env python3
"""Writes ROS bags from a spincal CSV recording with the pure-Python `rosbags` package.

Usage: .venv/bin/python scripts/make_bag_fixtures.py RECORDING.csv OUT_DIR

The CSV has a header `t_s,ax_mps2,ay_mps2,az_mps2[,gx_radps,gy_radps,gz_radps]` or the same
with `ax_g,ay_g,az_g` (what `Recording::write_csv` and `spincal simulate` write); g is converted
to m/s² (× 9.80665, REP-103). Every sample becomes one message whose
header stamp is EPOCH + t (ns, rounded) and whose receive (log) time is 1 ms later; values are
float64 as in the CSV. Written into OUT_DIR (which must not exist):

  mcap/, mcap_zstd/, sqlite3/      ROS 2 bag directories: /imu (sensor_msgs/msg/Imu) and
                                   /temperature (sensor_msgs/msg/Temperature, not an IMU topic);
                                   mcap_zstd/ has zstd-compressed chunks
  ros1_none.bag, ros1_bz2.bag, ros1_lz4.bag   ROS 1 bags, the same topics, chunk compressions
  two_imus_mcap/, two_imus_sqlite3/, two_imus.bag   /imu and /imu_b (values × 2): a topic to choose
  pairs_mcap/, pairs.bag           geometry_msgs/Vector3Stamped /camera/accel/sample and
                                   /camera/gyro/sample (the RealSense layout), same stamps
  zero_stamps/                     mcap, /imu with zero header stamps (receive times count)
"""

import csv
import sys
from pathlib import Path

from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin, Writer as Writer2
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
from rosbags.typesys import Stores, get_typestore

EPOCH_NS = 1_700_000_000 * 10**9
STANDARD_GRAVITY = 9.80665
LATENCY_NS = 1_000_000
IMU = "sensor_msgs/msg/Imu"
TEMP = "sensor_msgs/msg/Temperature"
VEC = "geometry_msgs/msg/Vector3Stamped"


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, data = rows[0], rows[1:]
    cols = {name: i for i, name in enumerate(header)}
    out = []
    for r in data:
        t = float(r[cols["t_s"]])
        if "ax_mps2" in cols:
            a = [float(r[cols[k]]) for k in ("ax_mps2", "ay_mps2", "az_mps2")]
        else:
            # REP-103: m/s² in the message; the same product spincal forms reading `_g` columns.
            a = [float(r[cols[k]]) * STANDARD_GRAVITY for k in ("ax_g", "ay_g", "az_g")]
        g = [float(r[cols[k]]) for k in ("gx_radps", "gy_radps", "gz_radps")] if "gx_radps" in cols else None
        out.append((t, a, g))
    return out


class Msgs:
    def __init__(self, store):
        self.ts = store
        T = store.types
        self.Time = T["builtin_interfaces/msg/Time"]
        self.Header = T["std_msgs/msg/Header"]
        self.Imu = T[IMU]
        self.Quat = T["geometry_msgs/msg/Quaternion"]
        self.Vec3 = T["geometry_msgs/msg/Vector3"]
        self.V3S = T[VEC]
        self.Temp = T[TEMP]
        import numpy as np

        self.np = np

    def header(self, ns, frame):
        stamp = self.Time(sec=ns // 10**9, nanosec=ns % 10**9)
        if "seq" in self.Header.__dataclass_fields__:
            return self.Header(seq=0, stamp=stamp, frame_id=frame)
        return self.Header(stamp=stamp, frame_id=frame)

    def imu(self, ns, a, g, scale=1.0):
        np = self.np
        cov_g = np.zeros(9)
        if g is None:
            cov_g[0] = -1.0
            g = [0.0, 0.0, 0.0]
        orient_cov = np.zeros(9)
        orient_cov[0] = -1.0
        return self.Imu(
            header=self.header(ns, "imu_link"),
            orientation=self.Quat(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=orient_cov,
            angular_velocity=self.Vec3(x=g[0] * scale, y=g[1] * scale, z=g[2] * scale),
            angular_velocity_covariance=cov_g,
            linear_acceleration=self.Vec3(x=a[0] * scale, y=a[1] * scale, z=a[2] * scale),
            linear_acceleration_covariance=np.zeros(9),
        )

    def vec(self, ns, v, frame):
        return self.V3S(header=self.header(ns, frame), vector=self.Vec3(x=v[0], y=v[1], z=v[2]))

    def temp(self, ns):
        return self.Temp(header=self.header(ns, "imu_link"), temperature=25.0, variance=0.0)


def stamp(t):
    return EPOCH_NS + round(t * 1e9)


def messages(m, rows, kind):
    """(topic, msgtype, log_ns, message) in log-time order."""
    for i, (t, a, g) in enumerate(rows):
        ns = stamp(t)
        log = ns + LATENCY_NS
        if kind == "imu":
            yield "/imu", IMU, log, m.imu(ns, a, g)
            if i % 100 == 0:
                yield "/temperature", TEMP, log, m.temp(ns)
        elif kind == "two":
            yield "/imu", IMU, log, m.imu(ns, a, g)
            yield "/imu_b", IMU, log, m.imu(ns, a, g, scale=2.0)
        elif kind == "pairs":
            yield "/camera/accel/sample", VEC, log, m.vec(ns, a, "accel_frame")
            yield "/camera/gyro/sample", VEC, log, m.vec(ns, g, "gyro_frame")
        elif kind == "zero":
            yield "/imu", IMU, ns, m.imu(0, a, g)


def write2(path, rows, kind, storage, zstd=False):
    store = get_typestore(Stores.ROS2_HUMBLE)
    m = Msgs(store)
    w = Writer2(path, version=9, storage_plugin=storage)
    if zstd:
        w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    conns = {}
    with w:
        for topic, ty, log, msg in messages(m, rows, kind):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, ty, typestore=store)
            w.write(conns[topic], log, store.serialize_cdr(msg, ty))


def write1(path, rows, kind, compression=None):
    store = get_typestore(Stores.ROS1_NOETIC)
    m = Msgs(store)
    w = Writer1(path)
    if compression is not None:
        w.set_compression(compression)
    conns = {}
    with w:
        for topic, ty, log, msg in messages(m, rows, kind):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, ty, typestore=store)
            w.write(conns[topic], log, store.serialize_ros1(msg, ty))


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = read_csv(sys.argv[1])
    out = Path(sys.argv[2])
    out.mkdir(parents=True)
    write2(out / "mcap", rows, "imu", StoragePlugin.MCAP)
    write2(out / "mcap_zstd", rows, "imu", StoragePlugin.MCAP, zstd=True)
    write2(out / "sqlite3", rows, "imu", StoragePlugin.SQLITE3)
    write1(out / "ros1_none.bag", rows, "imu")
    write1(out / "ros1_bz2.bag", rows, "imu", Writer1.CompressionFormat.BZ2)
    write1(out / "ros1_lz4.bag", rows, "imu", Writer1.CompressionFormat.LZ4)
    write2(out / "two_imus_mcap", rows, "two", StoragePlugin.MCAP)
    write2(out / "two_imus_sqlite3", rows, "two", StoragePlugin.SQLITE3)
    write1(out / "two_imus.bag", rows, "two")
    if rows[0][2] is not None:
        write2(out / "pairs_mcap", rows, "pairs", StoragePlugin.MCAP)
        write1(out / "pairs.bag", rows, "pairs")
    write2(out / "zero_stamps", rows, "zero", StoragePlugin.MCAP)


if __name__ == "__main__":
    main()
