#!/usr/bin/python3
"""scripts/colmap_align.py OUT — the GT mesh of a scripts/colmap_scene.sh folder in COLMAP's frame.

COLMAP's SfM frame is arbitrary (scale, rotation, translation), while OUT/render/ holds the
true cameras and gt_mesh.ply in the renders' normalized frame. This fits the similarity
  colmap_centre ~ s R true_centre + t            (Umeyama 1991: least squares, det R = +1)
from the true camera centres (OUT/render/transforms_{train,test}.json, image `./train/r_N`
= COLMAP image `train_r_N.png`) to the centres of the images COLMAP registered
(OUT/sparse/0/images.bin or .txt: centre = -R(q)^T t), reports the RMS residual relative to
the camera radius (the true centres' mean distance from the origin), appends the figures to
OUT/model_stats.txt, and writes OUT/gt_mesh.ply = s R gt + t, which the COLMAP loader reports
as the dataset's GT mesh (eval's Chamfer / F-score then runs in the trained model's frame).
Refuses (exit 1, no gt_mesh.ply) with fewer than 3 matched cameras or a relative residual above
MAX_REL (environment, default 0.02): a bad registration would give a meaningless Chamfer.

Debian's python3 + numpy only.
"""
import json
import os
import struct
import sys

import numpy as np


def umeyama(src, dst):
    """(s, R, t) minimising sum |dst_i - (s R src_i + t)|^2 with R a rotation (det +1)."""
    src = np.asarray(src, float)
    dst = np.asarray(dst, float)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 3 or src.shape[0] < 3:
        raise ValueError("umeyama: need matching n x 3 point sets with n >= 3")
    mu_s, mu_d = src.mean(0), dst.mean(0)
    xs, xd = src - mu_s, dst - mu_d
    var_s = (xs * xs).sum() / len(src)
    if not var_s > 0:
        raise ValueError("umeyama: the source points coincide")
    cov = xd.T @ xs / len(src)
    U, D, Vt = np.linalg.svd(cov)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1  # the best proper rotation, never a reflection
    R = U @ S @ Vt
    s = float((D * np.diag(S)).sum() / var_s)
    t = mu_d - s * R @ mu_s
    return s, R, t


def qvec_to_rot(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def read_colmap_centres(sparse):
    """{image name: camera centre} of a COLMAP model folder (images.bin or images.txt)."""
    out = {}
    binp, txtp = os.path.join(sparse, "images.bin"), os.path.join(sparse, "images.txt")
    if os.path.exists(binp):
        with open(binp, "rb") as f:
            data = f.read()
        (n,), off = struct.unpack_from("<Q", data, 0), 8
        for _ in range(n):
            vals = struct.unpack_from("<I7dI", data, off)
            off += struct.calcsize("<I7dI")
            end = data.index(b"\0", off)
            name = data[off:end].decode("utf-8")
            off = end + 1
            (npts,) = struct.unpack_from("<Q", data, off)
            off += 8 + npts * 24  # x, y (double) and point3D id (int64) per 2-D point
            q, t = np.array(vals[1:5]), np.array(vals[5:8])
            out[name] = -qvec_to_rot(q / np.linalg.norm(q)).T @ t
    elif os.path.exists(txtp):
        with open(txtp) as f:
            lines = [l for l in f if l.strip() and not l.startswith("#")]
        for l in lines[0::2]:  # each image: a pose line, then its 2-D points line
            p = l.split()
            q, t = np.array([float(x) for x in p[1:5]]), np.array([float(x) for x in p[5:8]])
            out[p[9]] = -qvec_to_rot(q / np.linalg.norm(q)).T @ t
    else:
        raise FileNotFoundError(f"{sparse}: no images.bin or images.txt")
    return out


def read_true_centres(render):
    """{COLMAP image name: true camera centre} from the synthetic dataset's transforms."""
    out = {}
    for split in ("train", "test"):
        p = os.path.join(render, f"transforms_{split}.json")
        if not os.path.exists(p):
            continue
        with open(p) as f:
            frames = json.load(f)["frames"]
        for fr in frames:
            base = os.path.basename(fr["file_path"])
            if not base.endswith(".png"):
                base += ".png"
            out[f"{split}_{base}"] = np.array(fr["transform_matrix"], float)[:3, 3]
    return out


def read_ply_mesh(path):
    """(header lines, vertices n x 3 float32, face bytes) of morsegs' binary PLY."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in header:
        raise ValueError(f"{path}: not a binary little-endian PLY")
    nv = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    props = [l for l in header if l.startswith("property")]
    if props[:3] != ["property float x", "property float y", "property float z"] or \
            props[3:4] != ["property list uchar int vertex_indices"] or len(props) != 4:
        raise ValueError(f"{path}: expected float x, y, z vertices and a uchar/int face list (morsegs' layout)")
    verts = np.frombuffer(data, "<f4", nv * 3, end).reshape(nv, 3)
    return header, verts, data[end + nv * 12:]


def write_ply_mesh(path, header, verts, faces, comment):
    lines = [l for l in header if l != "end_header"]
    lines.insert(2, f"comment {comment}")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(("\n".join(lines) + "\nend_header\n").encode("ascii"))
        f.write(np.ascontiguousarray(verts, "<f4").tobytes())
        f.write(faces)
    os.replace(tmp, path)


def align(out, max_rel=0.02):
    """Fits, reports and writes OUT/gt_mesh.ply; returns (ok, report lines)."""
    colmap = read_colmap_centres(os.path.join(out, "sparse", "0"))
    true = read_true_centres(os.path.join(out, "render"))
    names = sorted(n for n in colmap if n in true)
    target = os.path.join(out, "gt_mesh.ply")
    if os.path.exists(target):
        os.remove(target)  # never leave a mesh from an earlier fit beside a refused one
    lines = [f"GT alignment (scripts/colmap_align.py): {len(names)} of {len(colmap)} registered images matched to true cameras"]
    if len(names) < 3:
        lines.append("GT alignment refused: fewer than 3 registered cameras; no gt_mesh.ply (no geometry metrics)")
        return False, lines
    src = np.array([true[n] for n in names])
    dst = np.array([colmap[n] for n in names])
    s, R, t = umeyama(src, dst)
    res = dst - (s * (R @ src.T).T + t)
    rms = float(np.sqrt((res * res).sum(1).mean())) / s  # in the true (normalized) frame's units
    radius = float(np.linalg.norm(src, axis=1).mean())
    rel = rms / radius
    lines.append(f"GT alignment: scale {s:.6g}, RMS camera-centre residual {rms:.4g} = {100 * rel:.3f} % of the camera radius "
                 f"{radius:.4g} (limit {100 * max_rel:g} %), worst {float(np.linalg.norm(res, axis=1).max()) / s / radius * 100:.3f} %")
    lines.append("GT alignment: colmap = s R true + t, R rows " + "; ".join(" ".join(f"{x:.6f}" for x in r) for r in R) +
                 ", t " + " ".join(f"{x:.6f}" for x in t))
    if not rel <= max_rel:
        lines.append(f"GT alignment refused: residual above {100 * max_rel:g} % of the radius (a bad registration); no gt_mesh.ply")
        return False, lines
    header, verts, faces = read_ply_mesh(os.path.join(out, "render", "gt_mesh.ply"))
    moved = s * (verts.astype(float) @ R.T) + t
    write_ply_mesh(target, header, moved, faces,
                   f"render/gt_mesh.ply in COLMAP's frame (scale {s:.9g}, residual {100 * rel:.3f} % of the camera radius)")
    lines.append(f"GT alignment: wrote {target} ({len(verts)} vertices) in COLMAP's frame")
    return True, lines


def main(argv):
    if len(argv) != 2:
        print("usage: scripts/colmap_align.py OUT", file=sys.stderr)
        return 2
    out = argv[1]
    try:
        max_rel = float(os.environ.get("MAX_REL", "0.02"))
        ok, lines = align(out, max_rel)
    except (OSError, ValueError, KeyError, struct.error, json.JSONDecodeError) as e:
        print(f"colmap_align.py: {out}: {e}", file=sys.stderr)
        return 1
    with open(os.path.join(out, "model_stats.txt"), "a") as f:
        f.write("\n".join(lines) + "\n")
    for l in lines:
        print(l, file=sys.stdout if ok else sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
