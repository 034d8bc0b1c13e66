#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Mesh loading, lfi's PLY reader against Assimp (OBJ), on this machine.
#   scripts/mesh-load-bench.sh [segments=1000]
# Writes a sphere of 2 x segments x segments/2 triangles (radius 5 mm) as binary
# PLY and as OBJ, renders each at 8 x 8 pixels and 1 spp (so that loading, the
# smooth normals and Embree's BVH build dominate) and prints wall time and peak
# memory (wall time only without /usr/bin/time). Needs python3 (to write the
# meshes); builds lfi if needed.
set -euo pipefail
cd "$(dirname "$0")/.."
SEGMENTS=${1:-1000}
[[ -x build/release/apps/lfi ]] || make build
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
python3 - "$OUT" "$SEGMENTS" <<'EOF'
import math, struct, sys
out, nu = sys.argv[1], int(sys.argv[2])
nv = nu // 2
verts = [(5 * math.sin(math.pi * j / nv) * math.cos(2 * math.pi * i / nu),
          5 * math.sin(math.pi * j / nv) * math.sin(2 * math.pi * i / nu),
          5 * math.cos(math.pi * j / nv)) for j in range(nv + 1) for i in range(nu)]
faces = []
for j in range(nv):
    for i in range(nu):
        a, b = j * nu + i, j * nu + (i + 1) % nu
        c, d = a + nu, b + nu
        faces += [(a, c, b), (b, c, d)]
with open(f"{out}/sphere.ply", "wb") as f:
    f.write((f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\nproperty float x\n"
             f"property float y\nproperty float z\nelement face {len(faces)}\n"
             "property list uchar int vertex_indices\nend_header\n").encode())
    for v in verts: f.write(struct.pack("<fff", *v))
    for t in faces: f.write(struct.pack("<Biii", 3, *t))
with open(f"{out}/sphere.obj", "w") as f:
    for v in verts: f.write("v %.6f %.6f %.6f\n" % v)
    for t in faces: f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
print(f"sphere: {len(verts)} vertices, {len(faces)} triangles")
EOF
for format in ply obj; do
  cat > "$OUT/$format.toml" <<EOF
format = "lfi-scene"
version = 1
[render]
samples_per_pixel = 1
[camera]
focal_length_mm = 100
image_distance_mm = 200
stop_diameter_mm = 2
pixel_pitch_mm = 1
width = 8
height = 8
position_mm = [0, 0, 200]
rotation_deg = [180, 0, 0]
[[object]]
name = "sphere"
shape = "mesh"
file = "sphere.$format"
material = "dielectric"
ior = 1.5
[[object]]
name = "back light"
shape = "rectangle"
size_mm = [400, 400]
position_mm = [0, 0, -100]
emitter = "lambertian"
EOF
  ls -l "$OUT/sphere.$format" | awk -v f="$format" '{printf "%s: %.1f MB, ", f, $5 / 1e6}'
  render=(build/release/apps/lfi -q render "$OUT/$format.toml" --out "$OUT/render" --force)
  if [[ -x /usr/bin/time ]]; then  # Debian's package `time`: wall time and peak memory
    /usr/bin/time -f "%e s, %M KB peak" "${render[@]}" 2>&1 >/dev/null | tail -1
  else
    TIMEFORMAT="%R s"
    time "${render[@]}" >/dev/null
  fi
done
