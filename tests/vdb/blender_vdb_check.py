# Run inside Blender (blender --background --factory-startup --python THIS -- VDB GRID PLY):
# imports a MorseGS .vdb as a Volume object, meshes GRID with Blender's own Volume to Mesh
# modifier, imports PLY (the mesh morsegs extracted from the same grid) and compares the two
# meshes' piece counts and Euler characteristics. Exit status 1 on any mismatch or a grid
# Blender cannot find.
import sys
import bmesh
import bpy


def topology(me):
    bm = bmesh.new()
    bm.from_mesh(me)
    seen, pieces = set(), 0
    for v in bm.verts:
        if v.index in seen:
            continue
        pieces += 1
        stack = [v]
        seen.add(v.index)
        while stack:
            x = stack.pop()
            for e in x.link_edges:
                o = e.other_vert(x)
                if o.index not in seen:
                    seen.add(o.index)
                    stack.append(o)
    out = (len(bm.verts), len(bm.edges), len(bm.faces), pieces)
    bm.free()
    return out


def fail(msg):
    print("FAIL:", msg)
    sys.stdout.flush()
    sys.exit(1)


vdb, grid, ply = sys.argv[sys.argv.index("--") + 1:][:3]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.object.volume_import(filepath=vdb)
vol = bpy.context.selected_objects[0]
vol.data.grids.load()
names = [g.name for g in vol.data.grids]
print("grids in %s: %s" % (vdb, names))
if grid not in names:
    fail("grid %s not in %s" % (grid, vdb))
bpy.ops.mesh.primitive_cube_add()
holder = bpy.context.active_object
mod = holder.modifiers.new("volume_to_mesh", "VOLUME_TO_MESH")
mod.object = vol
mod.grid_name = grid
mod.resolution_mode = "GRID"
mod.threshold = 0.0  # the level set's zero
mod.adaptivity = 0.0
dg = bpy.context.evaluated_depsgraph_get()
v, e, f, pieces = topology(holder.evaluated_get(dg).to_mesh())
chi = v - e + f
print("blender volume-to-mesh of %s: %d vertices, %d faces, %d pieces, Euler characteristic %d" % (grid, v, f, pieces, chi))
if v == 0:
    fail("Blender's Volume to Mesh of %s is empty" % grid)
bpy.ops.import_mesh.ply(filepath=ply)
mv, me_, mf, mpieces = topology(bpy.context.selected_objects[0].data)
mchi = mv - me_ + mf
print("morsegs mesh %s: %d vertices, %d faces, %d pieces, Euler characteristic %d" % (ply, mv, mf, mpieces, mchi))
if (pieces, chi) != (mpieces, mchi):
    fail("pieces/Euler characteristic differ: blender (%d, %d), morsegs (%d, %d)" % (pieces, chi, mpieces, mchi))
print("OK")
