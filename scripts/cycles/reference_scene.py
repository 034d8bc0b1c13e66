# SPDX-License-Identifier: Apache-2.0
# Blender (Cycles, CPU) version of lfi's reference scene (data/scenes/reference.toml),
# for the speed comparison in docs/performance.md. Run through
# scripts/compare-cycles.sh, or:
#   blender -b -noaudio -P scripts/cycles/reference_scene.py -- <spp> <resolution> <threads> <out.exr> [seed]
# Scene units are millimetres (one Blender unit = 1 mm).
import math
import sys
import time

import bmesh
import bpy

args = sys.argv[sys.argv.index("--") + 1:]
spp, res, threads, out = int(args[0]), int(args[1]), int(args[2]), args[3]
seed = int(args[4]) if len(args) > 4 else 0

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
cy = scene.cycles
cy.device = "CPU"
cy.samples = spp
cy.seed = seed
cy.use_adaptive_sampling = False
cy.use_denoising = False
cy.max_bounces = cy.transmission_bounces = cy.glossy_bounces = cy.transparent_max_bounces = 64
cy.diffuse_bounces = 0
cy.caustics_reflective = cy.caustics_refractive = True
cy.sample_clamp_direct = cy.sample_clamp_indirect = 0.0
cy.filter_width = 0.01  # box-like: no pixel filter blur, as lfi samples the pixel area
scene.render.resolution_x = scene.render.resolution_y = res
scene.render.resolution_percentage = 100
scene.render.threads_mode = "FIXED"
scene.render.threads = threads
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.view_settings.view_transform = "Standard"

# Double-convex lens R1 = R2 = 100, diameter 50, centre thickness 7, n = 1.5:
# two spherical caps and the edge cylinder, finely tessellated, smooth shaded.
R, D, TC, RINGS, SECTORS = 100.0, 50.0, 7.0, 128, 256
mesh = bpy.data.meshes.new("lens")
bm = bmesh.new()
def cap(z0, sign):
    verts = [bm.verts.new((0, 0, z0))]
    for i in range(1, RINGS + 1):
        r = D / 2 * i / RINGS
        sag = R - math.sqrt(R * R - r * r)
        for k in range(SECTORS):
            phi = 2 * math.pi * k / SECTORS
            verts.append(bm.verts.new((r * math.cos(phi), r * math.sin(phi), z0 + sign * sag)))
    def v(i, k):
        return verts[0] if i == 0 else verts[1 + (i - 1) * SECTORS + k % SECTORS]
    for i in range(RINGS):
        for k in range(SECTORS):
            quad = [v(i, k), v(i + 1, k), v(i + 1, k + 1), v(i, k + 1)]
            quad = list(dict.fromkeys(quad))
            bm.faces.new(quad if sign > 0 else quad[::-1])
    return [v(RINGS, k) for k in range(SECTORS)]
front = cap(-TC / 2, +1)
back = cap(TC / 2, -1)
for k in range(SECTORS):
    bm.faces.new([front[k], front[(k + 1) % SECTORS], back[(k + 1) % SECTORS], back[k]])
bmesh.ops.recalc_face_normals(bm, faces=bm.faces)
bm.to_mesh(mesh)
for p in mesh.polygons:
    p.use_smooth = True
lens = bpy.data.objects.new("lens", mesh)
scene.collection.objects.link(lens)
glass = bpy.data.materials.new("glass")
glass.use_nodes = True
nodes = glass.node_tree.nodes
nodes.clear()
bsdf = nodes.new("ShaderNodeBsdfGlass")
bsdf.distribution = "SHARP"
bsdf.inputs["IOR"].default_value = 1.5
bsdf.inputs["Color"].default_value = (1, 1, 1, 1)
outn = nodes.new("ShaderNodeOutputMaterial")
glass.node_tree.links.new(bsdf.outputs["BSDF"], outn.inputs["Surface"])
lens.data.materials.append(glass)

# Lambertian emitter 400 x 400 at z = -100, radiance 1, facing +z.
bpy.ops.mesh.primitive_plane_add(size=400, location=(0, 0, -100))
light = bpy.context.active_object
em = bpy.data.materials.new("emitter")
em.use_nodes = True
n2 = em.node_tree.nodes
n2.clear()
emission = n2.new("ShaderNodeEmission")
emission.inputs["Strength"].default_value = 1.0
o2 = n2.new("ShaderNodeOutputMaterial")
em.node_tree.links.new(emission.outputs["Emission"], o2.inputs["Surface"])
light.data.materials.append(em)

# Telecentric camera: orthographic, 60 x 60 mm field, at z = +200 looking down -z,
# focused on the lens centre plane, aperture radius 2 mm (0.01 rad at 200 mm).
cam_data = bpy.data.cameras.new("camera")
cam_data.type = "ORTHO"
cam_data.ortho_scale = 60
cam_data.clip_start, cam_data.clip_end = 0.1, 1000
cam_data.dof.use_dof = True
cam_data.dof.focus_distance = 200
cam_data.lens = 50
# Blender's aperture radius = lens / (2 f-stop), in metres of the 50 mm lens
# (0.025 / f-stop m) converted to scene units (mm): 25 / f-stop.
cam_data.dof.aperture_fstop = 25.0 / 2.0
cam = bpy.data.objects.new("camera", cam_data)
cam.location = (0, 0, 200)
scene.collection.objects.link(cam)
scene.camera = cam
scene.world = bpy.data.worlds.new("black")
scene.world.color = (0, 0, 0)

scene.render.filepath = out
start = time.time()
bpy.ops.render.render(write_still=True)
seconds = time.time() - start
print(f"CYCLES_RESULT samples={res * res * spp} seconds={seconds:.3f} msamples_per_s={res * res * spp / seconds / 1e6:.3f}")
