#!/usr/bin/env bash
# Peak memory of `spincal inspect` on simulated 100 Hz CSV recordings of about 100 MB and 1 GB, and
# of refusing a MAT-file zlib bomb (a 30 M × 4 double array of zeros: 960 MB inflated, 0.93 MB
# compressed). Peak resident set size from /usr/bin/time -v; the page cache of the file read is
# not in it (the file is read, not mapped, when streamed).
#
#   bash bench/memory/inspect.sh [OUT_DIR] [SECONDS...]   (defaults: /tmp/spincal-memory 16000 160000)
#
# 16 000 s at 100 Hz is a 101 MB CSV, 160 000 s a 1.0 GB one. The CSVs are deleted at the end;
# nothing tracked is written.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-/tmp/spincal-memory}
shift || true
durations=("$@")
[ ${#durations[@]} -eq 0 ] && durations=(16000 160000)
mkdir -p "$out"
cd "$root"
cargo build --release -p spincal-cli --quiet
spincal=${CARGO_TARGET_DIR:-$root/target}/release/spincal
[ -x /usr/bin/time ] || { echo "needs /usr/bin/time (Debian: apt-get install time)"; exit 1; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(free -g | awk '/Mem:/{print $2}') GiB"
echo "load before: $(uptime)"
peak() { awk -F': ' '/Maximum resident/{printf "%.1f", $2/1024}' "$1"; }
wall() { awk -F': ' '/Elapsed \(wall/{print $2}' "$1"; }
printf '%-28s %-10s %-12s %-10s %s\n' case file_MB peak_RSS_MB wall exit
for d in "${durations[@]}"; do
    csv="$out/rec-$d.csv"
    "$spincal" simulate -o "$csv" --duration "$d" --seed 3 >/dev/null
    mb=$(python3 -c "import os;print(round(os.path.getsize('$csv')/1e6))")
    set +e
    /usr/bin/time -v "$spincal" inspect "$csv" >"$out/inspect-$d.txt" 2>"$out/time-$d.txt"
    code=$?
    set -e
    printf '%-28s %-10s %-12s %-10s %s\n' "inspect $d s at 100 Hz" "$mb" "$(peak "$out/time-$d.txt")" "$(wall "$out/time-$d.txt")" "$code"
    grep -m1 '^samples' "$out/inspect-$d.txt"
    rm -f "$csv"
done
python3 - "$out/bomb.mat" <<'PY'
import struct, sys, zlib
rows, cols = 30_000_000, 4
values = rows * cols * 8
def element(kind, data):
    e = struct.pack("<II", kind, len(data)) + data
    return e + b"\0" * (-len(e) % 8)
m = element(6, struct.pack("<II", 6, 0)) + element(5, struct.pack("<ii", rows, cols)) + element(1, b"z")
head = struct.pack("<II", 14, len(m) + 8 + values) + m + struct.pack("<II", 9, values)
z = zlib.compressobj(9)
parts = [z.compress(head)]
block = bytes(1 << 20)
for _ in range(values // len(block)):
    parts.append(z.compress(block))
parts.append(z.compress(bytes(values % len(block))))
parts.append(z.flush())
data = b"".join(parts)
text = b"MATLAB 5.0 MAT-file, Platform: GLNXA64, Created on: bench".ljust(116, b" ")
with open(sys.argv[1], "wb") as f:
    f.write(text + bytes(8) + struct.pack("<H", 0x0100) + b"IM" + struct.pack("<II", 15, len(data)) + data)
PY
mb=$(python3 -c "import os;print(round(os.path.getsize('$out/bomb.mat')/1e6, 2))")
set +e
/usr/bin/time -v "$spincal" inspect "$out/bomb.mat" >/dev/null 2>"$out/time-bomb.txt"
code=$?
set -e
printf '%-28s %-10s %-12s %-10s %s\n' "MAT bomb 30M×4 zeros" "$mb" "$(peak "$out/time-bomb.txt")" "$(wall "$out/time-bomb.txt")" "$code"
grep -m1 'spincal\|error\|Error' "$out/time-bomb.txt" || true
echo "load after: $(uptime)"
