#!/usr/bin/env bash
# Peak memory of correcting a file to a file: `spincal correct` and Python's
# `Corrector.correct_file` (the same library pipeline), on simulated 100 Hz CSVs of two sizes, with
# the demo campaign's physical model; checks that both outputs are the same bytes. Peak resident
# set size from /usr/bin/time -v; Python's includes the interpreter and numpy (printed alone).
#
#   bash bench/memory/correct_file.sh [OUT_DIR] [SECONDS...]   (defaults: /tmp/spincal-correct 1000 10000)
#
# Needs the test venv (.venv, from scripts/setup.sh). Nothing tracked is written.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-/tmp/spincal-correct}
shift || true
durations=("$@")
[ ${#durations[@]} -eq 0 ] && durations=(1000 10000)
mkdir -p "$out"
cd "$root"
cargo build --release -p spincal-cli --quiet
spincal=${CARGO_TARGET_DIR:-$root/target}/release/spincal
python=$root/.venv/bin/python
[ -x "$python" ] || { echo "needs the test venv: bash scripts/setup.sh"; exit 1; }
[ -x /usr/bin/time ] || { echo "needs /usr/bin/time (Debian: apt-get install time)"; exit 1; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "load before: $(uptime)"
"$spincal" demo --out "$out/demo" >/dev/null 2>&1
model=$out/demo/campaign-calibration/model.json
peak() { awk -F': ' '/Maximum resident/{printf "%.1f", $2/1024}' "$1"; }
wall() { awk -F': ' '/Elapsed \(wall/{print $2}' "$1"; }
/usr/bin/time -v "$python" -c "import spincal" 2>"$out/import.time"
echo "python + import spincal alone: $(peak "$out/import.time") MB"
printf '%-10s %-8s %-8s %-14s %-10s %-14s %-10s %s\n' seconds rows file_MB cli_peak_MB cli_wall py_peak_MB py_wall same_bytes
for d in "${durations[@]}"; do
    csv="$out/rec-$d.csv"
    "$spincal" simulate -o "$csv" --duration "$d" --seed 3 --quiet >/dev/null
    mb=$(python3 -c "import os;print(round(os.path.getsize('$csv')/1e6))")
    /usr/bin/time -v "$spincal" correct --model "$model" "$csv" -o "$out/cli-$d.csv" 2>"$out/cli.time"
    /usr/bin/time -v "$python" -c "import spincal; spincal.load_corrector('$model').correct_file('$csv', '$out/py-$d.csv', force=True)" 2>"$out/py.time"
    same=$(cmp -s "$out/cli-$d.csv" "$out/py-$d.csv" && echo yes || echo NO)
    printf '%-10s %-8s %-8s %-14s %-10s %-14s %-10s %s\n' "$d" "$((d * 100))" "$mb" "$(peak "$out/cli.time")" "$(wall "$out/cli.time")" "$(peak "$out/py.time")" "$(wall "$out/py.time")" "$same"
    rm -f "$csv" "$out/cli-$d.csv" "$out/py-$d.csv" "${csv%.csv}.truth.json"
done
echo "load after: $(uptime)"
