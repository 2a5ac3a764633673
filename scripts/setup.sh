#!/usr/bin/env bash
# Installs what the test suite needs beyond the Rust toolchain. Safe to run repeatedly.
# - chromium (Debian package): the headless browser that renders the HTML report and figures in tests.
# - gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm: the firmware export on a Cortex-M4F.
set -euo pipefail

as_root() {
    if [ "$(id -u)" -eq 0 ]; then
        "$@"
    elif command -v sudo >/dev/null 2>&1; then
        sudo -n "$@"
    else
        echo "spincal setup: need root (or sudo) to run: $*" >&2
        return 1
    fi
}

if [ -x /usr/bin/chromium ]; then
    echo "spincal setup: chromium present ($(/usr/bin/chromium --version 2>/dev/null || echo 'version unknown'))"
else
    echo "spincal setup: installing chromium (headless browser tests)"
    export DEBIAN_FRONTEND=noninteractive
    as_root env DEBIAN_FRONTEND=noninteractive apt-get update -q
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends chromium fonts-dejavu-core
    /usr/bin/chromium --version
fi

# The Cortex-M4F toolchain and emulator (Debian packages): the firmware export's float C is
# built for a Cortex-M4F and run under QEMU (crates/spincal-cli/tests/firmware.rs).
if command -v arm-none-eabi-gcc >/dev/null 2>&1 && command -v qemu-system-arm >/dev/null 2>&1 \
    && [ -f /usr/lib/arm-none-eabi/newlib/thumb/v7e-m+fp/hard/librdimon.a ]; then
    echo "spincal setup: arm-none-eabi-gcc and qemu-system-arm present ($(arm-none-eabi-gcc -dumpversion))"
else
    echo "spincal setup: installing gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm (Cortex-M4F test)"
    as_root env DEBIAN_FRONTEND=noninteractive apt-get update -q
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
        gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm
    arm-none-eabi-gcc --version | head -n 1
fi

# The test venv (.venv): Python peers and fixture writers the tests call.
bash "$(dirname "$0")/python_env.sh"
