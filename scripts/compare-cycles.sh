#!/usr/bin/env bash
# lfi against Blender Cycles (CPU) on lfi's reference scene, on this machine.
#   scripts/compare-cycles.sh speed [spp=16] [res=512] [threads=nproc]
#       throughput of both renderers (M samples/s)
#   scripts/compare-cycles.sh convergence [res=128] [threads=nproc]
#       the fair figure: relative RMS error against each renderer's own
#       converged image (4096 spp, another seed) and the time it took, for
#       4..256 spp
# Installs Debian's blender if missing (root or sudo) and builds lfi if needed.
set -euo pipefail
cd "$(dirname "$0")/.."
MODE=${1:-speed}
if ! command -v blender >/dev/null; then
  SUDO=(); [[ $(id -u) -ne 0 ]] && SUDO=(sudo)
  "${SUDO[@]}" apt-get install -y -q --no-install-recommends blender
fi
[[ -x build/release/apps/lfi && -x build/release/bench/lfi-bench ]] || make build
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT

scene() {  # scene <res>: the reference scene at another resolution, same field
  local pitch
  pitch=$(awk "BEGIN { printf \"%.9f\", 60 / $1 }")
  sed "s/^width = .*/width = $1/; s/^height = .*/height = $1/; s#^pixel_pitch_mm = .*#pixel_pitch_mm = ${pitch}#" \
    data/scenes/reference.toml > "$OUT/reference.toml"
}
lfi_render() {  # lfi_render <spp> <threads> <seed> <name>: prints seconds
  build/release/apps/lfi render "$OUT/reference.toml" --out "$OUT/$4" --spp "$1" --threads "$2" --seed "$3" --force 2>&1 |
    sed -n 's/.* samples in \([0-9.]*\) s.*/\1/p'
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
    lfi_render 4096 "$THREADS" 999 lfi-ref >/dev/null
    cycles_render 4096 "$RES" "$THREADS" 999 "$OUT/cycles-ref.exr" >/dev/null
    printf "%6s %12s %12s %12s %12s\n" spp "lfi s" "lfi rmse" "Cycles s" "Cycles rmse"
    for spp in 4 16 64 256; do
      tl=$(lfi_render "$spp" "$THREADS" 1 lfi)
      el=$(build/release/bench/lfi-bench --rmse "$OUT/lfi/reference.exr" "$OUT/lfi-ref/reference.exr" | cut -d= -f2)
      tc=$(cycles_render "$spp" "$RES" "$THREADS" 0 "$OUT/cycles.exr")
      ec=$(build/release/bench/lfi-bench --rmse "$OUT/cycles.exr" "$OUT/cycles-ref.exr" | cut -d= -f2)
      printf "%6d %12s %12s %12s %12s\n" "$spp" "$tl" "$el" "$tc" "$ec"
    done
    ;;
  *) echo "usage: $0 speed|convergence [...]" >&2; exit 2 ;;
esac
