#!/usr/bin/env bash
# The standard protocol on the benchmark files as shipped (../shared/data/sysid, no preprocessing):
# every model `spincal sysid` offers, at its default orders and at the extra orders given in
# EXTRA below, fitted on the estimation part and simulated on the test part from the first n
# measured outputs (README.md of the data: n = 50 Silverbox and WH2009, 5 tanks). Prints one row
# per fit: test simulation RMSE, fit %, training RMSE, iterations, fit time. Accuracy, not speed:
# the times are those of one run at whatever load `uptime` shows. The WH2009 NARX rows are issue
# 31 item 8's (NARX and HW below ARX [6 8 1]'s 58 mV); with --focus simulation the iteration count
# is that of the one-step fit plus the simulation-error refinement.
#
#   bash bench/sysid/shipped.sh [OUT_DIR]     (default /tmp/spincal-sysid-shipped)
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=${1:-/tmp/spincal-sysid-shipped}
DATA=${SPINCAL_SHARED_DATA:-../shared/data}/sysid
mkdir -p "$OUT"
cargo build --release -q -p spincal-cli
S=${CARGO_TARGET_DIR:-target}/release/spincal
uptime
declare -A ARGS=(
  [silverbox]="--data $DATA/Silverbox_SNLS80mV.mat --input V1 --output V2 --train 40650..127400 --test 0..40575 --init-samples 50"
  [wh2009]="--data $DATA/WienerHammerBenchmark.csv --input uBenchMark --output yBenchMark --train 5200..105200 --test 105200..184000 --init-samples 50"
  [tanks]="--data $DATA/CascadedTanks_dataBenchmark.mat --input uEst --output yEst --test-input uVal --test-output yVal --init-samples 5"
)
EXTRA=(
  "tanks arx --orders 2,2,1"
  "tanks oe --orders 2,2,1"
  "tanks narx --orders 2,2,1 --size 5 --max-iterations 300"
  "tanks narx --orders 3,3,1 --max-iterations 300"
  "tanks hw --orders 3,3,1 --max-iterations 300"
  "wh2009 oe --orders 6,6,1"
  "wh2009 hw --orders 4,4,1"
  "wh2009 narx --orders 4,4,1 --max-iterations 30"
  "wh2009 narx --orders 6,8,1 --max-iterations 30"
  "wh2009 narx --orders 6,8,1 --max-iterations 30 --focus simulation"
  "wh2009 narx --orders 10,10,1 --max-iterations 30 --focus simulation"
  "silverbox narx --orders 4,4,1"
)
RUNS=()
for b in silverbox wh2009 tanks; do
  for m in arx oe armax bj narx hw; do RUNS+=("$b $m"); done
done
RUNS+=("${EXTRA[@]}")
printf '%-10s %-68s %12s %9s %12s %6s %8s\n' bench model test_RMSE fit_% train_RMSE iters seconds
k=0
for run in "${RUNS[@]}"; do
  read -r b m rest <<<"$run"
  k=$((k + 1))
  f="$OUT/$k-$b-$m.json"
  # shellcheck disable=SC2086
  if "$S" sysid "$m" ${rest:-} ${ARGS[$b]} --json >"$f" 2>"$f.err"; then
    python3 - "$b" "$f" <<'PY'
import json, sys
b, f = sys.argv[1], sys.argv[2]
d = json.load(open(f))
t, tr = d["test"]["simulation"], d["train"]["simulation"]
print(f"{b:<10} {d['structure']:<68} {t['rmse']:12.4e} {t['fit_percent']:9.2f} {tr['rmse']:12.4e} {d['fitted']['iterations']:6d} {d['seconds']:8.2f}")
PY
  else
    printf '%-10s %-68s failed: %s\n' "$b" "$m ${rest:-}" "$(head -c 200 "$f.err")"
  fi
done
uptime
