#!/usr/bin/env bash
# Makes the toolchain that rust-toolchain.toml names available without a download when the
# machine's `stable` is that same release: rustup knows a fresh machine's toolchain only as
# `stable`, and a toolchain file naming `1.95.0` would otherwise make rustup download 1.95.0 again.
# If neither is there, rustup installs the pinned release (with the file's components).
# Called first by .ci/run and scripts/setup.sh; safe to rerun. Prints what it did.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
# The one place the version is written is rust-toolchain.toml.
pinned=$(sed -n 's/^channel *= *"\([^"]*\)".*/\1/p' "$root/rust-toolchain.toml")
if [ -z "$pinned" ]; then
    echo "spincal toolchain: no channel found in $root/rust-toolchain.toml" >&2
    exit 1
fi
command -v rustup >/dev/null 2>&1 || {
    echo "spincal toolchain: rustup not found; install it (https://rustup.rs), then rerun" >&2
    exit 1
}
# `+stable` overrides the toolchain file, so these ask the stable toolchain, never the pinned one
# (which rustup would download if it is missing).
stable=$(rustc +stable --version 2>/dev/null || true)
host=$(rustc +stable -vV 2>/dev/null | sed -n 's/^host: //p')
host=${host:-$(rustup show 2>/dev/null | sed -n 's/^Default host: //p')}
dir="${RUSTUP_HOME:-$HOME/.rustup}/toolchains/$pinned-$host"

install_pinned() {
    echo "spincal toolchain: $1; rustup installs $pinned (a download)"
    (cd "$root" && rustup toolchain install "$pinned" --profile minimal --component clippy,rustfmt)
    echo "spincal toolchain: installed $pinned ($(rustup run "$pinned" rustc --version))"
}

if [ -e "$dir" ]; then
    have=$(rustup run "$pinned" rustc --version 2>/dev/null || true)
    if [ "$(echo "$have" | awk '{print $2}')" = "$pinned" ]; then
        echo "spincal toolchain: $pinned present ($have)"
        exit 0
    fi
    # A link made here earlier to a `stable` that has since moved to a newer release.
    if [ -L "$dir" ]; then
        rm "$dir"
        install_pinned "the link $dir now gives ${have:-nothing}"
        exit 0
    fi
    echo "spincal toolchain: $dir exists but runs ${have:-nothing}, not $pinned; remove it (rustup toolchain uninstall $pinned) and rerun" >&2
    exit 1
fi
if [ "$(echo "$stable" | awk '{print $2}')" = "$pinned" ]; then
    # `rustup toolchain link` refuses names of official releases ("invalid custom toolchain name
    # '1.95.0'"), so the link is made the way rustup lays out its own toolchains: a folder named
    # <release>-<host> under $RUSTUP_HOME/toolchains. rustup then treats it as that release.
    sysroot=$(rustc +stable --print sysroot)
    ln -s "$sysroot" "$dir"
    echo "spincal toolchain: linked $pinned to the installed stable toolchain ($stable at $sysroot), no download"
else
    install_pinned "$pinned not installed and stable is ${stable:-absent}"
fi
