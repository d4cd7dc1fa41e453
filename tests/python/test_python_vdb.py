"""CubicalComplex.from_vdb / from_grid against the CLI: a .ply of Gaussians on a torus becomes
a .vdb by `morsegs vdb`; `morsegs persistence` on that file (its diagram.json) and from_vdb
give the same diagram, pair for pair with the same voxels (SDF level set, V and T; the
density fog grid, superlevel); from_grid on the pyopenvdb grid read from the file gives it
too; persistence_locations rows point at voxels whose grid values are the birth and death."""
import json
import math
import os
import subprocess

import numpy as np
import pyopenvdb

import morsegs
import pyt


def write_torus_ply(path, n=1500, seed=1):
    """An ASCII 3DGS .ply: isotropic Gaussians (std 0.07) on a torus R = 0.6, r = 0.25."""
    rng = np.random.default_rng(seed)
    u, v = rng.random(n) * 2 * np.pi, rng.random(n) * 2 * np.pi
    x = (0.6 + 0.25 * np.cos(v)) * np.cos(u)
    y = (0.6 + 0.25 * np.cos(v)) * np.sin(u)
    z = 0.25 * np.sin(v)
    props = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1",
             "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    with open(path, "w") as fh:
        fh.write("ply\nformat ascii 1.0\nelement vertex %d\n" % n)
        fh.writelines("property float %s\n" % p for p in props)
        fh.write("end_header\n")
        s = math.log(0.07)
        for i in range(n):  # opacity and scales as 3DGS stores them: logit, log
            fh.write("%.7g %.7g %.7g 0 0 0 0.1 0.2 0.3 2 %.7g %.7g %.7g 1 0 0 0\n" % (x[i], y[i], z[i], s, s, s))


def cli(*args):
    r = subprocess.run([pyt.CLI] + list(args), capture_output=True, text=True)
    assert r.returncode == 0, (args, r.stdout, r.stderr)
    return r.stdout


_cache = {}


def torus_vdb():
    if "vdb" not in _cache:
        d = pyt.tmpdir("vdb")
        ply, vdb = os.path.join(d, "torus.ply"), os.path.join(d, "torus.vdb")
        write_torus_ply(ply)
        cli("vdb", ply, "-o", vdb, "--resolution", "48", "--tau", "0.3")
        _cache["vdb"], _cache["dir"] = vdb, d
    return _cache["vdb"], _cache["dir"]


def cli_diagram(vdb, outdir, *extra):
    cli("persistence", vdb, "-o", outdir, *extra)
    doc = json.load(open(os.path.join(outdir, "diagram.json")))
    rows = []
    for p in doc["pairs"]:
        death = float(p["death"]) if isinstance(p["death"], str) else p["death"]
        bv = tuple(p["birth_cell"]["voxel"])
        dv = tuple(p["death_cell"]["voxel"]) if "death_cell" in p else (-1, -1, -1)
        rows.append((p["dim"], float(p["birth"]), death, bv, dv, bool(p["truncated"])))
    return sorted(rows), doc


def morsegs_rows(cc):
    loc = cc.persistence_locations()
    tr = cc.persistence_truncated()
    return sorted((int(r[0]), r[1], r[2], tuple(int(x) for x in r[3:6]), tuple(int(x) for x in r[6:9]), bool(t))
                  for r, t in zip(loc, tr))


def test_from_vdb_equals_cli():
    vdb, d = torus_vdb()
    cases = [("sdf_v", [], {}), ("sdf_t", ["--construction", "T"], {"construction": "T"}),
             ("sdf_band2", ["--band", "2"], {"band": 2}),
             ("density", ["--grid", "density"], {"grid": "density"}),
             ("density_t", ["--grid", "density", "--construction", "T"], {"grid": "density", "construction": "T"})]
    for name, args, kw in cases:
        ref, doc = cli_diagram(vdb, os.path.join(d, name), *args)
        cc = morsegs.CubicalComplex.from_vdb(vdb, **kw)
        got = morsegs_rows(cc)
        assert len(ref) > 3, (name, len(ref))
        assert got == ref, (name, len(got), len(ref), [r for r in got if r not in ref][:3], [r for r in ref if r not in got][:3])
        info = cc.grid_info
        assert info["grid"] == doc["meta"]["grid"] and info["filtration"] == doc["meta"]["filtration"].split()[0]
        # the CLI's Betti numbers at its level (0 for the SDF) from the same diagram
        if info["filtration"] == "sublevel":
            assert cc.persistent_betti_numbers(0.0, 0.0)[:3] == doc["meta"]["betti"], name
        print("  %-10s %4d pairs equal (%s, %s)" % (name, len(got), info["grid_class"], info["filtration"]))


def test_locations_are_grid_values():
    vdb, _ = torus_vdb()
    for kw in ({}, {"construction": "T"}, {"grid": "density"}):
        cc = morsegs.CubicalComplex.from_vdb(vdb, **kw)
        grid = pyopenvdb.read(vdb, cc.grid_info["grid"])
        acc = grid.getConstAccessor()
        loc = cc.persistence_locations()
        sign = -1.0 if cc.grid_info["filtration"] == "superlevel" else 1.0
        w = cc.stats["effective_w"]
        for row in loc:
            b = acc.getValue(tuple(int(x) for x in row[3:6]))
            assert b == row[1] or (sign * b <= -w and sign * row[1] == -w), (kw, row, b)
            if np.isfinite(row[2]):
                e = acc.getValue(tuple(int(x) for x in row[6:9]))
                # a death set by the clamp (truncated) is read at its voxel clamped to +w
                assert e == row[2] or (sign * e >= w and sign * row[2] == w), (kw, row, e)
        world = cc.persistence_locations(world=True)
        h, t = cc.grid_info["voxel_size"], np.asarray(cc.grid_info["translation"])
        assert np.allclose(world[:, 3:6], t + h * loc[:, 3:6])


def test_from_grid():
    vdb, _ = torus_vdb()
    grid = pyopenvdb.read(vdb, "sdf")
    a = morsegs_rows(morsegs.CubicalComplex.from_grid(grid))
    b = morsegs_rows(morsegs.CubicalComplex.from_vdb(vdb))
    assert a == b
    sphere = pyopenvdb.createLevelSetSphere(radius=10.0, center=(1.0, 2.0, 3.0), voxelSize=0.5, halfWidth=3.0)
    cc = morsegs.CubicalComplex.from_grid(sphere)
    assert cc.persistent_betti_numbers(0.0, 0.0) == [1, 0, 0, 0]  # a ball at t = 0
    loc = cc.persistence_locations(world=True)
    ess = loc[np.isinf(loc[:, 2])]
    # born at the clamped interior value -w, at a voxel inside the ball
    assert len(ess) == 1 and ess[0, 1] == -1.5 and np.linalg.norm(ess[0, 3:6] - (1, 2, 3)) < 10.0, ess
    raises_type = False
    try:
        morsegs.CubicalComplex.from_grid(pyopenvdb.Vec3SGrid())
    except TypeError:
        raises_type = True
    assert raises_type


if __name__ == "__main__":
    pyt.run(globals())
