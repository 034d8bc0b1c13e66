#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The threaded parts' tests under ThreadSanitizer (build/tsan, cmake --preset
# tsan): the tile renderer's and the camera sensor model's parallel loops
# (on std::threads in this build: sim/src/parallel_for.h), the sim: camera's
# stream thread, the Aravis backend's stream against Aravis's fake GigE Vision
# camera, and the USB backend's asynchronous transfers against the emulated
# display's handler thread (under umockdev). A race, a lock-order inversion
# or a thread leak reported fails the run; tests/tsan.supp names what
# uninstrumented libraries hide, each with its reason.
set -euo pipefail
cd "$(dirname "$0")/.."
export TSAN_OPTIONS="${TSAN_OPTIONS:+$TSAN_OPTIONS:}halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/tests/tsan.supp"
export LFI_NO_SKIPS=${LFI_NO_SKIPS:-1}
tests=build/tsan/tests
run() {  # run NAME COMMAND...: one line of the summary
  local name=$1 start=$SECONDS
  shift
  if "$@" >"build/tsan/$name.log" 2>&1; then
    echo "tsan: $name clean ($((SECONDS - start)) s)"
  else
    echo "tsan: $name FAILED ($((SECONDS - start)) s): build/tsan/$name.log" >&2
    grep -m3 -E "WARNING: ThreadSanitizer|FAILED" "build/tsan/$name.log" >&2 || true
    return 1
  fi
}
status=0
run tile_renderer "$tests/test_sim" --gtest_filter='Render.*:CameraSensorModel.*' || status=1
run sim_camera "$tests/test_sim_camera" || status=1
run aravis "$tests/test_drivers" || status=1
run usb_display tests/drivers/run_with_umockdev.sh "$tests/test_display" || status=1
exit $status
