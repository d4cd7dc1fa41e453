/* `morsegs scene MESH -o DIR` / `morsegs scene --builtin NAME -o DIR`: render a
 * NeRF-synthetic ground-truth dataset of a mesh with Embree (render/mgs_scene.h). */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/mgs_cli.h"
#include "assets/mgs_assets.h"
#include "core/mgs_log.h"
#include "core/mgs_math.h"
#include "render/mgs_scene.h"

static void scene_usage(FILE *f) {
  fprintf(f,
          "usage: morsegs scene MESH -o DIR [options]\n"
          "       morsegs scene --builtin NAME -o DIR [options]\n"
          "       morsegs scene --list\n"
          "Renders a NeRF-synthetic dataset (train/ and test/ RGBA PNGs, transforms_{train,test}.json,\n"
          "gt_mesh.ply normalized to [-1,1]^3, points3d.ply initial points, scene.json) with Embree.\n"
          "MESH: OBJ, PLY, OFF (anything assimp reads). Must be closed and manifold unless --allow-open.\n"
          "Appearance: the mesh's own diffuse texture (its material's, through its UVs; path relative to\n"
          "MESH; TGA/PNG/JPEG) where it has one, else its vertex colours, else a procedural 3D texture;\n"
          "a texture that cannot be read is a warning and falls back. scene.json records the choice.\n\n"
          "options:\n"
          "  -o, --output DIR      output folder (must not exist, be empty, or hold a dataset with --force)\n"
          "      --builtin NAME    a built-in procedural scene instead of MESH (see --list)\n"
          "      --detail N        finer builtin tessellation (1)\n"
          "      --size N          with --builtin city: N x N blocks of 2 x 2 units (1); the city is not\n"
          "                        normalized, cameras see a few units each (street level and low\n"
          "                        aerial); defaults scale with N^2: 16 N^2 train and 4 N^2 test views,\n"
          "                        10000 N^2 initial points\n"
          "      --list            list the built-in scenes\n"
          "      --views N         training views (60)\n"
          "      --test-views N    test views (20)\n"
          "      --width W         image width (200)\n"
          "      --height H        image height (200)\n"
          "      --fov DEG         horizontal field of view in degrees (39.6)\n"
          "      --radius R        camera distance (default: fit the object)\n"
          "      --hemisphere      cameras on the upper hemisphere only (default: full sphere)\n"
          "      --specular        add a Blinn-Phong highlight (view-dependent colour)\n"
          "      --texture-scale F finer (F > 1) or coarser procedural texture (1); F = 4 gives SIFT\n"
          "                        enough corners for COLMAP (scripts/colmap_scene.sh)\n"
          "      --procedural-texture  the procedural texture even where the mesh has its own texture\n"
          "                        or vertex colours (e.g. a texture with too little detail for SIFT)\n"
          "      --spp N           N x N antialiasing samples per pixel (4)\n"
          "      --white, --black  background colour under transparent pixels (white)\n"
          "      --init MODE       initial points: surface (noisy surface samples, SfM stand-in),\n"
          "                        random (uniform in [-1.3,1.3]^3 as the reference), none (surface)\n"
          "      --init-points N   number of initial points (surface 10000, random 100000)\n"
          "      --init-noise F    surface point noise sigma as a fraction of the extent (0.01)\n"
          "      --seed S          random seed: cameras, sub-pixel jitter, init points (0)\n"
          "      --allow-open      render meshes with boundary or non-manifold edges\n"
          "      --force           replace DIR if it already holds a dataset\n"
          "  -q, --quiet           no progress output\n"
          "  -h, --help            this text\n");
}

static int parse_long(const char *s, long lo, long hi, long *out) {
  char *end;
  errno = 0;
  long v = strtol(s, &end, 10);
  if (errno || end == s || *end || v < lo || v > hi) return 0;
  *out = v;
  return 1;
}

static int parse_double(const char *s, double *out) {
  char *end;
  errno = 0;
  double v = strtod(s, &end);
  if (errno || end == s || *end || !isfinite(v)) return 0;
  *out = v;
  return 1;
}

static void list_builtins(void) {
  for (size_t i = 0; i < mgs_assets_builtin_count(); i++)
    printf("%-8s %s\n", mgs_assets_builtin_name(i), mgs_assets_builtin_description(i));
  printf("%-8s %s\n", "city", "N x N blocks of the above and towers on a ground slab (--size N), world units");
}

enum { OPT_BUILTIN = 256, OPT_DETAIL, OPT_LIST, OPT_VIEWS, OPT_TEST_VIEWS, OPT_WIDTH, OPT_HEIGHT, OPT_FOV, OPT_RADIUS,
       OPT_HEMI, OPT_SPEC, OPT_TEXTURE, OPT_SPP, OPT_WHITE, OPT_BLACK, OPT_INIT, OPT_INIT_POINTS, OPT_INIT_NOISE, OPT_SEED,
       OPT_ALLOW_OPEN, OPT_FORCE, OPT_SIZE, OPT_PROCEDURAL };

int mgs_cmd_scene(int argc, char **argv) {
  static const struct option longopts[] = {
      {"output", required_argument, 0, 'o'}, {"builtin", required_argument, 0, OPT_BUILTIN},
      {"detail", required_argument, 0, OPT_DETAIL}, {"list", no_argument, 0, OPT_LIST},
      {"size", required_argument, 0, OPT_SIZE},
      {"views", required_argument, 0, OPT_VIEWS}, {"test-views", required_argument, 0, OPT_TEST_VIEWS},
      {"width", required_argument, 0, OPT_WIDTH}, {"height", required_argument, 0, OPT_HEIGHT},
      {"fov", required_argument, 0, OPT_FOV}, {"radius", required_argument, 0, OPT_RADIUS},
      {"hemisphere", no_argument, 0, OPT_HEMI}, {"specular", no_argument, 0, OPT_SPEC},
      {"texture-scale", required_argument, 0, OPT_TEXTURE}, {"procedural-texture", no_argument, 0, OPT_PROCEDURAL},
      {"spp", required_argument, 0, OPT_SPP}, {"white", no_argument, 0, OPT_WHITE}, {"black", no_argument, 0, OPT_BLACK},
      {"init", required_argument, 0, OPT_INIT}, {"init-points", required_argument, 0, OPT_INIT_POINTS},
      {"init-noise", required_argument, 0, OPT_INIT_NOISE}, {"seed", required_argument, 0, OPT_SEED},
      {"allow-open", no_argument, 0, OPT_ALLOW_OPEN}, {"force", no_argument, 0, OPT_FORCE},
      {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  const char *out_dir = NULL, *builtin = NULL;
  long detail = 1, city = 0;
  int list = 0, views_set = 0, test_set = 0;
  optind = 1;
  opterr = 0;
  int c, li = -1;
  while ((li = -1, c = getopt_long(argc, argv, ":o:qh", longopts, &li)) != -1) {
    long lv = 0;
    double dv = 0;
    int ok = 1;
    switch (c) {
    case 'o': out_dir = optarg; break;
    case 'q': o.quiet = 1; break;
    case 'h': scene_usage(stdout); return 0;
    case OPT_BUILTIN: builtin = optarg; break;
    case OPT_DETAIL: ok = parse_long(optarg, 1, 16, &detail); break;
    case OPT_LIST: list = 1; break;
    case OPT_SIZE: ok = parse_long(optarg, 1, 64, &city); break;
    case OPT_VIEWS: ok = parse_long(optarg, 1, 100000, &lv); o.n_train = (int)lv; views_set = 1; break;
    case OPT_TEST_VIEWS: ok = parse_long(optarg, 0, 100000, &lv); o.n_test = (int)lv; test_set = 1; break;
    case OPT_WIDTH: ok = parse_long(optarg, 1, 16384, &lv); o.width = (int)lv; break;
    case OPT_HEIGHT: ok = parse_long(optarg, 1, 16384, &lv); o.height = (int)lv; break;
    case OPT_FOV: ok = parse_double(optarg, &dv) && dv > 1 && dv < 170; o.fovx = dv * MGS_PI / 180.0; break;
    case OPT_RADIUS: ok = parse_double(optarg, &dv) && dv > 0; o.radius = dv; break;
    case OPT_HEMI: o.hemisphere = 1; break;
    case OPT_SPEC: o.specular = 1; break;
    case OPT_TEXTURE: ok = parse_double(optarg, &dv) && dv > 0 && dv <= 1000; o.texture_scale = dv; break;
    case OPT_PROCEDURAL: o.procedural_texture = 1; break;
    case OPT_SPP: ok = parse_long(optarg, 1, 16, &lv); o.spp = (int)lv; break;
    case OPT_WHITE: o.white_background = 1; break;
    case OPT_BLACK: o.white_background = 0; break;
    case OPT_INIT:
      if (!strcmp(optarg, "surface")) o.init = MGS_SCENE_INIT_SURFACE;
      else if (!strcmp(optarg, "random")) o.init = MGS_SCENE_INIT_RANDOM;
      else if (!strcmp(optarg, "none")) o.init = MGS_SCENE_INIT_NONE;
      else ok = 0;
      break;
    case OPT_INIT_POINTS: ok = parse_long(optarg, 1, 50000000, &lv); o.init_points = (size_t)lv; break;
    case OPT_INIT_NOISE: ok = parse_double(optarg, &dv) && dv >= 0 && dv < 1; o.init_noise = dv; break;
    case OPT_SEED: {
      char *end;
      errno = 0;
      unsigned long long s = strtoull(optarg, &end, 10);
      ok = !errno && end != optarg && !*end && optarg[0] != '-';
      o.seed = (uint64_t)s;
      break;
    }
    case OPT_ALLOW_OPEN: o.allow_open = 1; break;
    case OPT_FORCE: o.force = 1; break;
    case ':': fprintf(stderr, "morsegs scene: option %s needs a value\n", argv[optind - 1]); scene_usage(stderr); return 2;
    default: fprintf(stderr, "morsegs scene: unknown option %s\n", argv[optind - 1]); scene_usage(stderr); return 2;
    }
    if (!ok) {
      /* argv[optind - 1] is the value itself when it came as a separate argument */
      fprintf(stderr, "morsegs scene: bad value '%s' for --%s\n", optarg, li >= 0 ? longopts[li].name : "?");
      return 2;
    }
  }
  if (list) { list_builtins(); return 0; }
  const char *mesh_path = optind < argc ? argv[optind] : NULL;
  if (optind + 1 < argc) { fprintf(stderr, "morsegs scene: unexpected argument '%s'\n", argv[optind + 1]); return 2; }
  if (!!mesh_path == !!builtin) {
    fprintf(stderr, "morsegs scene: give exactly one of MESH or --builtin NAME\n");
    scene_usage(stderr);
    return 2;
  }
  if (!out_dir) { fprintf(stderr, "morsegs scene: -o DIR is required\n"); return 2; }
  int is_city = builtin && !strcmp(builtin, "city");
  if (city && !is_city) { fprintf(stderr, "morsegs scene: --size is for --builtin city only\n"); return 2; }
  if (is_city) {
    if (!city) city = 1;
    o.city_size = (int)city;
    if (!views_set) o.n_train = (int)(16 * city * city);
    if (!test_set) o.n_test = (int)(4 * city * city);
    if (!o.init_points && o.init != MGS_SCENE_INIT_RANDOM) o.init_points = (size_t)(10000 * city * city);
  }

  mgs_error err;
  mgs_error_clear(&err);
  mgs_mesh *mesh = NULL;
  mgs_status s = is_city ? mgs_assets_city((int)city, (int)detail, &mesh, &err)
                 : builtin ? mgs_assets_builtin_detail(builtin, (int)detail, &mesh, &err) : mgs_mesh_read(mesh_path, &mesh, &err);
  if (s != MGS_OK) {
    if (builtin && s == MGS_ERR_ARG) { fprintf(stderr, "morsegs scene: %s\n", err.msg); return 2; } /* unknown name */
    return mgs_cli_fail("scene", &err);
  }
  char label[512];
  if (is_city) snprintf(label, sizeof label, "builtin:city:%ld", city);
  else snprintf(label, sizeof label, "%s%s", builtin ? "builtin:" : "", builtin ? builtin : mesh_path);
  o.mesh_name = label;
  mgs_scene_stats st;
  s = mgs_scene_render_dataset_stats(mesh, &o, out_dir, &st, &err);
  mgs_mesh_destroy(mesh);
  if (s != MGS_OK) return mgs_cli_fail("scene", &err);
  static const char *init_names[] = {"none", "random", "surface"};
  printf("wrote %s: %d train + %d test views at %dx%d (%s), transforms_train.json, transforms_test.json,\n"
         "  gt_mesh.ply (%zu triangles, %s), scene.json",
         out_dir, o.n_train, o.n_test, o.width, o.height,
         is_city ? "city rig" : (o.hemisphere ? "upper hemisphere" : "full sphere"), st.triangles,
         is_city ? "world units" : "normalized to [-1,1]^3");
  if (o.init != MGS_SCENE_INIT_NONE)
    printf(", points3d.ply (%zu %s points)", o.init_points ? o.init_points : (o.init == MGS_SCENE_INIT_RANDOM ? 100000 : 10000), init_names[o.init]);
  printf("\n  appearance: %s", st.appearance ? st.appearance : "procedural");
  printf("\n  %.2f s (%.2f s ray casting, %.3g Mrays/s)\n", st.total_seconds, st.render_seconds,
         st.render_seconds > 0 ? st.rays / st.render_seconds * 1e-6 : 0.0);
  return 0;
}
