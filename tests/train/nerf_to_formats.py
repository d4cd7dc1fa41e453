#!/usr/bin/python3
"""Copies a NeRF-synthetic folder (as `morsegs scene` writes it) into the two other layouts
users bring, exactly as those tools write them, for tests:
  OUT/colmap/      sparse/0/{cameras,images,points3D}.txt + images/ (RGB, black background:
                   COLMAP users have photos, not RGBA renders)
  OUT/nerfstudio/  transforms.json (fl_x fl_y cx cy w h, file_path with extension,
                   ply_file_path) + images/
and OUT/lego/, the NeRF-synthetic folder without points3d.ply (as the original lego ships).
Usage: nerf_to_formats.py NERF_DIR OUT_DIR"""
import json, math, os, shutil, sys
import numpy as np
from PIL import Image

src, out = sys.argv[1], sys.argv[2]
frames = []
for split in ("train", "test"):
    t = json.load(open(os.path.join(src, "transforms_%s.json" % split)))
    for f in t["frames"]:
        frames.append((split, f["file_path"], np.array(f["transform_matrix"], float), t["camera_angle_x"]))

lego = os.path.join(out, "lego")
shutil.copytree(src, lego)
if os.path.exists(os.path.join(lego, "points3d.ply")):
    os.remove(os.path.join(lego, "points3d.ply"))

def read_points(path):
    """x y z r g b of a binary little-endian points3d.ply (the scene maker's layout)."""
    with open(path, "rb") as fh:
        header, props, n = [], [], 0
        while True:
            line = fh.readline().decode().strip()
            header.append(line)
            if line.startswith("element vertex"): n = int(line.split()[2])
            if line.startswith("property"): props.append(line.split())
            if line == "end_header": break
        dt = np.dtype([(p[2], {"float": "<f4", "uchar": "u1", "double": "<f8"}[p[1]]) for p in props])
        v = np.frombuffer(fh.read(n * dt.itemsize), dtype=dt, count=n)
    rgb = np.stack([v[c] for c in ("red", "green", "blue")], 1) if "red" in v.dtype.names else np.full((n, 3), 128)
    return np.stack([v["x"], v["y"], v["z"]], 1).astype(float), rgb.astype(int)

xyz, rgb = read_points(os.path.join(src, "points3d.ply"))

# nerfstudio: one transforms.json, images with extension, the points by ply_file_path
ns = os.path.join(out, "nerfstudio")
os.makedirs(os.path.join(ns, "images"))
nsf = []
for k, (split, fp, m, ax) in enumerate(frames):
    name = "%s_%s.png" % (split, os.path.basename(fp))
    shutil.copy(os.path.join(src, fp + ".png"), os.path.join(ns, "images", name))
    nsf.append({"file_path": "images/" + name, "transform_matrix": m.tolist()})
w, h = Image.open(os.path.join(src, frames[0][1] + ".png")).size
fl = 0.5 * w / math.tan(0.5 * frames[0][3])
shutil.copy(os.path.join(src, "points3d.ply"), os.path.join(ns, "sparse_pc.ply"))
json.dump({"fl_x": fl, "fl_y": fl, "cx": w / 2, "cy": h / 2, "w": w, "h": h, "ply_file_path": "sparse_pc.ply",
           "frames": nsf}, open(os.path.join(ns, "transforms.json"), "w"), indent=1)

# COLMAP text model: world-to-camera in OpenCV axes (x right, y down, z forward)
cm = os.path.join(out, "colmap")
os.makedirs(os.path.join(cm, "sparse", "0"))
os.makedirs(os.path.join(cm, "images"))
flip = np.diag([1.0, -1.0, -1.0, 1.0])
def quat(R):
    q = np.empty(4)
    t = np.trace(R)
    if t > 0:
        s = 0.5 / math.sqrt(t + 1.0); q[0] = 0.25 / s
        q[1:] = [(R[2, 1] - R[1, 2]) * s, (R[0, 2] - R[2, 0]) * s, (R[1, 0] - R[0, 1]) * s]
    else:
        i = int(np.argmax(np.diag(R))); j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k])
        q[0] = (R[k, j] - R[j, k]) / s; q[1 + i] = 0.25 * s
        q[1 + j] = (R[j, i] + R[i, j]) / s; q[1 + k] = (R[k, i] + R[i, k]) / s
    return q
with open(os.path.join(cm, "sparse", "0", "cameras.txt"), "w") as fh:
    fh.write("# Camera list\n1 PINHOLE %d %d %.17g %.17g %.17g %.17g\n" % (w, h, fl, fl, w / 2, h / 2))
with open(os.path.join(cm, "sparse", "0", "images.txt"), "w") as fh:
    fh.write("# Image list\n")
    for k, (split, fp, m, ax) in enumerate(frames):
        name = "%s_%s.png" % (split, os.path.basename(fp))
        im = Image.open(os.path.join(src, fp + ".png")).convert("RGBA")
        bg = Image.new("RGBA", im.size, (0, 0, 0, 255))
        Image.alpha_composite(bg, im).convert("RGB").save(os.path.join(cm, "images", name))
        w2c = np.linalg.inv(m @ flip)
        q = quat(w2c[:3, :3]); t = w2c[:3, 3]
        fh.write("%d %s %s 1 %s\n\n" % (k + 1, " ".join("%.17g" % x for x in q), " ".join("%.17g" % x for x in t), name))
with open(os.path.join(cm, "sparse", "0", "points3D.txt"), "w") as fh:
    fh.write("# 3D point list\n")
    for i, (p, c) in enumerate(zip(xyz, rgb)):
        fh.write("%d %.9g %.9g %.9g %d %d %d 0.5\n" % (i + 1, p[0], p[1], p[2], c[0], c[1], c[2]))
