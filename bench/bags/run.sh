#!/usr/bin/env bash
# MCAP reading speed: spincal's ROS 2 MCAP reader against the Python `mcap` reader (with
# mcap-ros2-support's decoder, and with a hand-written struct CDR decoder) on the same bag of
# MESSAGES sensor_msgs/msg/Imu messages, in one run. Usage: bench/bags/run.sh [MESSAGES] [REPEATS] [CPU]
# Both sides pinned to one CPU (default 1), single-threaded; best and median of REPEATS after a
# warm-up, file read included; cpu s is the least on-CPU time of a repeat. The readers' checksums
# (Σ t + Σ accel + Σ gyro) are printed to show they produced the same samples. Writes only bench/out/bags.
set -euo pipefail
cd "$(dirname "$0")/../.."
MESSAGES=${1:-1000000}
REPEATS=${2:-5}
CPU=${3:-1}
OUT=bench/out/bags
VENV=bench/.venv-bags
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install -q numpy==2.1.3 mcap==1.6.0 mcap-ros2-support==0.6.0
fi
cargo build --release -q -p spincal --example bag_bench
BIN=${CARGO_TARGET_DIR:-target}/release/examples/bag_bench
mkdir -p "$OUT"
BAG=$OUT/imu_$MESSAGES.mcap
[ -f "$BAG" ] || "$VENV/bin/python" bench/bags/peers.py gen "$BAG" "$MESSAGES"
echo "load before: $(uptime)"
{
    RAYON_NUM_THREADS=1 taskset -c "$CPU" "$BIN" read "$BAG" "$REPEATS"
    taskset -c "$CPU" "$VENV/bin/python" bench/bags/peers.py read "$BAG" "$REPEATS"
} > "$OUT/times.txt"
echo "load after:  $(uptime)"
echo "messages: $MESSAGES ($(du -m "$BAG" | cut -f1) MB, uncompressed chunks); best and median of $REPEATS; pinned to CPU $CPU;" \
    "mcap $("$VENV/bin/python" -c 'import importlib.metadata as m; print(m.version("mcap"))')," \
    "mcap-ros2-support $("$VENV/bin/python" -c 'import importlib.metadata as m; print(m.version("mcap-ros2-support"))')"
awk '
    { name[NR] = $1; best[NR] = $2; med[NR] = $3; cpu[NR] = $4; mb[NR] = $5; n[NR] = $6; sum[NR] = $7
      if ($1 == "spincal-mcap") { sb = $2; sm = $3; sc = $4; ss = $7 } }
    END {
        printf "%-14s %8s %8s %8s %8s %12s  %-22s %s\n", "reader", "best s", "median s", "cpu s", "MB/s",
            "samples/s", "checksum", "spincal x faster (best / median / cpu)"
        for (i = 1; i <= NR; i++)
            printf "%-14s %8.3f %8.3f %8.3f %8.1f %12.0f  %-22s %6.1f / %5.1f / %5.1f\n", name[i], best[i],
                med[i], cpu[i], mb[i] / best[i], n[i] / best[i], sum[i], best[i] / sb, med[i] / sm, cpu[i] / sc
        for (i = 1; i <= NR; i++) { d = sum[i] - ss; if (d < 0) d = -d; if (d > maxd) maxd = d }
        printf "largest checksum difference from spincal: %.3g (relative %.3g)\n", maxd, maxd / (ss < 0 ? -ss : ss)
    }' "$OUT/times.txt"
