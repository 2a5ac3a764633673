#!/usr/bin/env bash
# Reading speed: spincal's CSV reader and 3DM-GX1 decoder against numpy.loadtxt and pandas.read_csv
# on the same generated file, in one run. Usage: bench/io/run.sh [ROWS] [REPEATS] [CPU]
# Every reader runs pinned to one CPU (default 1) under the same rule: best and median of REPEATS,
# file read included; cpu s is the least on-CPU time of a repeat (steadier under load). spincal's CSV
# reader is then timed again on all CPUs (its cpu s counts the main thread only). Writes only bench/out/io.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROWS=${1:-1000000}
REPEATS=${2:-5}
CPU=${3:-1}
source bench/io/prepare.sh
echo "load before: $(uptime)"
{
    taskset -c "$CPU" "$BIN" read "$OUT" "$REPEATS"
    taskset -c "$CPU" "$VENV/bin/python" bench/io/peers.py "$OUT" "$REPEATS"
    "$BIN" read "$OUT" "$REPEATS" csv | sed 's/^spincal-csv /spincal-csv-all-cpus /'
} > "$OUT/times.txt"
echo "load after:  $(uptime)"
echo "rows: $ROWS; best and median of $REPEATS; pinned to CPU $CPU except spincal-csv-all-cpus ($(nproc) CPUs);" \
    "numpy $("$VENV/bin/python" -c 'import numpy; print(numpy.__version__)')," \
    "pandas $("$VENV/bin/python" -c 'import pandas; print(pandas.__version__)')"
awk '
    { name[NR] = $1; best[NR] = $2; med[NR] = $3; cpu[NR] = $4; mb[NR] = $5; n[NR] = $6
      if ($1 == "pandas-read_csv") { pb = $2; pm = $3; pc = $4 } }
    END {
        printf "%-21s %8s %8s %8s %8s %13s  %s\n", "reader", "best s", "median s", "cpu s", "MB/s",
            "samples/s", "x pandas.read_csv (best / median / cpu)"
        for (i = 1; i <= NR; i++)
            printf "%-21s %8.4f %8.4f %8.4f %8.1f %13.0f  %6.2f / %5.2f / %5.2f\n", name[i], best[i],
                med[i], cpu[i], mb[i] / best[i], n[i] / best[i], pb / best[i], pm / med[i], pc / cpu[i]
    }' "$OUT/times.txt"
