#!/usr/bin/env bash
# Installs what the test suite needs beyond the Rust toolchain. Safe to run repeatedly.
# - chromium (Debian package): the headless browser that renders the HTML report and figures in tests.
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

# The test venv (.venv): Python peers and fixture writers the tests call.
bash "$(dirname "$0")/python_env.sh"
