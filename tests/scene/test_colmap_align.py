#!/usr/bin/python3
"""scripts/colmap_align.py: the similarity fit on constructed cameras (a known s, R, t plus
noise), and the whole step on a constructed OUT folder (COLMAP images.bin / images.txt written
here, a synthetic dataset's transforms and a binary PLY): the mesh lands where the known
similarity puts it, and bad registrations are refused without a gt_mesh.ply."""
import importlib.util
import json
import os
import struct
import sys
import tempfile

import numpy as np

src = os.environ.get("MGS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
spec = importlib.util.spec_from_file_location("colmap_align", os.path.join(src, "scripts", "colmap_align.py"))
ca = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ca)

failures = 0


def check(cond, what):
    global failures
    if not cond:
        failures += 1
        print("FAIL:", what)


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return ca.qvec_to_rot(q)


def rot_to_qvec(R):
    # Shepperd's method via the largest diagonal term
    w = np.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = np.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2
    y = np.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2
    z = np.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2
    i = int(np.argmax([w, x, y, z]))
    if i == 0:
        q = [w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)]
    elif i == 1:
        q = [(R[2, 1] - R[1, 2]) / (4 * x), x, (R[0, 1] + R[1, 0]) / (4 * x), (R[0, 2] + R[2, 0]) / (4 * x)]
    elif i == 2:
        q = [(R[0, 2] - R[2, 0]) / (4 * y), (R[0, 1] + R[1, 0]) / (4 * y), y, (R[1, 2] + R[2, 1]) / (4 * y)]
    else:
        q = [(R[1, 0] - R[0, 1]) / (4 * z), (R[0, 2] + R[2, 0]) / (4 * z), (R[1, 2] + R[2, 1]) / (4 * z), z]
    return np.array(q)


def hemisphere(n, radius, rng):
    d = rng.normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.2
    return radius * d / np.linalg.norm(d, axis=1, keepdims=True)


rng = np.random.default_rng(7)

# 1. The fit alone: exact data gives the similarity back; noise of 0.1 % of the radius keeps
#    it close; a mirrored target still gives a rotation (det +1), never a reflection.
src_pts = hemisphere(40, 4.0, rng)
s0, R0, t0 = 0.37, random_rotation(rng), np.array([3.0, -2.0, 11.0])
dst = s0 * src_pts @ R0.T + t0
s, R, t = ca.umeyama(src_pts, dst)
check(abs(s - s0) < 1e-9 and np.abs(R - R0).max() < 1e-9 and np.abs(t - t0).max() < 1e-9, f"exact fit: s {s} R err {np.abs(R - R0).max()}")
noisy = dst + rng.normal(scale=0.001 * 4.0 * s0, size=dst.shape)
s, R, t = ca.umeyama(src_pts, noisy)
check(abs(s / s0 - 1) < 5e-3 and np.abs(R - R0).max() < 5e-3, f"noisy fit: s {s} vs {s0}, R err {np.abs(R - R0).max()}")
mirrored = dst * np.array([1, 1, -1])
s, R, t = ca.umeyama(src_pts, mirrored)
check(abs(np.linalg.det(R) - 1) < 1e-9, f"mirrored target gave det R = {np.linalg.det(R)}")
try:
    ca.umeyama(src_pts[:2], dst[:2])
    check(False, "two points accepted")
except ValueError:
    pass


# 2. The step on a folder: COLMAP's world-to-camera poses of the true cameras moved by (s0, R0, t0).
def look_at_c2w(c):
    f = -c / np.linalg.norm(c)  # OpenCV: +z forward, +y down
    up = np.array([0.0, 0.0, 1.0])
    x = np.cross(f, up)
    x /= np.linalg.norm(x)
    y = np.cross(f, x)
    return np.stack([x, y, f], 1)


def make_folder(root, n, noise_rel, text=False, extra_unmatched=1):
    os.makedirs(os.path.join(root, "render"))
    os.makedirs(os.path.join(root, "sparse", "0"))
    cen = hemisphere(n, 4.0, rng)
    frames = {"train": [], "test": []}
    images = []
    for i, c in enumerate(cen):
        split = "test" if i % 8 == 0 else "train"
        Rc = look_at_c2w(c)
        gl = np.eye(4)
        gl[:3, :3] = Rc @ np.diag([1, -1, -1])  # OpenGL axes, as transforms_*.json
        gl[:3, 3] = c
        frames[split].append({"file_path": f"./{split}/r_{i}", "transform_matrix": gl.tolist()})
        # the same camera in the COLMAP frame: centre s R c + t (+ noise), rotation R Rc
        cc = s0 * R0 @ c + t0 + rng.normal(scale=noise_rel * 4.0 * s0, size=3)
        Rw2c = (R0 @ Rc).T
        images.append((i + 1, rot_to_qvec(Rw2c), -Rw2c @ cc, f"{split}_r_{i}.png"))
    for k in range(extra_unmatched):  # registered but not a render (ignored by the match)
        images.append((1000 + k, np.array([1.0, 0, 0, 0]), np.zeros(3), f"other_{k}.png"))
    for split in ("train", "test"):
        with open(os.path.join(root, "render", f"transforms_{split}.json"), "w") as f:
            json.dump({"camera_angle_x": 0.69, "frames": frames[split]}, f)
    if text:
        with open(os.path.join(root, "sparse", "0", "images.txt"), "w") as f:
            f.write("# IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n")
            for iid, q, tt, name in images:
                f.write(f"{iid} {' '.join(repr(float(x)) for x in q)} {' '.join(repr(float(x)) for x in tt)} 1 {name}\n")
                f.write("10.5 20.5 -1\n")
    else:
        with open(os.path.join(root, "sparse", "0", "images.bin"), "wb") as f:
            f.write(struct.pack("<Q", len(images)))
            for iid, q, tt, name in images:
                f.write(struct.pack("<I7dI", iid, *q, *tt, 1) + name.encode() + b"\0")
                f.write(struct.pack("<Q", 2) + struct.pack("<ddq", 1.0, 2.0, -1) * 2)
    # a tetrahedron in morsegs' binary PLY layout
    v = np.array([[1, 1, 1], [-1, -1, 1], [-1, 1, -1], [1, -1, -1]], "<f4")
    faces = [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)]
    with open(os.path.join(root, "render", "gt_mesh.ply"), "wb") as f:
        f.write(b"ply\nformat binary_little_endian 1.0\ncomment written by morsegs\nelement vertex 4\n"
                b"property float x\nproperty float y\nproperty float z\nelement face 4\n"
                b"property list uchar int vertex_indices\nend_header\n")
        f.write(v.tobytes())
        for fc in faces:
            f.write(struct.pack("<B3i", 3, *fc))
    return v


with tempfile.TemporaryDirectory() as tmp:
    for text in (False, True):
        root = os.path.join(tmp, f"ok_{int(text)}")
        v = make_folder(root, 24, 0.001, text=text)
        ok, lines = ca.align(root, 0.02)
        check(ok, f"good registration refused ({'txt' if text else 'bin'}): {lines}")
        check(any("24 of 25 registered images matched" in l for l in lines), f"match count: {lines}")
        # noise sigma 0.1 % of the radius per axis: an RMS of about sqrt(3) x 0.1 % (less the fit's freedom)
        rel = [float(l.split(" = ")[1].split(" %")[0]) for l in lines if "RMS camera-centre residual" in l]
        check(len(rel) == 1 and 0.12 < rel[0] < 0.2, f"reported residual {rel} % (expected about 0.16 %)")
        out = os.path.join(root, "gt_mesh.ply")
        if ok and os.path.exists(out):
            _, moved, fbytes = ca.read_ply_mesh(out)
            want = s0 * v.astype(float) @ R0.T + t0
            err = np.abs(moved - want).max()
            check(err < 0.02 * s0 * 4.0, f"moved mesh off by {err} ({'txt' if text else 'bin'})")
            check(len(fbytes) == 4 * 13, "faces not copied")
        else:
            check(False, "no gt_mesh.ply written")
    # a registration 5 % off: refused, and the gt_mesh.ply of an earlier fit is removed
    root = os.path.join(tmp, "bad")
    make_folder(root, 24, 0.05)
    open(os.path.join(root, "gt_mesh.ply"), "w").write("stale")
    ok, lines = ca.align(root, 0.02)
    check(not ok and not os.path.exists(os.path.join(root, "gt_mesh.ply")), f"5 % residual accepted: {lines}")
    check(any("refused" in l and "residual" in l for l in lines), f"no reason given: {lines}")
    # two registered cameras: refused
    root = os.path.join(tmp, "two")
    make_folder(root, 2, 0.0)
    ok, lines = ca.align(root, 0.02)
    check(not ok and not os.path.exists(os.path.join(root, "gt_mesh.ply")) and any("fewer than 3" in l for l in lines),
          f"two cameras accepted: {lines}")
    # the command: exit 1 and a message naming the folder on a missing model
    root = os.path.join(tmp, "empty")
    os.makedirs(root)
    check(ca.main(["colmap_align.py", root]) == 1, "missing model not an error")

print("test_colmap_align:", "FAILED" if failures else "ok")
sys.exit(1 if failures else 0)
