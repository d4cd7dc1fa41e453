#!/usr/bin/python3
"""Copies a NeRF-synthetic / nerfstudio scene folder, moved by a translation (issue 28).

    translate_scene.py SRC DST TX TY TZ [--no-points]

Every transforms*.json transform_matrix gets (TX, TY, TZ) added to its translation column
(written with Python's round-trip float repr); points3d.ply (binary little-endian) is
rewritten with double x y z = x + T (the other properties as they were), so the moved
points carry no float32 rounding the centred ones do not; gt_mesh.ply is left out (a float
mesh cannot hold 1e6-scale coordinates to the scene's precision). Images are copied.
--no-points leaves points3d.ply out (the random-init case).
"""
import json
import os
import shutil
import struct
import sys

TYPES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
         "float": "f", "double": "d", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H",
         "int32": "i", "uint32": "I", "float32": "f", "float64": "d"}


def move_ply(src, dst, t):
    with open(src, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in header:
        sys.exit(f"{src}: only binary_little_endian .ply is handled")
    props, count, in_vertex, out = [], 0, False, []
    for line in header:
        w = line.split()
        if w[0] == "element":
            in_vertex = w[1] == "vertex"
            if in_vertex:
                count = int(w[2])
        elif w[0] == "property" and in_vertex:
            if w[1] == "list":
                sys.exit(f"{src}: list properties in the vertex element are not handled")
            props.append((w[2], TYPES[w[1]]))
            if w[2] in ("x", "y", "z"):
                line = f"property double {w[2]}"
        out.append(line)
    fmt_in = "<" + "".join(c for _, c in props)
    fmt_out = "<" + "".join("d" if n in ("x", "y", "z") else c for n, c in props)
    size = struct.calcsize(fmt_in)
    axis = {"x": 0, "y": 1, "z": 2}
    body = bytearray()
    for i in range(count):
        row = list(struct.unpack_from(fmt_in, data, end + i * size))
        for k, (n, _) in enumerate(props):
            if n in axis:
                row[k] = float(row[k]) + t[axis[n]]
        body += struct.pack(fmt_out, *row)
    with open(dst, "wb") as f:
        f.write(("\n".join(out) + "\n").encode("ascii"))
        f.write(body)
        f.write(data[end + count * size:])


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 5:
        sys.exit(__doc__)
    src, dst = args[0], args[1]
    t = [float(a) for a in args[2:5]]
    no_points = "--no-points" in sys.argv
    if os.path.exists(dst):
        shutil.rmtree(dst)
    os.makedirs(dst)
    for name in sorted(os.listdir(src)):
        p, q = os.path.join(src, name), os.path.join(dst, name)
        if os.path.isdir(p):
            shutil.copytree(p, q)
        elif name.startswith("transforms") and name.endswith(".json"):
            with open(p) as f:
                j = json.load(f)
            for fr in j.get("frames", []):
                m = fr["transform_matrix"]
                for r in range(3):
                    m[r][3] = float(m[r][3]) + t[r]
            with open(q, "w") as f:
                json.dump(j, f, indent=1)
        elif name == "points3d.ply":
            if not no_points:
                move_ply(p, q, t)
        elif name == "gt_mesh.ply":
            continue
        else:
            shutil.copy2(p, q)


if __name__ == "__main__":
    main()
