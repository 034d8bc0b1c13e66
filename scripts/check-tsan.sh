#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The tests of lfi's threads under ThreadSanitizer (build/tsan: cmake --preset
# tsan, cmake --build --preset tsan), one binary after another, each under a
# time limit: the tile renderer's and the sensor model's parallel loops, the
# sim: camera's stream thread, the Aravis backend against Aravis's fake camera,
# the USB backend against the emulated display, the Aravis backend against
# `lfi serve-camera` (both processes checked), and `lfi sim-bench` with its
# control socket and the commands run under it. docs/reliability.md says which
# threads each run checks and what its test filter leaves out. A race, a
# lock-order inversion or a thread leak reported, by a test or by an `lfi`
# process it runs, fails the run; so does a run that outlives its limit (the
# summary names the test it was in). tests/tsan.supp names what the
# uninstrumented libraries hide, each with its reason.
set -euo pipefail
cd "$(dirname "$0")/.."
export TSAN_OPTIONS="${TSAN_OPTIONS:+$TSAN_OPTIONS:}halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/tests/tsan.supp"
export LFI_NO_SKIPS=${LFI_NO_SKIPS:-1}
tests=build/tsan/tests
umockdev=tests/drivers/run_with_umockdev.sh
run() {  # run NAME LIMIT_S COMMAND...: one line of the summary
  local name=$1 limit=$2 log=build/tsan/$1.log start=$SECONDS status=0
  shift 2
  # (Its own process group, stopped whole: the `lfi` servers a test starts go with it.)
  timeout --signal=TERM --kill-after=30 "$limit" "$@" >"$log" 2>&1 || status=$?
  if [ "$status" -eq 124 ] || [ "$status" -eq 137 ]; then
    local test
    test=$(grep -E '^\[ RUN +\]' "$log" | tail -n 1 | sed -E 's/^\[ RUN +\] //' || true)
    echo "tsan: $name HUNG: stopped after $limit s in ${test:-its set-up}: $log" >&2
  elif [ "$status" -ne 0 ] || grep -q "WARNING: ThreadSanitizer" "$log"; then
    echo "tsan: $name FAILED ($((SECONDS - start)) s): $log" >&2
  else
    echo "tsan: $name clean ($((SECONDS - start)) s)"
    return 0
  fi
  grep -m4 -E "WARNING: ThreadSanitizer|SUMMARY: ThreadSanitizer|^\[  FAILED  \] [A-Za-z]" "$log" >&2 || true
  return 1
}
# The served camera: discovery, the stream hand-over (one format), the
# software trigger, device loss, the server's shutdown. Left out: the other
# format and binning (the same threads), the 3000-frame block id wrap and the
# 2000 frames of packet loss (protocol, not threads; minutes under
# ThreadSanitizer), the device listings, and the twenty kills and reopens
# (reopening after a loss is the aravis run's; docs/reliability.md says why
# this one is not run here).
served='ServedCameraTest.DiscoveryFindsTheServedCamera:ServedCameraTest.Mono8FramesEqualTheLocalRender'
served+=':ServedCameraTest.SoftwareTriggerDeliversOneFramePerTrigger'
served+=':ServedCameraTest.ServerKilledMidStreamIsAClearErrorWithinTheTimeout'
served+=':ServedCameraTest.SigtermStopsTheServerCleanly'
# sim-bench: parts put in place from the control socket's thread while the
# camera streams on Aravis's device thread, line triggers, the control
# requests and the program's end. Left out: the runs of 50 parts with faults,
# and the calibrations (the same threads as the line-triggered run, for minutes).
simbench='LfiSimBench.ALineTriggeredRunInspectsEachPartTheLineBringsInItsOrder'
simbench+=':LfiSimBench.TheProgramsExitStatusIsTheBenchsAndTheEnvironmentNamesTheDevices'
simbench+=':LfiSimBench.RequestsItCannotDoAreRefusedWithTheReasonAndTheBenchGoesOn'
simbench+=':LfiSimBench.ABenchThatIsNotSimulatedAndAControlSocketNobodyServesAreNamed'
# (test_mixed_wiring is not run: each of its cases runs the study's parts twice,
# 80 s and more, and the served bench's threads are sim-bench's.)
# Two lanes, one a core: the runs that serve a GigE Vision device on 127.0.0.1:3956 (aravis, served_camera,
# sim_bench) take turns in the first; the others run beside them in the second.
gige_lane() {
  local status=0
  run aravis 400 "$tests/test_drivers" || status=1
  run served_camera 180 "$tests/test_served_camera" --gtest_filter="$served" || status=1
  run sim_bench 240 "$tests/test_lfi_sim_bench" --gtest_filter="$simbench" || status=1
  return $status
}
other_lane() {
  local status=0
  run usb_display 300 "$umockdev" "$tests/test_display" || status=1
  run tile_renderer 120 "$tests/test_sim" --gtest_filter='Render.*:CameraSensorModel.*' || status=1
  run sim_camera 120 "$tests/test_sim_camera" || status=1
  run run_output 180 "$tests/test_run_output" || status=1
  return $status
}
gige_lane &
gige=$!
other_lane &
other=$!
status=0
wait $gige || status=1
wait $other || status=1
exit $status
