#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Tests udev/70-lfi.rules with udev itself: the emulated display, a USB3 Vision
# camera and an unrelated USB device are described as umockdev devices
# (devices.umockdev, with real descriptor bytes so that udev's usb_id builtin
# derives the interface classes), with the emulated USB3 Vision camera's own
# record beside them (printed by PRINT_U3V_RECORD, lfi-test-u3v-record: the
# device the USB3 Vision tests use), and `udevadm test` runs over each of them in
# a private mount namespace with the project's rules bind-mounted over
# /etc/udev/rules.d and private tmpfs mounts on /dev and /run (udevadm test
# creates the symlinks it computes and writes its database there; a stale
# database would report tags our rules did not set).
# Usage: udev_rules_test.sh <source-dir> <print-u3v-record>. Exit 77 (skipped) where this is not possible (a tool missing,
# not root, no mount namespace); a failure (exit 1) instead where LFI_NO_SKIPS is set, as .ci/run sets it.
set -euo pipefail
SRC=${1:?usage: udev_rules_test.sh <source-dir> <print-u3v-record>}
PRINT_U3V_RECORD=${2:?usage: udev_rules_test.sh <source-dir> <print-u3v-record>}
for tool in udevadm umockdev-run unshare; do
  command -v "$tool" >/dev/null || { echo "SKIP: $tool not installed"; [[ -n ${LFI_NO_SKIPS:-} ]] && exit 1; exit 77; }
done
if [[ $(id -u) -ne 0 ]] || ! unshare -m true 2>/dev/null; then
  echo "SKIP: needs root and a private mount namespace (unshare -m) to run udevadm test"
  [[ -n ${LFI_NO_SKIPS:-} ]] && exit 1
  exit 77
fi

emulated=$(mktemp)
trap 'rm -f "$emulated"' EXIT
"$PRINT_U3V_RECORD" U3VEMU01 >"$emulated"

run() {  # run <devpath>: udevadm test output for that device
  unshare -m bash -c '
    set -e
    mount --make-rprivate /
    mount -t tmpfs tmpfs /run
    mount -t tmpfs tmpfs /dev
    mount --bind "$1/udev" /etc/udev/rules.d
    umockdev-run -d "$1/tests/udev/devices.umockdev" -d "$3" -- udevadm test -a add "$2" 2>&1
  ' _ "$SRC" "$1" "$emulated"
}

failures=0
expect() {  # expect <name> <output> <regex> [present|absent]
  if grep -qE "$3" <<<"$2"; then found=present; else found=absent; fi
  if [[ $found == "${4:-present}" ]]; then echo "ok   $1"; else echo "FAIL $1: /$3/ is $found"; failures=$((failures + 1)); fi
}

usb=/sys/devices/pci0000:00/0000:00:14.0
display=$(run "$usb/usb1/1-3")
display2=$(run "$usb/usb1/1-5")  # the same protocol under another VID:PID
camera=$(run "$usb/usb2/2-1")
emulated_camera=$(run "/sys/devices/2-2")  # (EmulatedU3vCamera's default bus position)
other=$(run "$usb/usb1/1-4")

for name in display display2 camera emulated_camera; do
  out=${!name}
  expect "$name: rules file read" "$out" "Reading rules file: /etc/udev/rules.d/70-lfi.rules"
  expect "$name: mode 0660" "$out" "70-lfi.rules:[0-9]+ MODE 0660"
  expect "$name: group plugdev" "$out" "70-lfi.rules:[0-9]+ GROUP $(getent group plugdev | cut -d: -f3)"
  expect "$name: no uaccess tag (the group alone)" "$out" "^TAGS=.*:uaccess:" absent
done
expect "display: vendor interface seen" "$display" "^ID_USB_INTERFACES=.*:ff4c01:"
expect "display: symlink by serial" "$display" "symlink '/dev/lfi/display-LFD0001'"
expect "display2: symlink by serial" "$display2" "symlink '/dev/lfi/display-LFD0002'"
expect "camera: USB3 Vision interfaces seen" "$camera" "^ID_USB_INTERFACES=.*:ef0500:"
expect "camera: symlink by serial" "$camera" "symlink '/dev/lfi/u3v-U3V0001'"
expect "emulated_camera: USB3 Vision interfaces seen" "$emulated_camera" "^ID_USB_INTERFACES=.*:ef0500:"
expect "emulated_camera: symlink by serial" "$emulated_camera" "symlink '/dev/lfi/u3v-U3VEMU01'"
expect "other: rules file read" "$other" "Reading rules file: /etc/udev/rules.d/70-lfi.rules"
expect "other: no rule of ours applies" "$other" "70-lfi.rules:[0-9]+ (MODE|GROUP|LINK)" absent
expect "other: no uaccess tag" "$other" "^TAGS=.*:uaccess:" absent
expect "other: no lfi symlink" "$other" "/dev/lfi/" absent

total=$(grep -cE '^ *expect "' "$0")
total=$((total + 4 * 4 - 4))  # the loop's four checks run for four devices
echo "$((total - failures)) passed, $failures failed"
[[ $failures -eq 0 ]]
