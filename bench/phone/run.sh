#!/usr/bin/env bash
# A phone's chip radius and its gyroscope's scale about the spindle, from simulated phone sessions
# written as phyphox and as Sensor Logger zips, no radius stated (issue 48, "What it must show").
# Each seed is `spincal simulate --phone` (simulate::phone's default setup), calibrated from the
# zips as `spincal calibrate --campaign` does (examples/phone_sessions.rs); then the same seeds
# with the second placement turned 90° instead of 180° (phyphox only).
#
# Usage: bash bench/phone/run.sh [FIRST-LAST]   (default 1-5)
# Prints one Markdown table row per seed and app, then whether the goals hold on every one:
# the radius within 2 mm and within 3 standard errors, the scale within 0.1 %.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
seeds=${1:-1-5}
cd "$root"
cargo build --release -p spincal --example phone_sessions
bin="${CARGO_TARGET_DIR:-$root/target}/release/examples/phone_sessions"
echo "== placements turned 180°, phyphox and Sensor Logger =="
"$bin" "$seeds"
echo
echo "== placements turned 90°, phyphox =="
"$bin" "$seeds" --turn 90 --app phyphox
