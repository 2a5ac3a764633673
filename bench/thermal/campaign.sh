#!/usr/bin/env bash
# Issue 46's thermal campaign end to end, as a user runs it (bench/thermal/campaign.py, a numpy
# generator written from first principles): per seed, a ±2 g consumer part whose bias and gain
# change with die temperature, its temperature sensor lagging the die by 25 s in 0.25 °C steps;
# cold poses, two cold runs, a 30 min warm-up in one pose, hot poses, two hot runs, one CSV each
# on one clock, a campaign file without truth keys; `spincal calibrate --campaign`; the held-out
# slower warm-up (24 random poses) streamed through `spincal correct`; scored against the oracle
# and the flight stacks' method at die temperatures between the recorded poses'.
#
#   bash bench/thermal/campaign.sh OUT_DIR [SEEDS] [FIRST_SEED]      (default 5 seeds from 1)
# Env: PYTHON, SPINCAL (bench/lib.sh).
set -euo pipefail
out=${1:?OUT_DIR}
seeds=${2:-5}
first=${3:-1}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../lib.sh"
mkdir -p "$out"
for seed in $(seq "$first" $((first + seeds - 1))); do
    unit=$out/unit-$seed
    rm -rf "$unit"
    "$python" "$here/campaign.py" generate "$unit" "$seed"
    start=$(date +%s.%N)
    "$spincal" calibrate --campaign "$unit/campaign.toml" --out "$unit/cal" --quiet > "$unit/calibrate.log" 2>&1 || true
    seconds=$(echo "$(date +%s.%N) - $start" | bc)
    mkdir -p "$unit/corrected"
    if [ -f "$unit/cal/model.json" ]; then
        "$spincal" correct --quiet --model "$unit/cal/model.json" "$unit/held_out/warmup2.csv" -o "$unit/corrected/warmup2.csv" > /dev/null 2>&1
        # The diagnostic: the joint fit's physical model (with q) in place of the saved sensor.
        "$python" - "$unit/cal" <<'PY'
import json, sys
d = sys.argv[1]
model = json.load(open(d + "/model.json"))
joint = json.load(open(d + "/results.json"))["joint"]["sensor"]
if model["corrector"].get("kind") == "physical":
    model["corrector"]["sensor"] = joint
    model["corrector"].pop("uncertainty", None)
    json.dump(model, open(d + "/model-joint.json", "w"))
PY
        if [ -f "$unit/cal/model-joint.json" ]; then
            "$spincal" correct --quiet --model "$unit/cal/model-joint.json" "$unit/held_out/warmup2.csv" -o "$unit/corrected/warmup2-joint.csv" > /dev/null 2>&1 || true
        fi
    fi
    "$python" "$here/campaign.py" evaluate "$unit" > "$unit/score.json"
    "$python" - "$unit" "$seconds" <<'PY'
import json, sys
unit, seconds = sys.argv[1], float(sys.argv[2])
s = json.load(open(unit + "/score.json"))
truth = json.load(open(unit + "/truth.json"))
r = s["rms_mps2"]
try:
    res = json.load(open(unit + "/cal/results.json"))
except FileNotFoundError:
    res = {}
th = res.get("thermal") or {}
fit = th.get("fit") or {}
model = fit.get("model") or {}
terms = fit.get("terms") or {}
saved = res.get("saved")
try:
    has_thermal = json.load(open(unit + "/cal/model.json")).get("thermal") is not None
except FileNotFoundError:
    has_thermal = False
print("seed %d: saved %s, thermal part saved %s, lag %s s (true %g), bias orders %s, gain orders %s, range %s °C, scored %d samples at %.1f–%.1f °C, calibrate %.0f s" % (
    s["seed"], saved, has_thermal, model.get("lag_s"), truth["sensor_lag_s"], terms.get("bias_orders"), terms.get("scale_orders"),
    "–".join("%.1f" % v for v in model["fitted_range_c"]) if model else None, s["band_samples"], s["band_c"][0], s["band_c"][1], seconds))
for metric, label in (("sample", "per sample"), ("second", "1 s means")):
    o = r["oracle"][metric]
    for k, axis in enumerate("xyz"):
        sp, fl = r["spincal"][metric][k], r["flight"][metric][k]
        line = "  %-10s %s: oracle %.5f  spincal/oracle %.3f  flight/oracle %.3f  six-face/oracle %.3f  excess ratio %.3f (quadrature %.3f)" % (
            label, axis, o[k], sp / o[k], fl / o[k], r["six-face"][metric][k] / o[k], (sp - o[k]) / (fl - o[k]),
            max(sp * sp - o[k] ** 2, 0) ** 0.5 / max(fl * fl - o[k] ** 2, 1e-30) ** 0.5)
        if "spincal-joint" in r:
            line += "  joint-by-hand/oracle %.3f" % (r["spincal-joint"][metric][k] / o[k])
        print(line)
    # Pooled over the axes (RMS of the three), the issue's "mean" figure.
    pool = lambda v: (sum(x * x for x in v) / 3) ** 0.5
    po, ps, pf = pool(o), pool(r["spincal"][metric]), pool(r["flight"][metric])
    print("  %-10s pooled: spincal/oracle %.3f  flight/oracle %.3f  excess ratio %.3f (quadrature %.3f)" % (
        label, ps / po, pf / po, (ps - po) / (pf - po), max(ps * ps - po * po, 0) ** 0.5 / (pf * pf - po * po) ** 0.5))
if "error_bars" in s:
    e = s["error_bars"]
    print("  error bars: systematic error / predicted sd over %d held-out pose-axes in the band: RMS %.2f, largest %.2f" % (
        e["poses_axes"], e["rms_z"], e["max_abs_z"]))
if "thermal_part_rms_mps2" in s:
    o = r["oracle"]["sample"]
    print("  thermal part alone (saved β, ρ against the truth's at the true die temperature): RMS %s m/s², as a ratio to the oracle per sample %s" % (
        "/".join("%.4f" % v for v in s["thermal_part_rms_mps2"]),
        "/".join("%.3f" % ((o[k] ** 2 + s["thermal_part_rms_mps2"][k] ** 2) ** 0.5 / o[k]) for k in range(3))))
PY
done
# Over the seeds: the issue's two goals, per sample, worst axis and pooled.
"$python" - "$out" "$first" "$seeds" <<'PY'
import json, sys
out, first, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
near, half, rows = 0, 0, []
for seed in range(first, first + n):
    r = json.load(open("%s/unit-%d/score.json" % (out, seed)))["rms_mps2"]
    o, sp, fl = r["oracle"]["sample"], r["spincal"]["sample"], r["flight"]["sample"]
    worst = max(sp[k] / o[k] for k in range(3))
    pool = lambda v: (sum(x * x for x in v) / 3) ** 0.5
    ratio = (pool(sp) - pool(o)) / (pool(fl) - pool(o))
    near += worst <= 1.25
    half += ratio <= 0.5
    rows.append((worst, pool(sp) / pool(o), pool(fl) / pool(o), ratio))
z2 = [json.load(open("%s/unit-%d/score.json" % (out, seed))).get("error_bars") for seed in range(first, first + n)]
z2 = [e for e in z2 if e and e["poses_axes"]]
if z2:
    print("== error bars: systematic error / predicted sd, RMS %.2f over %d held-out pose-axes of %d units (issue 46: 0.7–1.4)" % (
        (sum(e["rms_z"] ** 2 * e["poses_axes"] for e in z2) / sum(e["poses_axes"] for e in z2)) ** 0.5,
        sum(e["poses_axes"] for e in z2), len(z2)))
print("== over %d seeds (per sample): worst axis within 1.25x the oracle on %d; pooled excess at most half the flight stacks' on %d" % (n, near, half))
print("   spincal/oracle worst axis %.3f–%.3f, pooled mean %.3f; flight/oracle pooled mean %.3f; excess ratio pooled %.3f–%.3f" % (
    min(r[0] for r in rows), max(r[0] for r in rows), sum(r[1] for r in rows) / n, sum(r[2] for r in rows) / n,
    min(r[3] for r in rows), max(r[3] for r in rows)))
PY
echo "== load after: $(uptime)"
