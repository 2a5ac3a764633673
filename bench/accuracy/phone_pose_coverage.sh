#!/usr/bin/env bash
# The joint fit's standard errors on a phone's still poses alone (bench/accuracy/phone.py's design:
# faces first, then 45° tilts; its runs left out of the campaign file), against the generator's
# truth over many seeds: per sensor parameter, the RMS and mean of (fitted − true)/se. Separates
# the poses' covariance from the runs' in the phone bench's error bars.
#
#   bash bench/accuracy/phone_pose_coverage.sh OUT_DIR [SEEDS] [POSES]      (default 20 seeds, 12 poses)
set -euo pipefail
out=${1:?OUT_DIR}
seeds=${2:-20}
poses=${3:-12}
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../lib.sh"
mkdir -p "$out"
for seed in $(seq 1 "$seeds"); do
    unit=$out/unit-$seed
    rm -rf "$unit"
    "$python" "$here/independent.py" generate "$unit" "$seed" "$poses" --phone > /dev/null
    "$python" - "$unit" <<'PY'
import sys
unit = sys.argv[1]
blocks = open(unit + "/campaign.toml").read().split("[[recording]]")
with open(unit + "/poses.toml", "w") as fh:
    fh.write(blocks[0] + "".join("[[recording]]" + b for b in blocks[1:] if 'kind = "static"' in b))
PY
    "$spincal" calibrate --campaign "$unit/poses.toml" --out "$unit/cal" --quiet > "$unit/calibrate.log" 2>&1 || true
done
"$python" - "$out" "$seeds" <<'PY'
import json, sys
import numpy as np
out, seeds = sys.argv[1], int(sys.argv[2])
rows, names = [], None
for seed in range(1, seeds + 1):
    unit = "%s/unit-%d" % (out, seed)
    res = json.load(open(unit + "/cal/results.json"))
    t = json.load(open(unit + "/truth.json"))["sensor"]
    k = np.array(t["k"])
    # k = diag(1 + s)(I + lower-triangular misalignment): spincal's parameters in its order.
    truth = list(t["bias"]) + [k[i][i] - 1 for i in range(3)] + [k[1][0] / k[1][1], k[2][0] / k[2][2], k[2][1] / k[2][2]] + list(t["q"])
    params = res["joint"]["sensor_params"]
    names = [p["name"] for p in params]
    z = [(p["value"] - v) / p["std_error"] for p, v in zip(params, truth)]
    rows.append(z)
    print("seed %2d: largest |error/se| %.1f (%s)" % (seed, max(abs(v) for v in z), names[int(np.argmax(np.abs(z)))]))
z = np.array(rows)
for i, name in enumerate(names):
    print("%-26s error/se RMS %.2f, mean %+.2f" % (name, np.sqrt(np.mean(z[:, i] ** 2)), z[:, i].mean()))
print("all: error/se RMS %.2f over %d parameter-seeds" % (np.sqrt(np.mean(z ** 2)), z.size))
PY
