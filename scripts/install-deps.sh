#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs lfi's build, run and test dependencies from Debian 12 packages.
# Idempotent: packages already installed are left alone and apt is not
# touched at all when nothing is missing. Needs root or sudo for apt-get.
set -euo pipefail

PACKAGES=(
  # toolchain
  g++ cmake make pkg-config ninja-build git
  # ray queries, parallelism
  libembree-dev libtbb-dev
  # camera: GenICam through Aravis (tools for the loopback and USB3 Vision tests: arv-camera-test, arv-tool)
  libaravis-dev aravis-tools aravis-tools-cli
  # display: USB; monitors (HDMI, DisplayPort, USB display adapters) through SDL2, tested on a real X server
  libusb-1.0-0-dev libsdl2-dev xvfb
  # images, light fields, analysis
  libopencv-dev libopenexr-dev libimath-dev zlib1g-dev libpng-dev
  # Gray code patterns for the coded reference (OpenCV's structured_light)
  libopencv-contrib-dev
  # meshes (OBJ, PLY, STL, ...)
  libassimp-dev
  # small libraries instead of hand-written code
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  # exact Poisson draws for the camera sensor model where its fast draw does not apply (Boost.Random, header-only)
  libboost-dev
  # tests, and the emulated USB display and USB3 Vision camera (emulation/: umockdev)
  libgtest-dev libgmock-dev umockdev libumockdev-dev udev
  # network namespaces for the tests that need an address outside 127/8 (ip, unshare)
  iproute2 util-linux
  # the fuzz targets (make fuzz: clang's libFuzzer)
  clang libclang-rt-14-dev
  # the formatting check (make check-format, CI)
  clang-format
  # the Python package (python/: pybind11) and its tests (pytest, numpy)
  pybind11-dev python3-dev python3-pytest python3-numpy
  # a run's records over MQTT ([output.mqtt]: libmosquitto) and the broker its tests start (mosquitto, mosquitto_passwd)
  libmosquitto-dev mosquitto
  # the certificates of the MQTT tests' TLS broker
  openssl
  # sweeps on a cluster (scripts/slurm/) and the single-node cluster of their test
  slurm-wlm munge
)

if [[ ! -r /etc/os-release ]] || ! grep -qE '^ID=debian' /etc/os-release \
    || ! grep -qE '^VERSION_ID="?12' /etc/os-release; then
  echo "install-deps: this script supports Debian 12 (bookworm) only;" >&2
  echo "  found: $( (grep -E '^PRETTY_NAME=' /etc/os-release 2>/dev/null || echo unknown) | cut -d= -f2-)" >&2
  echo "  install the equivalents of these packages by hand: ${PACKAGES[*]}" >&2
  exit 1
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null; then SUDO=(sudo); else
    echo "install-deps: need root or sudo to install: ${missing[*]}" >&2
    exit 1
  fi
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -q
"${SUDO[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
