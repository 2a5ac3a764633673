#!/usr/bin/env bash
# Installs what the test suite needs beyond the Rust toolchain. Safe to run repeatedly.
set -euo pipefail
echo "spincal setup: nothing beyond the Rust toolchain is needed yet"
