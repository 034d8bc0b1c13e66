#!/usr/bin/env bash
# Renders lfi's reference scene with lfi and with Blender Cycles (CPU) on this
# machine and prints both throughputs. Installs Debian's blender if missing
# (root or sudo). Usage: scripts/compare-cycles.sh [spp] [resolution] [threads]
set -euo pipefail
cd "$(dirname "$0")/.."
SPP=${1:-16}
RES=${2:-512}
THREADS=${3:-$(nproc)}
if ! command -v blender >/dev/null; then
  SUDO=(); [[ $(id -u) -ne 0 ]] && SUDO=(sudo)
  "${SUDO[@]}" apt-get install -y -q --no-install-recommends blender
fi
[[ -x build/release/apps/lfi ]] || make build
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

echo "== lfi (data/scenes/reference.toml, ${RES}x${RES}, ${SPP} spp, ${THREADS} threads)"
PITCH=$(awk "BEGIN { printf \"%.9f\", 60 / ${RES} }")
sed "s/^width = .*/width = ${RES}/; s/^height = .*/height = ${RES}/; s#^pixel_pitch_mm = .*#pixel_pitch_mm = ${PITCH}#" \
  data/scenes/reference.toml > "$OUT/reference.toml"
build/release/apps/lfi render "$OUT/reference.toml" --out "$OUT/lfi" --spp "$SPP" --threads "$THREADS" 2>&1 | grep samples

echo "== Blender Cycles $(blender --version 2>/dev/null | head -1 | cut -d' ' -f2) (CPU, same scene, lens as 66k smooth quads)"
blender -b -noaudio -P scripts/cycles/reference_scene.py -- "$SPP" "$RES" "$THREADS" "$OUT/cycles.exr" 2>&1 |
  grep CYCLES_RESULT
