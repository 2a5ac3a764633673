# Sourced by the bench scripts that run the CLI on generated campaigns: finds the checkout, a
# Python with numpy and scipy, and the spincal binary, and prints what a result must name (machine,
# commit, load). Sets `root`, `python` and `spincal`.
# Env: PYTHON (default bench/.venv, else .venv, else ../main/.venv), SPINCAL (a built binary;
#      default: built here into target/release).
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
python=${PYTHON:-}
if [ -z "$python" ]; then
    for p in "$root/bench/.venv/bin/python" "$root/.venv/bin/python" "$root/../main/.venv/bin/python"; do
        if [ -x "$p" ] && "$p" -c "import numpy, scipy" 2>/dev/null; then python=$p; break; fi
    done
fi
[ -n "$python" ] || { echo "no python with numpy and scipy: run bench/setup_venv.sh or set PYTHON" >&2; exit 1; }
spincal=${SPINCAL:-}
if [ -z "$spincal" ]; then
    cargo build --release -q -p spincal-cli --manifest-path "$root/Cargo.toml"
    spincal=$root/target/release/spincal
fi
echo "== machine: $(lscpu | sed -n 's/^Model name: *//p' | head -1), $(getconf _NPROCESSORS_ONLN) CPUs"
echo "== commit: $(git -C "$root" rev-parse --short HEAD)$(git -C "$root" diff --quiet HEAD -- crates && echo '' || echo ' + uncommitted changes in crates/')"
echo "== load before: $(uptime)"
