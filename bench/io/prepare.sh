# Sourced by run.sh and spread.sh (from the repository root): the peers' venv, the read_bench
# binary, and OUT with ROWS rows of bench.csv (made again unless KEEP_CSV=1 and it exists).
OUT=bench/out/io
VENV=bench/.venv-io
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install -q numpy pandas
fi
cargo build --release -q -p spincal --example read_bench
BIN=${CARGO_TARGET_DIR:-target}/release/examples/read_bench
mkdir -p "$OUT"
if [ "${KEEP_CSV:-0}" != 1 ] || [ ! -f "$OUT/bench.csv" ]; then
    "$BIN" gen "$OUT" "$ROWS"
fi
