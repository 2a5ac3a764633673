#!/usr/bin/env bash
# Why the CSV reader's ratio to pandas moves from run to run: spincal and pandas.read_csv timed in
# alternation (ROUNDS rounds, each side best of REPS inside a round, the order swapped every round)
# so that both sides see the same machine, optionally with a load on the other core.
#
# Usage: bash bench/io/spread.sh [ROWS] [ROUNDS] [REPS] [CPU] [LOAD]
#   ROWS 1000000, ROUNDS 8, REPS 3, CPU 1 (both sides pinned there);
#   LOAD none | cpu (a busy loop on the other core) | memory (numpy copying 512 MB arrays there).
# Prints each round's times and ratio, then the least, median and largest ratio.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROWS=${1:-1000000}
ROUNDS=${2:-8}
REPS=${3:-3}
CPU=${4:-1}
LOAD=${5:-none}
KEEP_CSV=1
source bench/io/prepare.sh
other=$(( CPU == 0 ? 1 : 0 ))
loader=""
case "$LOAD" in
    none) ;;
    cpu) taskset -c "$other" sh -c 'while :; do :; done' & loader=$! ;;
    memory) taskset -c "$other" "$VENV/bin/python" -c 'import numpy as np
a = np.ones(64 << 20)
while True:
    b = a.copy()' & loader=$! ;;
    *) echo "LOAD must be none, cpu or memory" >&2; exit 2 ;;
esac
trap '[ -n "$loader" ] && kill "$loader" 2>/dev/null || true' EXIT
sleep 1
echo "load before: $(uptime); other core: $LOAD; pandas $("$VENV/bin/python" -c 'import pandas; print(pandas.__version__)')"
# Each side prints its best wall seconds and its least on-CPU seconds (time not spent running, as
# when another process shares the pinned core, counts in the first only).
spincal() { taskset -c "$CPU" "$BIN" read "$OUT" "$REPS" csv | awk '$1 == "spincal-csv" { print $2, $4 }'; }
pandas() { taskset -c "$CPU" "$VENV/bin/python" bench/io/peers.py "$OUT" "$REPS" pandas | awk '{ print $2, $4 }'; }
walls=() cpus=()
for r in $(seq "$ROUNDS"); do
    if (( r % 2 )); then s=$(spincal); p=$(pandas); else p=$(pandas); s=$(spincal); fi
    read -r sw sc <<< "$s"
    read -r pw pc <<< "$p"
    wall=$(awk -v p="$pw" -v s="$sw" 'BEGIN { printf "%.3f", p / s }')
    cpu=$(awk -v p="$pc" -v s="$sc" 'BEGIN { printf "%.3f", p / s }')
    walls+=("$wall") cpus+=("$cpu")
    echo "round $r: spincal $sw s wall / $sc s CPU, pandas $pw / $pc s, ratio $wall wall, $cpu CPU"
done
spread() {
    sort -n | awk -v what="$1" '{ v[NR] = $1 } END {
        printf "%s ratio (pandas / spincal): least %s, median %s, largest %s over %d rounds\n",
            what, v[1], (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2), v[NR], NR }'
}
printf '%s\n' "${walls[@]}" | spread "wall"
printf '%s\n' "${cpus[@]}" | spread "on-CPU"
echo "load after: $(uptime)"
