#!/usr/bin/env bash
# scripts/colmap_scene.sh MESH OUT — a real COLMAP dataset from a mesh, for `morsegs train OUT`.
#
# Renders MESH with `morsegs scene` (textured, black background), then runs COLMAP's own
# structure-from-motion on the renders, knowing nothing of the true cameras: SIFT on the
# CPU, exhaustive matching, incremental mapper, and image_undistorter (the steps of the
# reference 3DGS's convert.py). The result is the standard layout the COLMAP loader reads:
#
#   OUT/images/*.png               undistorted RGB images (black background)
#   OUT/sparse/0/{cameras,images,points3D}.bin   PINHOLE cameras, poses, SfM points
#   OUT/render/                    the synthetic dataset the images came from (its GT mesh
#                                  and cameras are in the normalized frame, NOT the SfM frame)
#   OUT/distorted/                 COLMAP's database and the distorted model (OPENCV camera)
#   OUT/colmap.log                 every COLMAP command's output
#   OUT/model_stats.txt            `colmap model_analyzer` of OUT/sparse/0, then the GT alignment
#   OUT/gt_mesh.ply                OUT/render/gt_mesh.ply moved into COLMAP's frame by the
#                                  similarity (Umeyama) from the true camera centres to the
#                                  registered ones (scripts/colmap_align.py), so `morsegs eval`
#                                  measures Chamfer / F-score in the trained model's frame; not
#                                  written (a warning, exit 0: the folder still trains) with fewer
#                                  than 3 registered cameras or an RMS residual above MAX_REL
#                                  (default 0.02) of the camera radius
#
# The loader holds out every 8th image (sorted by name) as the test split.
#
# Environment (defaults in brackets):
#   MORSEGS   the CLI [build/apps/morsegs of this checkout]
#   VIEWS     images rendered in total, train + test of the render merged [48]
#   SIZE      image width = height in pixels [300]
#   SCENE_ARGS  extra `morsegs scene` flags [--texture-scale 4 --hemisphere. Texture: at the
#             default scale the procedural texture is smooth and SIFT finds ~80 features a
#             view, too few for the mapper; at 4, ~550. Hemisphere: on the hinge (a plate),
#             views of the two faces share almost no features, so a full sphere of 64 views
#             registered only the 24 seeing the upper face]
#   CAMERA    camera model COLMAP estimates before undistortion [OPENCV]
#   INTRINSICS  known: COLMAP starts from the renders' true focal length and principal point
#             (a calibrated camera; it still refines them and estimates every pose and point);
#             estimate: no prior (COLMAP guesses 1.2 x image size) [known]. On the hinge
#             both work with the hemisphere views (42 / 43 of 48 registered); on a full
#             sphere neither did (the plate makes most pairs homography-only,
#             PLANAR_OR_PANORAMIC, and its two faces share no features).
#   THREADS   COLMAP threads [1]
#   SIFT_ARGS extra feature_extractor flags [none]
#   MAX_REL   the GT alignment's largest accepted RMS camera-centre residual, as a fraction
#             of the camera radius [0.02]
#   MIN_TRACK_LEN  when set, `colmap point_filtering --min_track_len N` on the final model
#             [unset: COLMAP's output as convert.py leaves it]. Two-view points include a few
#             far outliers (on the hinge, 7 of 1840 points lie 2-20x the object's radius
#             away), which stretch the points' bounding box; see docs/notes/colmap.md
#
# Needs the Debian package `colmap` (3.8 in bookworm; CPU only here: *.use_gpu 0),
# oiiotool (openimageio-tools) and python3-numpy (the alignment). Not part of the test suite
# (the alignment's math is: tests/scene/test_colmap_align.py).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
die() { echo "colmap_scene.sh: $*" >&2; exit 1; }

[ $# -eq 2 ] || die "usage: scripts/colmap_scene.sh MESH OUT"
mesh=$1; out=$2
[ -f "$mesh" ] || die "$mesh: mesh file not found"
command -v colmap >/dev/null || die "colmap not found: install it (apt-get install colmap)"
command -v oiiotool >/dev/null || die "oiiotool not found: install openimageio-tools"
MORSEGS=${MORSEGS:-$here/build/apps/morsegs}
[ -x "$MORSEGS" ] || die "$MORSEGS: not built (scripts/build.sh build, or set MORSEGS)"
SIFT_ARGS=${SIFT_ARGS:-}; SCENE_ARGS=${SCENE_ARGS---texture-scale 4 --hemisphere}
INTRINSICS=${INTRINSICS:-known}
case $INTRINSICS in known|estimate) ;; *) die "INTRINSICS must be known or estimate (got $INTRINSICS)" ;; esac
VIEWS=${VIEWS:-48}; SIZE=${SIZE:-300}; CAMERA=${CAMERA:-OPENCV}; THREADS=${THREADS:-1}
if [ -e "$out" ] && [ -n "$(ls -A "$out" 2>/dev/null)" ]; then die "$out: exists and is not empty"; fi
mkdir -p "$out"
out=$(cd "$out" && pwd)
log=$out/colmap.log
: > "$log"
export QT_QPA_PLATFORM=offscreen # COLMAP links Qt; no display is needed for these commands

# 1. Renders: the scene's train and test views are merged; the loader makes its own split.
test_views=$((VIEWS / 8)); [ "$test_views" -ge 1 ] || test_views=1
# shellcheck disable=SC2086
"$MORSEGS" scene "$mesh" -o "$out/render" --views $((VIEWS - test_views)) --test-views "$test_views" \
  --width "$SIZE" --height "$SIZE" --black -q $SCENE_ARGS
mkdir -p "$out/input"
for split in train test; do
  for f in "$out/render/$split"/*.png; do
    # RGBA with straight alpha -> RGB over black (SIFT and COLMAP ignore alpha)
    oiiotool "$f" --premult --ch R,G,B -o "$out/input/${split}_$(basename "$f")"
  done
done

# 2. COLMAP: features, matches, incremental SfM.
cam_params=()
case $INTRINSICS in
  known)
    ax=$(sed -n 's/.*"camera_angle_x"[[:space:]]*:[[:space:]]*\([0-9.eE+-]*\).*/\1/p' "$out/render/transforms_train.json" | head -1)
    [ -n "$ax" ] || die "$out/render/transforms_train.json: no camera_angle_x"
    p=$(awk -v a="$ax" -v w="$SIZE" -v m="$CAMERA" 'BEGIN { f = 0.5 * w / (sin(a / 2) / cos(a / 2)); c = w / 2;
      if (m == "SIMPLE_PINHOLE") printf "%.6f,%g,%g", f, c, c; else if (m == "PINHOLE") printf "%.6f,%.6f,%g,%g", f, f, c, c;
      else if (m == "SIMPLE_RADIAL") printf "%.6f,%g,%g,0", f, c, c; else if (m == "OPENCV") printf "%.6f,%.6f,%g,%g,0,0,0,0", f, f, c, c;
      else exit 1 }') || die "INTRINSICS=known supports CAMERA=SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, OPENCV (got $CAMERA)"
    cam_params=(--ImageReader.camera_params "$p") ;;
  estimate) ;;
  *) die "INTRINSICS must be known or estimate (got $INTRINSICS)" ;;
esac
run() { echo "+ colmap $*" >> "$log"; colmap "$@" >> "$log" 2>&1 || die "colmap $1 failed (see $log)"; }
mkdir -p "$out/distorted/sparse"
db=$out/distorted/database.db
# shellcheck disable=SC2086
run feature_extractor --database_path "$db" --image_path "$out/input" \
  --ImageReader.single_camera 1 --ImageReader.camera_model "$CAMERA" "${cam_params[@]}" \
  --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads "$THREADS" $SIFT_ARGS
run exhaustive_matcher --database_path "$db" --SiftMatching.use_gpu 0 --SiftMatching.num_threads "$THREADS"
run mapper --database_path "$db" --image_path "$out/input" --output_path "$out/distorted/sparse" \
  --Mapper.num_threads "$THREADS" --Mapper.ba_global_function_tolerance=0.000001

# The mapper writes one model per connected component (0, 1, ...): keep the one with the
# most registered images.
best=""; best_n=-1
for m in "$out/distorted/sparse"/*/; do
  [ -f "$m/images.bin" ] || continue
  n=$(colmap model_analyzer --path "$m" 2>&1 | sed -n 's/.*Registered images: *\([0-9]*\).*/\1/p' | head -1)
  [ "${n:-0}" -gt "$best_n" ] && { best=$m; best_n=${n:-0}; }
done
[ -n "$best" ] || die "the mapper reconstructed nothing (too few features or matches? see $log; try more VIEWS, a larger SIZE or a higher --texture-scale in SCENE_ARGS)"

# 3. Undistortion to PINHOLE (the loader reads only PINHOLE/SIMPLE_PINHOLE), as convert.py.
run image_undistorter --image_path "$out/input" --input_path "$best" --output_path "$out" --output_type COLMAP
mkdir -p "$out/sparse/0"
for f in "$out/sparse"/*; do [ "$f" = "$out/sparse/0" ] || mv "$f" "$out/sparse/0/"; done
rm -rf "$out/stereo" "$out"/run-colmap-*.sh
if [ -n "${MIN_TRACK_LEN:-}" ]; then
  run point_filtering --input_path "$out/sparse/0" --output_path "$out/sparse/0" --min_track_len "$MIN_TRACK_LEN"
fi
colmap model_analyzer --path "$out/sparse/0" > "$out/model_stats.txt" 2>&1
echo "colmap_scene.sh: $out: $(sed -n 's/.*\(Registered images: *[0-9]*\).*/\1/p' "$out/model_stats.txt") of $VIEWS," \
  "$(sed -n 's/.*\(Points: *[0-9]*\).*/\1/p' "$out/model_stats.txt"), $(sed -n 's/.*\(Mean reprojection error: *[0-9.]*px\).*/\1/p' "$out/model_stats.txt")"
# 4. The GT mesh in COLMAP's frame (the loader reports OUT/gt_mesh.ply as the dataset's mesh).
if ! MAX_REL=${MAX_REL:-0.02} /usr/bin/python3 "$here/scripts/colmap_align.py" "$out"; then
  echo "colmap_scene.sh: $out: no gt_mesh.ply (see the GT alignment lines above and in $out/model_stats.txt):" \
    "training and image metrics work, geometry metrics need a mesh (eval --mesh)" >&2
fi
