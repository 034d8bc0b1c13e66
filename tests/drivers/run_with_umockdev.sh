#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Runs a test binary with umockdev's preload library (so libusb sees the emulated
# devices of the testbed), a private TMPDIR per run, and ASan told that the preload
# library comes first on purpose.
set -eu
dir=$(mktemp -d "${TMPDIR:-/tmp}/lfi-umockdev.XXXXXX")
trap 'rm -rf "$dir"' EXIT INT TERM
export TMPDIR="$dir"
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}verify_asan_link_order=0"
LD_PRELOAD="libumockdev-preload.so.0${LD_PRELOAD:+:$LD_PRELOAD}" "$@"
