#!/usr/bin/env bash
# Peak memory of `spincal fit` on long recordings, against the recording's own size in memory
# (time + three axes, 32 bytes per sample). Measured with /usr/bin/time -v (maximum resident set
# size, which includes the CSV file's pages while it is read).
#
#   bash bench/memory/run.sh [OUT_DIR] [SAMPLES...]      (defaults: bench/out/memory 1000000 10000000)
#
# Simulates each recording at 100 Hz (10⁷ samples: a 632 MB CSV, a day and four hours), then fits
# it once. Nothing tracked is written.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-$root/bench/out/memory}
shift || true
sizes=("$@")
[ ${#sizes[@]} -eq 0 ] && sizes=(1000000 10000000)
mkdir -p "$out"
cd "$root"
cargo build --release -p spincal-cli --quiet
spincal=${CARGO_TARGET_DIR:-$root/target}/release/spincal
[ -x /usr/bin/time ] || { echo "needs /usr/bin/time (Debian: apt-get install time)"; exit 1; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(free -g | awk '/Mem:/{print $2}') GiB"
echo "load before: $(uptime)"
printf '%-10s %-12s %-14s %-12s %-14s %-10s\n' samples csv_MB peak_RSS_MB bytes/sample ×recording wall_s
for n in "${sizes[@]}"; do
    csv="$out/rec-$n.csv"
    [ -f "$csv" ] || "$spincal" simulate -o "$csv" --duration "$(python3 -c "print($n/100)")" --seed 3 >/dev/null
    /usr/bin/time -v "$spincal" fit "$csv" --radius 0.10 --json >"$out/fit-$n.json" 2>"$out/time-$n.txt"
    rss_kb=$(awk -F': ' '/Maximum resident/{print $2}' "$out/time-$n.txt")
    wall=$(awk -F': ' '/Elapsed \(wall/{print $2}' "$out/time-$n.txt")
    python3 - "$n" "$rss_kb" "$(stat -c %s "$csv")" "$wall" <<'PY'
import sys
n, rss_kb, csv_bytes, wall = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
m, s = wall.split(":")[-2:]
rss = rss_kb * 1024
print(f"{n:<10d} {csv_bytes/1e6:<12.0f} {rss/1e6:<14.0f} {rss/n:<12.0f} {rss/(32*n):<14.2f} {60*float(m)+float(s):<10.1f}")
PY
done
echo "load after: $(uptime)"
