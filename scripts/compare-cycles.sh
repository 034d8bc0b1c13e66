#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# lfi against Blender Cycles (CPU) on lfi's reference scene, on this machine.
#   scripts/compare-cycles.sh speed [spp=16] [res=512] [threads=nproc]
#       throughput of both renderers (M samples/s)
#   scripts/compare-cycles.sh convergence [res=128] [threads=nproc]
#       the fair figure: relative RMS error against each renderer's own
#       converged image (another seed; lfi: 1024 spp with Fresnel splitting,
#       Cycles: 4096 spp) and the time it took, for 1..256 spp; lfi both as the
#       reference scene samples (Fresnel choices drawn, like Cycles) and with
#       its default Fresnel splitting (split depth 4)
# Installs Debian's blender if missing (root or sudo) and builds lfi if needed.
set -euo pipefail
cd "$(dirname "$0")/.."
MODE=${1:-speed}
if ! command -v blender >/dev/null; then
  SUDO=(); [[ $(id -u) -ne 0 ]] && SUDO=(sudo)
  "${SUDO[@]}" apt-get install -y -q --no-install-recommends blender
fi
[[ -x build/release/apps/lfi && -x build/release/benchmarks/lfi-bench ]] || make build
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

scene() {  # scene <res>: the reference scene at another resolution, same field; also with splitting
  local pitch
  pitch=$(awk "BEGIN { printf \"%.9f\", 60 / $1 }")
  sed "s/^width = .*/width = $1/; s/^height = .*/height = $1/; s#^pixel_pitch_mm = .*#pixel_pitch_mm = ${pitch}#" \
    data/scenes/reference.toml > "$OUT/reference.toml"
  sed "s/^split_depth = .*/split_depth = 4/" "$OUT/reference.toml" > "$OUT/split.toml"
}
lfi_render() {  # lfi_render <spp> <threads> <seed> <name> [scene=reference]: prints seconds
  build/release/apps/lfi render "$OUT/${5:-reference}.toml" --out "$OUT/$4" --spp "$1" --threads "$2" --seed "$3" \
    --force 2>&1 | sed -n 's/.* samples in \([0-9.]*\) s.*/\1/p'
}
cycles_render() {  # cycles_render <spp> <res> <threads> <seed> <file>: prints seconds
  blender -b -noaudio -P scripts/cycles/reference_scene.py -- "$1" "$2" "$3" "$5" "$4" 2>&1 |
    sed -n 's/^CYCLES_RESULT .* seconds=\([0-9.]*\) .*/\1/p'
}

case "$MODE" in
  speed)
    SPP=${2:-16} RES=${3:-512} THREADS=${4:-$(nproc)}
    scene "$RES"
    samples=$((RES * RES * SPP))
    t=$(lfi_render "$SPP" "$THREADS" 1 lfi)
    echo "lfi:    ${RES}x${RES}, ${SPP} spp, ${THREADS} threads: $(awk "BEGIN { printf \"%.2f\", $samples / $t / 1e6 }") M samples/s"
    t=$(cycles_render "$SPP" "$RES" "$THREADS" 0 "$OUT/cycles.exr")
    echo "Cycles: ${RES}x${RES}, ${SPP} spp, ${THREADS} threads: $(awk "BEGIN { printf \"%.2f\", $samples / $t / 1e6 }") M samples/s"
    ;;
  convergence)
    RES=${2:-128} THREADS=${3:-$(nproc)}
    scene "$RES"
    lfi_render 1024 "$THREADS" 999 lfi-ref split >/dev/null
    cycles_render 4096 "$RES" "$THREADS" 999 "$OUT/cycles-ref.exr" >/dev/null
    rmse() { build/release/benchmarks/lfi-bench --rmse "$1" "$2" | cut -d= -f2; }
    printf "%6s %10s %10s %10s %10s %10s %10s\n" spp "lfi s" "lfi rmse" "split s" "split rmse" "Cycles s" "Cyc. rmse"
    for spp in 1 4 16 64 256; do
      tl=$(lfi_render "$spp" "$THREADS" 1 lfi)
      el=$(rmse "$OUT/lfi/reference.exr" "$OUT/lfi-ref/split.exr")
      ts=$(lfi_render "$spp" "$THREADS" 1 lfi-split split)
      es=$(rmse "$OUT/lfi-split/split.exr" "$OUT/lfi-ref/split.exr")
      tc=$(cycles_render "$spp" "$RES" "$THREADS" 0 "$OUT/cycles.exr")
      ec=$(rmse "$OUT/cycles.exr" "$OUT/cycles-ref.exr")
      printf "%6d %10s %10s %10s %10s %10s %10s\n" "$spp" "$tl" "$el" "$ts" "$es" "$tc" "$ec"
    done
    ;;
  *) echo "usage: $0 speed|convergence [...]" >&2; exit 2 ;;
esac
