#!/usr/bin/env bash
# The firmware export's cost: flash and RAM bytes per corrector kind on a Cortex-M4F
# (arm-none-eabi-size of the float export, and the stack GCC reports), and host nanoseconds per
# sample of the float and double C exports and the no_std Rust exports. No peer.
#
#   bash bench/embedded/run.sh [OUT_DIR] [CPU] [REPS]
#
# The exports are the ones tests/firmware.rs makes (every kind trained on a simulated recording,
# all with a gyro calibration; physical_ann's network is 3-6-3, ann's 6-5-2 with two delays),
# kept in OUT_DIR by SPINCAL_FIRMWARE_KEEP. Writes only OUT_DIR (default bench/out/embedded).
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=$(realpath -m "${1:-bench/out/embedded}")
CPU=${2:-1}
REPS=${3:-5}
mkdir -p "$OUT"
echo "load before: $(uptime)"
SPINCAL_FIRMWARE_KEEP="$OUT" cargo test --release -q -p spincal-cli --test firmware every_kind -- --nocapture \
    | grep -E "^(kind|physical|linear|static|ann)" || true
EXPORTS="$OUT/host/exports"
LIB="$OUT/host/no-std-check/target/release/libno_std_check.a"
M4=(-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -std=c99 -ffp-contract=off -ffunction-sections -fdata-sections)
echo
echo "Cortex-M4F, float export, arm-none-eabi-gcc $(arm-none-eabi-gcc -dumpversion): bytes"
printf "%-16s %-4s %8s %8s %8s %10s %s\n" kind opt code coeffs state stack "calls"
for kind in physical physical_linear linear static ann physical_ann; do
    for opt in -Os -O2; do
        obj="$OUT/$kind$opt.o"
        arm-none-eabi-gcc "${M4[@]}" "$opt" -fstack-usage -c "$EXPORTS/$kind/${kind}_f32.c" -o "$obj"
        code=$(arm-none-eabi-size -A "$obj" | awk '$1 ~ /^\.text/ {s += $2} END {print s + 0}')
        coeffs=$(arm-none-eabi-size -A "$obj" | awk '$1 ~ /^\.rodata/ {s += $2} END {print s + 0}')
        history=$(awk '/_HISTORY / {print $3}' "$EXPORTS/$kind/${kind}_f32.h")
        state=$((4 * history + 4))
        # Every function's frame summed: a bound on the deepest call chain.
        stack=$(awk '{s += $2} END {print s + 0}' "${obj%.o}.su")
        calls=$(arm-none-eabi-nm -u "$obj" | awk '{print $2}' | tr '\n' ' ')
        printf "%-16s %-4s %8s %8s %8s %10s %s\n" "$kind" "$opt" "$code" "$coeffs" "$state" "<= $stack" "${calls:-none}"
    done
done
echo
echo "host ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), cc $(cc -dumpversion), CPU $CPU, best and median of $REPS): ns per sample"
for kind in physical physical_linear linear static ann physical_ann; do
    bin="$OUT/bench-$kind"
    cc -O2 -std=c99 -ffp-contract=off -D_POSIX_C_SOURCE=199309L -DKIND="$kind" -I"$EXPORTS/$kind" \
        bench/embedded/bench.c "$EXPORTS/$kind/${kind}_f32.c" "$EXPORTS/$kind/${kind}_f64.c" "$LIB" -lm -o "$bin"
    echo "$kind:"
    taskset -c "$CPU" "$bin" "$REPS" < "$OUT/host/held_out.txt" | sed 's/^/  /'
done
echo "load after: $(uptime)"
