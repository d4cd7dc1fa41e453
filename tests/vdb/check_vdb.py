#!/usr/bin/python3
"""Independent check of a morsegs .vdb with Debian's python3-openvdb (pyopenvdb) and
vdb_print (libopenvdb-tools): grids 'sdf' (level set) and 'density' (fog volume) with the
expected names, classes, voxel size, identity-rotation transform, background, active voxel
counts and file metadata; the 'critical' PointDataGrid (pyopenvdb cannot load point grids,
so vdb_print lists it). Exits non-zero with a message on any mismatch."""
import argparse
import math
import subprocess
import sys

import pyopenvdb as vdb

ap = argparse.ArgumentParser()
ap.add_argument("path")
ap.add_argument("--voxel-size", type=float, required=True)
ap.add_argument("--tau", type=float, required=True)
ap.add_argument("--source", required=True)
ap.add_argument("--sdf-active", type=int)
ap.add_argument("--density-active", type=int)
ap.add_argument("--band", type=int, default=3)
ap.add_argument("--critical", type=int, default=-1, help="expected number of critical points (-1: no grid)")
a = ap.parse_args()
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)


meta = vdb.readMetadata(a.path)
check(meta.get("tool") == "morsegs", "file metadata tool = %r" % meta.get("tool"))
check(bool(meta.get("version")), "file metadata version missing")
check(abs(meta.get("tau", float("nan")) - a.tau) < 1e-12, "file metadata tau = %r" % meta.get("tau"))
check(abs(meta.get("voxel_size", float("nan")) - a.voxel_size) < 1e-12, "file metadata voxel_size = %r" % meta.get("voxel_size"))
check(meta.get("source") == a.source, "file metadata source = %r" % meta.get("source"))

for name, cls, active in (("sdf", vdb.GridClass.LEVEL_SET, a.sdf_active), ("density", vdb.GridClass.FOG_VOLUME, a.density_active)):
    g = vdb.read(a.path, name)
    check(g.name == name, "grid name %r" % g.name)
    check(g.gridClass == cls, "grid %s class %r, expected %r" % (name, g.gridClass, cls))
    check(type(g).__name__ == "FloatGrid", "grid %s type %s" % (name, type(g).__name__))
    vs = g.transform.voxelSize()
    check(all(abs(v - a.voxel_size) < 1e-9 for v in vs), "grid %s voxel size %r" % (name, vs))
    # Uniform scale, no rotation: index (1,0,0) maps to world origin + (h,0,0).
    o = g.transform.indexToWorld((0, 0, 0))
    e = g.transform.indexToWorld((1, 2, 3))
    d = [e[i] - o[i] for i in range(3)]
    check(all(abs(d[i] - (i + 1) * a.voxel_size) < 1e-9 for i in range(3)), "grid %s transform %r" % (name, d))
    if active is not None:
        check(g.activeVoxelCount() == active, "grid %s active voxels %d, expected %d" % (name, g.activeVoxelCount(), active))
    lo, hi = g.evalMinMax()
    if name == "sdf":
        bg = a.band * a.voxel_size
        check(abs(g.background - bg) < 1e-6, "sdf background %r, expected %r" % (g.background, bg))
        check(lo < 0 < hi and lo >= -bg - 1e-6 and hi <= bg + 1e-6, "sdf range [%r, %r]" % (lo, hi))
    else:
        check(g.background == 0, "density background %r" % g.background)
        check(0 <= lo and hi <= 1, "density range [%r, %r]" % (lo, hi))

if a.critical >= 0:
    out = subprocess.run(["vdb_print", "-l", a.path], capture_output=True, text=True)
    check(out.returncode == 0, "vdb_print failed: %s" % out.stderr.strip())
    blocks = out.stdout.split("Name: ")
    crit = [b for b in blocks if b.startswith("critical\n")]
    check(len(crit) == 1, "vdb_print lists no grid 'critical'")
    if crit:
        check("ptdataidx" in crit[0], "grid 'critical' is not a PointDataGrid")

if failures:
    for f in failures:
        print("check_vdb.py: %s: %s" % (a.path, f), file=sys.stderr)
    sys.exit(1)
print("check_vdb.py: %s: ok (python3-openvdb %s)" % (a.path, ".".join(map(str, vdb.LIBRARY_VERSION))))
