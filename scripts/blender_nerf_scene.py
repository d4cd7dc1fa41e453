# A NeRF-synthetic folder rendered by Blender, laid out exactly as the original lego is:
# transforms_{train,test}.json with camera_angle_x and Blender camera-to-world matrices,
# frames "./train/r_N" without extension, RGBA PNGs with a transparent background, and no
# point file. Data made by another renderer than `morsegs scene` (Embree), to try MorseGS
# as a user with such a folder would. The mesh is normalised into [-0.8, 0.8] (its longest
# side 1.6, centred), given a procedural noise colour and written as OUT/gt_mesh_blender.ply
# in the transforms' frame (for `morsegs eval RUN --mesh`). Cameras at radius 4 look at the
# origin from elevations uniform in [LOW, HIGH] rad (default -0.2..1.3: mostly the upper
# hemisphere, as lego's) with a fixed seed.
#   blender -b --factory-startup -P scripts/blender_nerf_scene.py -- MESH OUT [RES NTRAIN NTEST LOW HIGH]
# Debian's blender 3.4 (Cycles on the CPU, 16 samples, no denoiser: Debian builds it without OIDN).
import bpy, sys, os, json, math, random
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) < 2:
    sys.exit("usage: blender -b -P blender_nerf_scene.py -- MESH OUT [RES NTRAIN NTEST LOW HIGH]")
mesh, out = argv[0], argv[1]
res, ntrain, ntest = (int(a) for a in (argv[2:5] + ["200", "60", "10"][len(argv[2:5]):]))
low, high = (float(a) for a in (argv[5:7] + ["-0.2", "1.3"][len(argv[5:7]):]))

bpy.ops.wm.read_factory_settings(use_empty=True)
ext = mesh.lower().rsplit(".", 1)[-1]
if ext == "obj": bpy.ops.import_scene.obj(filepath=mesh)
elif ext == "stl": bpy.ops.import_mesh.stl(filepath=mesh)
elif ext == "ply": bpy.ops.import_mesh.ply(filepath=mesh)
else: sys.exit("blender_nerf_scene: %s: OBJ, STL or PLY expected" % mesh)
objs = [o for o in bpy.context.scene.objects if o.type == 'MESH']
if not objs: sys.exit("blender_nerf_scene: %s: no mesh object" % mesh)
bpy.ops.object.select_all(action='DESELECT')
for o in objs: o.select_set(True)
bpy.context.view_layer.objects.active = objs[0]
if len(objs) > 1: bpy.ops.object.join()
ob = bpy.context.view_layer.objects.active
bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
vs = [ob.matrix_world @ v.co for v in ob.data.vertices]
lo = Vector([min(v[i] for v in vs) for i in range(3)])
hi = Vector([max(v[i] for v in vs) for i in range(3)])
s = 1.6 / max(hi - lo)
ob.location = -(lo + hi) / 2 * s
ob.scale = (s, s, s)
bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)

mat = bpy.data.materials.new("noise")
mat.use_nodes = True
nt = mat.node_tree
noise = nt.nodes.new("ShaderNodeTexNoise")
noise.inputs["Scale"].default_value = 6.0
ramp = nt.nodes.new("ShaderNodeValToRGB")
ramp.color_ramp.elements[0].color = (0.8, 0.3, 0.1, 1)
ramp.color_ramp.elements[1].color = (0.2, 0.5, 0.9, 1)
nt.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
nt.links.new(ramp.outputs["Color"], nt.nodes["Principled BSDF"].inputs["Base Color"])
ob.data.materials.clear()
ob.data.materials.append(mat)

os.makedirs(out, exist_ok=True)
# axis_forward/up as Blender's own axes: the file keeps the world frame of the transforms
bpy.ops.export_mesh.ply(filepath=os.path.join(out, "gt_mesh_blender.ply"), use_selection=True, use_normals=False,
                        use_uv_coords=False, use_colors=False, axis_forward='Y', axis_up='Z')

sc = bpy.context.scene
sc.world = bpy.data.worlds.new("world")
sc.world.use_nodes = True
sc.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.6
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", 'SUN'))
sc.collection.objects.link(sun)
sun.rotation_euler = (0.6, 0.2, 0.8)
sun.data.energy = 2
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
sc.collection.objects.link(cam)
sc.camera = cam
cam.data.lens, cam.data.sensor_width = 50, 32
sc.render.engine = 'CYCLES'
sc.cycles.samples, sc.cycles.device, sc.cycles.use_denoising = 16, 'CPU', False
sc.render.resolution_x = sc.render.resolution_y = res
sc.render.resolution_percentage = 100
sc.render.film_transparent = True
sc.render.image_settings.file_format, sc.render.image_settings.color_mode = 'PNG', 'RGBA'

random.seed(1)
for split, n in (("train", ntrain), ("test", ntest)):
    frames = []
    os.makedirs(os.path.join(out, split), exist_ok=True)
    for i in range(n):
        th, ph = random.uniform(0, 2 * math.pi), random.uniform(low, high)
        cam.location = Vector((4 * math.cos(ph) * math.cos(th), 4 * math.cos(ph) * math.sin(th), 4 * math.sin(ph)))
        cam.rotation_euler = (-cam.location).to_track_quat('-Z', 'Y').to_euler()
        bpy.context.view_layer.update()
        sc.render.filepath = os.path.join(out, split, "r_%d.png" % i)
        bpy.ops.render.render(write_still=True)
        frames.append({"file_path": "./%s/r_%d" % (split, i), "rotation": 0.0,
                       "transform_matrix": [list(r) for r in cam.matrix_world]})
    with open(os.path.join(out, "transforms_%s.json" % split), "w") as f:
        json.dump({"camera_angle_x": cam.data.angle_x, "frames": frames}, f, indent=2)
