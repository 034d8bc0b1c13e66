#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# install_test.sh <build-dir> <source-dir>: installs the build into a
# temporary folder (DESTDIR, prefix /opt/lfi), then builds a program outside
# the tree against the installed package twice, through find_package(lfi) and
# through pkg-config, and runs both: each opens a sim: camera and grabs a frame.
# Also checks that the udev rules land in LFI_UDEV_RULES_DIR, outside the prefix,
# and that the package and the .pc file carry the licence.
set -euo pipefail
build=$(realpath "$1") source=$(realpath "$2")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "install_test: $*" >&2; exit 1; }

DESTDIR="$tmp/root" cmake --install "$build" --prefix /opt/lfi >"$tmp/install.log" ||
  { cat "$tmp/install.log"; fail "cmake --install failed"; }
prefix="$tmp/root/opt/lfi"
udev_dir=$(sed -n 's/^LFI_UDEV_RULES_DIR:PATH=//p' "$build/CMakeCache.txt")
[[ -f "$tmp/root$udev_dir/70-lfi.rules" ]] || fail "udev rules not in $udev_dir"
for f in bin/lfi include/lfi/drivers/camera.h include/lfi/sim/devices/sim_camera.h; do
  [[ -e "$prefix/$f" ]] || fail "$f not installed"
done
libdir=$(dirname "$(find "$prefix" -name liblfi_core.a)")
[[ -n "$libdir" ]] || fail "liblfi_core.a not installed"
scene="$source/data/scenes/inspection_bench.toml"
# The licence: its text beside the documentation, its name in the .pc file
cmp -s "$prefix/share/doc/lfi/LICENSE" "$source/LICENSE" || fail "LICENSE not installed in share/doc/lfi"
grep -qx 'License: Apache-2.0' "$libdir/pkgconfig/lfi.pc" || fail "lfi.pc does not name the licence"

# CMake package
cmake -S "$source/tests/install/consumer" -B "$tmp/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >"$tmp/configure.log" || { cat "$tmp/configure.log"; fail "find_package(lfi) failed"; }
cmake --build "$tmp/consumer" >"$tmp/build.log" || { cat "$tmp/build.log"; fail "building against lfi::sim failed"; }
"$tmp/consumer/grab_frame" "$scene" || fail "the program built with find_package(lfi) failed"

# pkg-config
flags=$(PKG_CONFIG_PATH="$libdir/pkgconfig" pkg-config --cflags --libs lfi) || fail "pkg-config lfi failed"
include_dir=$(PKG_CONFIG_PATH="$libdir/pkgconfig" pkg-config --variable=includedir lfi)
[[ "$(realpath "$include_dir")" == "$prefix/include" ]] || fail "pkg-config's includedir $include_dir is not $prefix/include"
# shellcheck disable=SC2086  # the flags are words
g++ -std=c++23 -O1 "$source/tests/install/consumer/grab_frame.cpp" -o "$tmp/grab_frame_pc" $flags \
  >"$tmp/pc-build.log" 2>&1 || { cat "$tmp/pc-build.log"; fail "building with pkg-config's flags failed"; }
"$tmp/grab_frame_pc" "$scene" || fail "the program built with pkg-config failed"
echo "install_test: passed (prefix $prefix, udev rules in $udev_dir)"
