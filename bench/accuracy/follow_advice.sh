#!/usr/bin/env bash
# The verdict's next pose, followed: on the units of a bench/accuracy/run.sh output, each unit whose
# saved model's error map advises a still pose (results.json error_map.next_pose) gets that pose
# recorded by the same sensor as a file of its own (independent.py follow), and is calibrated and
# scored again in unit-N-next1; with ROUNDS > 1 the advice of each round is followed again
# (unit-N-next2, …). Per unit and round: the share of the directions of gravity trusted and the
# median predicted error over the noise, now / predicted / after; the held-out pooled ratio to the
# oracle before and after.
#
#   bash bench/accuracy/run.sh OUT UNITS POSES [flags]; bash bench/accuracy/follow_advice.sh OUT [ROUNDS]
# Env: PYTHON, SPINCAL (bench/lib.sh).
set -euo pipefail
out=${1:?OUT_DIR (a bench/accuracy/run.sh output)}
rounds=${2:-1}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../lib.sh"
for unit in $(ls -d "$out"/unit-* | grep -v -- '-next[0-9]*$' | sort -V); do
    seed=${unit##*-}
    current=$unit
    for round in $(seq 1 "$rounds"); do
        next=$unit-next$round
        if ! "$python" "$here/independent.py" follow "$current" "$next" "$seed" "pose-next-$round.csv"; then
            echo "unit $seed round $round: no pose advised"
            break
        fi
        "$spincal" calibrate --campaign "$next/campaign.toml" --out "$next/cal" --quiet > "$next/calibrate.log" 2>&1 || true
        mkdir -p "$next/corrected"
        if [ -f "$next/cal/model.json" ]; then
            for f in "$next"/held_out/*.csv; do
                base=$(basename "$f")
                "$spincal" correct --model "$next/cal/model.json" "$f" -o "$next/corrected/$base" > /dev/null 2>&1
            done
        fi
        "$python" "$here/independent.py" evaluate "$next" > "$next/score.json"
        "$python" - "$current" "$next" "$seed" "$round" <<'PY'
import json, sys
unit, nxt, seed, round_ = sys.argv[1:]
before = json.load(open(unit + "/cal/results.json"))
after = json.load(open(nxt + "/cal/results.json"))
m0, m1 = before["error_map"], after.get("error_map") or {}
advice = m0["next_pose"]
s0, s1 = json.load(open(unit + "/score.json")), json.load(open(nxt + "/score.json"))
pooled = lambda s: "/".join("%.2f" % v for v in s["pooled_ratio"])
print("unit %s round %s: saved %s → %s; trusted share %.2f → predicted %.2f, after %s; median sd/noise %.2f → predicted %.2f, after %s; held-out pooled x/y/z %s → %s, worst %.2f → %.2f" % (
    seed, round_, before["saved"], after["saved"], m0["share_determined"], advice["share_determined_after"],
    "%.2f" % m1["share_determined"] if m1 else "-", advice["median_sd_over_noise"][0], advice["median_sd_over_noise"][1],
    "%.2f" % m1["median_sd_over_noise"] if m1.get("median_sd_over_noise") else "-",
    pooled(s0), pooled(s1), s0["worst_ratio"], s1["worst_ratio"]))
PY
        [ -f "$next/cal/model.json" ] || break
        current=$next
    done
done
echo "== load after: $(uptime)"
