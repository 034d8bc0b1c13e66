#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs COMMAND in a network namespace of its own whose interfaces are the
# loopback and one end of a veth pair at 192.0.2.77/24 (TEST-NET-1, RFC 5737):
# a host with an IPv4 address outside 127/8, whatever the host itself has.
# Usage: in_veth_netns.sh COMMAND [ARG ...]. Exit 77 (skipped) without root,
# unshare -n or ip; a failure (exit 1) instead where LFI_NO_SKIPS is set, as
# .ci/run sets it.
set -euo pipefail
skip() {
  echo "SKIP: $1"
  [[ -n ${LFI_NO_SKIPS:-} ]] && exit 1
  exit 77
}
for tool in unshare ip; do command -v "$tool" >/dev/null || skip "$tool not installed"; done
if [[ $(id -u) -ne 0 ]] || ! unshare -n true 2>/dev/null; then
  skip "needs root and a network namespace of its own (unshare -n)"
fi
exec unshare -n bash -c '
  set -e
  ip link set lo up
  ip link add lfi0 type veth peer name lfi1
  ip addr add 192.0.2.77/24 dev lfi0
  ip link set lfi1 up
  ip link set lfi0 up
  exec "$@"
' _ "$@"
