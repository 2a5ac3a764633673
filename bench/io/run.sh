#!/usr/bin/env bash
# Reading speed: spincal's CSV reader and 3DM-GX1 decoder against numpy.loadtxt and pandas.read_csv
# on the same generated file, in one run. Usage: bench/io/run.sh [ROWS] [REPEATS]
set -euo pipefail
cd "$(dirname "$0")/../.."
ROWS=${1:-1000000}
REPEATS=${2:-3}
OUT=bench/out/io
VENV=bench/.venv-io
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install -q numpy pandas
fi
cargo build --release -q -p spincal --example read_bench
BIN=target/release/examples/read_bench
mkdir -p "$OUT"
$BIN gen "$OUT" "$ROWS"
{
    $BIN read "$OUT" "$REPEATS"
    "$VENV/bin/python" bench/io/peers.py "$OUT" "$REPEATS"
} > "$OUT/times.txt"
echo "rows: $ROWS, best of $REPEATS; numpy $("$VENV/bin/python" -c 'import numpy; print(numpy.__version__)'), pandas $("$VENV/bin/python" -c 'import pandas; print(pandas.__version__)')"
awk '
    { name[NR] = $1; s[NR] = $2; mb[NR] = $3; n[NR] = $4; if ($1 == "spincal-csv") ref = $2 }
    END {
        printf "%-16s %10s %9s %14s %22s\n", "reader", "seconds", "MB/s", "samples/s", "time / spincal-csv"
        for (i = 1; i <= NR; i++)
            printf "%-16s %10.4f %9.1f %14.0f %22.2f\n", name[i], s[i], mb[i] / s[i], n[i] / s[i], s[i] / ref
    }' "$OUT/times.txt"
