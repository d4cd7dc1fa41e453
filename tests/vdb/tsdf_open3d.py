"""Fuses the depth maps test_vdb_tsdf wrote with Open3D's ScalableTSDFVolume (Debian's
python3-open3d), extracts its mesh and reports the mesh-to-mesh Chamfer distance to the
mesh of morsegs' own fusion of the same maps. Usage: tsdf_open3d.py DIR (DIR/views.txt,
DIR/depth_K.f32, DIR/ours.ply). Prints 'chamfer C accuracy A completeness B voxel H'.

views.txt: 'voxel H trunc T' then one line per view: 'W H fx fy cx cy' and the 16 numbers
of the world-to-camera matrix (OpenCV, row-major). Pixel centres are at +0.5 in morsegs
and at integers in Open3D: its cx, cy are ours - 0.5."""
import sys
import numpy as np
import open3d as o3d

d = sys.argv[1]
lines = open(f"{d}/views.txt").read().split("\n")
_, h, _, t = lines[0].split()
h, t = float(h), float(t)
vol = o3d.pipelines.integration.ScalableTSDFVolume(
    voxel_length=h, sdf_trunc=t, color_type=o3d.pipelines.integration.TSDFVolumeColorType.NoColor)
k = 0
for line in lines[1:]:
    if not line.strip():
        continue
    v = [float(x) for x in line.split()]
    w, hh, fx, fy, cx, cy = int(v[0]), int(v[1]), v[2], v[3], v[4], v[5]
    w2c = np.array(v[6:22]).reshape(4, 4)
    depth = np.fromfile(f"{d}/depth_{k}.f32", dtype=np.float32).reshape(hh, w)
    color = o3d.geometry.Image(np.zeros((hh, w, 3), dtype=np.uint8))
    rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
        color, o3d.geometry.Image(depth), depth_scale=1.0, depth_trunc=1e6, convert_rgb_to_intensity=False)
    intr = o3d.camera.PinholeCameraIntrinsic(w, hh, fx, fy, cx - 0.5, cy - 0.5)
    vol.integrate(rgbd, intr, w2c)
    k += 1
theirs = vol.extract_triangle_mesh()
o3d.io.write_triangle_mesh(f"{d}/open3d.ply", theirs)
ours = o3d.io.read_triangle_mesh(f"{d}/ours.ply")
if len(theirs.triangles) == 0 or len(ours.triangles) == 0:
    print("empty mesh: open3d", len(theirs.triangles), "ours", len(ours.triangles))
    sys.exit(1)
pa = ours.sample_points_uniformly(number_of_points=100000)
pb = theirs.sample_points_uniformly(number_of_points=100000)
acc = float(np.mean(np.asarray(pa.compute_point_cloud_distance(pb))))
comp = float(np.mean(np.asarray(pb.compute_point_cloud_distance(pa))))
print(f"chamfer {(acc + comp) / 2:.6g} accuracy {acc:.6g} completeness {comp:.6g} voxel {h:.6g} "
      f"triangles ours {len(ours.triangles)} open3d {len(theirs.triangles)}")
