"""MCAP bag benchmark, Python side.

`peers.py gen FILE N` writes a ROS 2 MCAP file of N sensor_msgs/msg/Imu messages (CDR, uncompressed
chunks; what `ros2 bag record -s mcap` writes by default) with the `mcap` package's writer.
`peers.py read FILE REPEATS` times two readers of it, each to the same arrays spincal makes (time
from the header stamps counted from the first, accel and gyro), and prints
`name best_seconds median_seconds cpu_seconds megabytes samples checksum`:

  mcap-ros2        mcap_ros2.reader.read_ros2_messages (the decoder users call)
  mcap-struct      mcap's reader + a hand-written CDR decoder (struct, lengths checked)
"""

import math
import os
import struct
import sys
import time

import numpy as np
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

IMU_DEF = """std_msgs/Header header
geometry_msgs/Quaternion orientation
float64[9] orientation_covariance
geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance
geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Quaternion
float64 x 0
float64 y 0
float64 z 0
float64 w 1
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"""

FRAME = b"imu_link\x00"
# header: 4 encapsulation, sec, nanosec, len + "imu_link\0" (9) → body offset 4+8+4+9 = 25 → pad to 32
HEAD = struct.Struct("<4siII9s3x")
BODY = struct.Struct("<37d")


def cpu_seconds():
    try:
        with open("/proc/self/schedstat") as f:
            return int(f.read().split()[0]) * 1e-9
    except OSError:
        return 0.0


def gen(path, n):
    rng = np.random.default_rng(1)
    acc = rng.uniform(-2, 2, (n, 3)) + [0, 0, 9.8]
    gyr = rng.uniform(-1, 1, (n, 3))
    t0 = 1_700_000_000 * 10**9
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.NONE)
        w.start(profile="ros2", library="spincal-bench")
        sid = w.register_schema(name="sensor_msgs/msg/Imu", encoding="ros2msg", data=IMU_DEF.encode())
        cid = w.register_channel(topic="/imu", message_encoding="cdr", schema_id=sid)
        cov = [0.0] * 9
        orient = [0.0, 0.0, 0.0, 1.0]
        ocov = [-1.0] + [0.0] * 8
        for i in range(n):
            ns = t0 + i * 5_000_000
            data = HEAD.pack(b"\x00\x01\x00\x00", ns // 10**9, ns % 10**9, len(FRAME), FRAME) + BODY.pack(
                *orient, *ocov, *gyr[i], *cov, *acc[i], *cov
            )
            w.add_message(channel_id=cid, log_time=ns + 1000, publish_time=ns, data=data, sequence=i)
        w.finish()


def finish(t_ns, a, g):
    t_ns = np.asarray(t_ns, dtype=np.int64)
    t = (t_ns - t_ns[0]) * 1e-9
    a = np.asarray(a)
    g = np.asarray(g)
    return t, a, g


def read_ros2(path):
    from mcap_ros2.reader import read_ros2_messages

    ts, a, g = [], [], []
    for m in read_ros2_messages(path, topics=["/imu"]):
        msg = m.ros_msg
        st = msg.header.stamp
        ts.append(st.sec * 1_000_000_000 + st.nanosec)
        la, av = msg.linear_acceleration, msg.angular_velocity
        a.append((la.x, la.y, la.z))
        g.append((av.x, av.y, av.z))
    return finish(ts, a, g)


def decode_cdr(data):
    """sensor_msgs/Imu from plain little-endian CDR, every length checked."""
    if len(data) < 16 or data[0] != 0 or data[1] != 1:
        raise ValueError("not little-endian plain CDR")
    sec, nsec, slen = struct.unpack_from("<iII", data, 4)
    pos = 16 + slen
    if slen > len(data) - 16:
        raise ValueError("frame_id runs past the message")
    pos = 4 + ((pos - 4 + 7) // 8) * 8
    if len(data) - pos < 37 * 8:
        raise ValueError("message too short")
    v = struct.unpack_from("<37d", data, pos)
    return sec * 1_000_000_000 + nsec, v[25:28], v[13:16]


def read_struct(path):
    ts, a, g = [], [], []
    with open(path, "rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages(topics=["/imu"]):
            t, acc, gyr = decode_cdr(message.data)
            ts.append(t)
            a.append(acc)
            g.append(gyr)
    return finish(ts, a, g)


def main():
    if sys.argv[1] == "gen":
        gen(sys.argv[2], int(sys.argv[3]))
        return
    path, repeats = sys.argv[2], int(sys.argv[3])
    mb = os.path.getsize(path) / 1e6
    for name, fn in (("mcap-ros2", read_ros2), ("mcap-struct", read_struct)):
        fn(path)  # warm-up
        secs, cpu = [], math.inf
        for _ in range(repeats):
            w0, c0 = time.perf_counter(), cpu_seconds()
            t, a, g = fn(path)
            secs.append(time.perf_counter() - w0)
            cpu = min(cpu, cpu_seconds() - c0)
        secs.sort()
        checksum = t.sum() + a.sum() + g.sum()
        print(f"{name} {secs[0]:.6f} {secs[len(secs) // 2]:.6f} {cpu:.6f} {mb:.3f} {len(t)} {checksum:.9e}")


if __name__ == "__main__":
    main()
