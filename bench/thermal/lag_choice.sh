#!/usr/bin/env bash
# How well the recordings determine the temperature sensor's lag: the units of
# `thermal_corrector_near_the_oracle_on_held_out_temperatures` (`spincal simulate --thermal`,
# seeds 1000…, a 20 s lag) calibrated as a campaign, with the temperature reported in steps of
# each RESOLUTION (°C; 0: unquantised); per unit, the lag chosen and the profile of the windows'
# χ² over the lag grid, Δχ²(τ) = n ln(RMS(τ)² / RMS(best)²), n the residuals.
#
#   bash bench/thermal/lag_choice.sh OUT_DIR [UNITS] [RESOLUTION...]   (default 20 units, 1 0.25 0)
set -euo pipefail
out=${1:?OUT_DIR}
units=${2:-20}
shift 2 || shift $#
resolutions=${*:-1 0.25 0}
root=$(cd "$(dirname "$0")/../.." && pwd)
if [ -z "${SPINCAL:-}" ]; then
    cargo build --release -q -p spincal-cli --manifest-path "$root/Cargo.toml"
    SPINCAL=$root/target/release/spincal
fi
python=${PYTHON:-python3}
echo "== commit: $(git -C "$root" rev-parse --short HEAD)$(git -C "$root" diff --quiet HEAD -- crates && echo '' || echo ' + uncommitted changes in crates/')"
echo "== load before: $(uptime)"
mkdir -p "$out"
for res in $resolutions; do
    for i in $(seq 0 $((units - 1))); do
        seed=$((1000 + i))
        d=$out/res-$res/unit-$seed
        rm -rf "$d"
        mkdir -p "$out/res-$res"
        echo "{\"resolution_c\": $res}" > "$out/res-$res/setup.json"
        "$SPINCAL" simulate --thermal "$d" --seed "$seed" --setup "$out/res-$res/setup.json" > /dev/null
        "$SPINCAL" calibrate --campaign "$d/campaign.toml" --out "$d/cal" --quiet > "$d/calibrate.log" 2>&1 || true
        "$python" - "$d" "$res" "$seed" <<'PY'
import json, math, sys
d, res, seed = sys.argv[1:4]
r = json.load(open(d + "/cal/results.json"))
fit = r["thermal"]["fit"]
n = 3 * fit["windows"]
scores = fit["lag_scores"]
best = min(s[1] for s in scores)
profile = " ".join("%g:%.1f" % (lag, n * math.log(rms * rms / (best * best))) for lag, rms in scores)
print("resolution %s °C, seed %s: lag %g s (true %g), Δχ² by lag %s" % (res, seed, fit["model"]["lag_s"],
      json.load(open(d + "/truth.json"))["model"]["lag_s"], profile))
PY
    done
done
echo "== load after: $(uptime)"
