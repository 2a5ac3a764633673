#!/usr/bin/env bash
# Installs what the test suite needs beyond the Rust toolchain, and builds the tests. Safe to run
# repeatedly.
# - the pinned Rust toolchain (rust-toolchain.toml): scripts/toolchain.sh, without a download when
#   the machine's stable is that release.
# - chromium (Debian package): the headless browser that renders the HTML report and figures in tests.
# - a C++ compiler (g++): libfuzzer-sys's build script compiles libFuzzer's C++ sources even for
#   `cargo check` of the fuzz targets (.ci/run).
# - python3-venv (Debian): Debian's python3 makes no venv without it (no ensurepip).
# - gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm: the firmware export on a Cortex-M4F.
# - the test venv (.venv) and the Python package's wheel: scripts/python_env.sh.
# The Debian packages and the venv's downloads are mostly waiting on the network, so they run in the
# background while cargo builds the workspace's tests (the CPU's work); the wheel, which needs the
# venv's maturin and shares the library's artifacts with that build, comes last.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
bash "$root/scripts/toolchain.sh"
logs=$(mktemp -d "${TMPDIR:-/tmp}/spincal-setup.XXXXXX")

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

packages=()
if [ -x /usr/bin/chromium ]; then
    echo "spincal setup: chromium present ($(/usr/bin/chromium --version 2>/dev/null || echo 'version unknown'))"
else
    packages+=(chromium fonts-dejavu-core)
fi
# The Cortex-M4F toolchain and emulator: the firmware export's float C is built for a Cortex-M4F
# and run under QEMU (crates/spincal-cli/tests/firmware.rs).
if command -v arm-none-eabi-gcc >/dev/null 2>&1 && command -v qemu-system-arm >/dev/null 2>&1 \
    && [ -f /usr/lib/arm-none-eabi/newlib/thumb/v7e-m+fp/hard/librdimon.a ]; then
    echo "spincal setup: arm-none-eabi-gcc and qemu-system-arm present ($(arm-none-eabi-gcc -dumpversion))"
else
    packages+=(gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm)
fi

# The fuzz targets' check: libfuzzer-sys builds with the cc crate, which runs $CXX or c++.
if command -v "${CXX:-c++}" >/dev/null 2>&1; then
    echo "spincal setup: C++ compiler present ($("${CXX:-c++}" --version | head -n 1))"
else
    packages+=(g++)
fi
# The test venv: `python3 -m venv` needs ensurepip, which Debian ships in python3-venv.
venv_needs_apt=0
if command -v python3 >/dev/null 2>&1 && python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then
    echo "spincal setup: python3 with venv present ($(python3 --version))"
else
    packages+=(python3 python3-venv)
    venv_needs_apt=1
fi

pids=()
names=()
if [ ${#packages[@]} -gt 0 ]; then
    echo "spincal setup: installing ${packages[*]} (Debian) in the background"
    (
        as_root env DEBIAN_FRONTEND=noninteractive apt-get update -q
        as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${packages[@]}"
    ) >"$logs/apt.log" 2>&1 &
    pids+=($!)
    names+=(apt)
fi
if [ "$venv_needs_apt" -eq 0 ]; then
    bash "$root/scripts/python_env.sh" venv >"$logs/venv.log" 2>&1 &
    pids+=($!)
    names+=(venv)
fi

echo "spincal setup: building the workspace's tests (release) meanwhile"
build_status=0
(cd "$root" && cargo test --release --workspace --no-run) || build_status=$?

failed=0
for i in "${!pids[@]}"; do
    if wait "${pids[$i]}"; then
        grep '^spincal setup' "$logs/${names[$i]}.log" || true
    else
        echo "spincal setup: ${names[$i]} failed; its log ($logs/${names[$i]}.log):" >&2
        cat "$logs/${names[$i]}.log" >&2
        failed=1
    fi
done
[ "$build_status" -eq 0 ] || { echo "spincal setup: the test build failed" >&2; exit "$build_status"; }
[ "$failed" -eq 0 ] || exit 1
if [ ${#packages[@]} -gt 0 ]; then
    /usr/bin/chromium --version
    arm-none-eabi-gcc --version | head -n 1
    "${CXX:-c++}" --version | head -n 1
fi
# Without python3-venv before apt ran, the venv could not be made in the background.
if [ "$venv_needs_apt" -eq 1 ]; then
    bash "$root/scripts/python_env.sh" venv
fi

bash "$root/scripts/python_env.sh" wheel
rm -rf "$logs"
