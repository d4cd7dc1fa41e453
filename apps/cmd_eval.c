/* morsegs eval RUN: PSNR and SSIM on the test views (renders clamped to [0,1], as the
 * reference's metrics.py), Gaussian count and training time; RUN/results.json (in the
 * reference's "ours_N" layout plus our fields), a readable table, and side-by-side PNGs
 * render | ground truth | error (5x absolute error) in RUN/eval/. Geometry metrics against
 * a ground-truth mesh come from the mgs_eval_geometry hook (measure/mgs_eval_geometry.h). */
#include <getopt.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "apps/mgs_cli.h"
#include "measure/mgs_depth_fusion.h"
#include "measure/mgs_eval_geometry.h"
#include "core/mgs_core.h"
#include "render/mgs_loss.h"
#include "render/mgs_raster.h"
#include "train/mgs_train.h"

static void usage(FILE *f) {
  fprintf(f,
    "usage: morsegs eval RUN [options]\n"
    "       morsegs eval MODEL --data DATASET -o RUN [--background white|black] [--downscale N] [--images DIR] [options]\n"
    "  MODEL: a model trained elsewhere, in the dataset's frame (the reference's output folder or\n"
    "  .ply, 2DGS, SuperSplat's .compressed.ply, .splat, .spz, .sog or a SOG meta.json, .ksplat), first\n"
    "  made the run folder RUN (point_cloud/iteration_0, the dataset's cameras.json, cfg_args; RUN must\n"
    "  not exist or be empty, nor lie in the dataset), then evaluated as one;\n"
    "  --background: the dataset's default (white for NeRF-synthetic) unless given;\n"
    "  --downscale N: the images at 1/N size, as the model was trained (the reference's --resolution N)\n"
    "  --images DIR: a COLMAP dataset's image folder the model was trained on (the reference's -i, e.g. images_4)\n"
    "      --iteration N      which point_cloud/iteration_N (default: the latest)\n"
    "      --split S          test (default), val or train\n"
    "      --mesh GT          ground-truth mesh for geometry metrics (default: the dataset's gt_mesh.ply): the\n"
    "                         alpha-field's surface and the depth-fused one (morsegs vdb RUN)\n"
    "      --no-images        do not write the side-by-side PNGs\n"
    "      --max-views N      evaluate at most N views (evenly spaced)\n"
    "      --depth median|expected, --fuse-voxel F, --trunc F, --trunc-back F, --trunc-thin F, --min-weight W, --carve,\n"
    "      --mask-carve PX|off\n"
    "                         the depth fusion's settings (as morsegs vdb: footprints of the views)\n"
    "      --fused-only       geometry of the depth-fused surface only (not the alpha-field's)\n"
    "      --no-geometry      image metrics only (as the reference's metrics.py): no surfaces, no Chamfer\n"
    "  With RUN/mesh/sugar.ply (morsegs vdb RUN --sugar-mesh) its geometry is reported too (geometry.sugar).\n");
}

static double read_train_seconds(const char *run, int *iterations) {
  char *p = mgs_path_join(run, "train_stats.json");
  char *text = NULL;
  size_t n = 0;
  double s = -1;
  if (p && mgs_read_file(p, &text, &n, NULL) == MGS_OK) {
    cJSON *j = cJSON_Parse(text);
    cJSON *t = cJSON_GetObjectItem(j, "train_seconds"), *it = cJSON_GetObjectItem(j, "iterations");
    if (cJSON_IsNumber(t)) s = t->valuedouble;
    if (cJSON_IsNumber(it) && iterations) *iterations = it->valueint;
    cJSON_Delete(j);
  }
  free(text);
  free(p);
  return s;
}

int mgs_cmd_eval(int argc, char **argv) {
  static const struct option opts[] = {{"iteration", required_argument, 0, 'i'}, {"split", required_argument, 0, 's'},
                                       {"mesh", required_argument, 0, 'm'}, {"no-images", no_argument, 0, 'n'},
                                       {"max-views", required_argument, 0, 'v'}, {"help", no_argument, 0, 'h'},
                                       {"depth", required_argument, 0, 'Z'}, {"fuse-voxel", required_argument, 0, 'x'},
                                       {"trunc", required_argument, 0, 'T'}, {"min-weight", required_argument, 0, 'W'},
                                       {"trunc-back", required_argument, 0, 'B'}, {"trunc-thin", required_argument, 0, 'N'},
                                       {"fused-only", no_argument, 0, 'F'}, {"carve", no_argument, 0, 'C'}, {"mask-carve", required_argument, 0, 1001},
                                       {"data", required_argument, 0, 'D'}, {"output", required_argument, 0, 'o'},
                                       {"background", required_argument, 0, 'G'}, {"downscale", required_argument, 0, 'R'},
                                       {"no-geometry", no_argument, 0, 1002}, {"images", required_argument, 0, 1003}, {0, 0, 0, 0}};
  const char *split_s = "test", *mesh = NULL, *data = NULL, *out = NULL, *image_dir = NULL;
  int white = -1, downscale = 0;
  int iteration = -1, images = 1, max_views = 0, c, fused_only = 0, geometry = 1;
  mgs_fusion_opts fo;
  mgs_fusion_opts_default(&fo);
  optind = 1;
  while ((c = getopt_long(argc, argv, "ho:", opts, NULL)) != -1) {
    switch (c) {
      case 'i': case 'v': {
        char *end;
        long v = strtol(optarg, &end, 10);
        if (!*optarg || *end || v < 0 || v > INT_MAX) { fprintf(stderr, "morsegs eval: --%s needs an integer >= 0\n", c == 'i' ? "iteration" : "max-views"); return 2; }
        if (c == 'i') iteration = (int)v; else max_views = (int)v;
        break;
      }
      case 's': split_s = optarg; break;
      case 'm': mesh = optarg; break;
      case 'n': images = 0; break;
      case 'F': fused_only = 1; break;
      case 1002: geometry = 0; break;
      case 'D': data = optarg; break;
      case 1003: image_dir = optarg; break;
      case 'o': out = optarg; break;
      case 'R': {
        char *end;
        long v = strtol(optarg, &end, 10);
        if (!*optarg || *end || v < 1 || v > 64) { fprintf(stderr, "morsegs eval: --downscale needs an integer 1..64\n"); return 2; }
        downscale = (int)v;
        break;
      }
      case 'G':
        if (!strcmp(optarg, "white")) white = 1;
        else if (!strcmp(optarg, "black")) white = 0;
        else { fprintf(stderr, "morsegs eval: --background '%s': expected white or black\n", optarg); return 2; }
        break;
      case 'C': fo.carve = 1; break;
      case 1001:
        if (!mgs_cli_mask_carve("eval", optarg, &fo.mask_carve_px)) return 2;
        break;
      case 'Z':
        if (!strcmp(optarg, "median")) fo.depth = MGS_DEPTH_MEDIAN;
        else if (!strcmp(optarg, "expected")) fo.depth = MGS_DEPTH_EXPECTED;
        else { fprintf(stderr, "morsegs eval: --depth '%s': expected median or expected\n", optarg); return 2; }
        break;
      case 'x': case 'T': case 'W': case 'B': case 'N': {
        if (c == 'N' && !strcmp(optarg, "0")) { fo.thin_fp = 0; break; }
        char *end;
        double v = strtod(optarg, &end);
        if (!*optarg || *end || !(v > 0) || v > 1e6) { fprintf(stderr, "morsegs eval: '%s' must be a positive number\n", optarg); return 2; }
        if (c == 'x') fo.voxel_fp = v; else if (c == 'T') fo.trunc_fp = v; else if (c == 'B') fo.trunc_back_fp = v; else if (c == 'N') fo.thin_fp = v; else fo.min_weight = (float)v;
        break;
      }
      case 'h': usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (!geometry && (mesh || fused_only)) {
    fprintf(stderr, "morsegs eval: --no-geometry contradicts --%s\n", mesh ? "mesh" : "fused-only");
    return 2;
  }
  if (optind != argc - 1) { fprintf(stderr, "morsegs eval: exactly one RUN folder (or MODEL with --data) is expected\n"); usage(stderr); return 2; }
  if (!data != !out || ((white >= 0 || downscale || image_dir) && !data)) {
    fprintf(stderr, "morsegs eval: --data DATASET and -o RUN go together (a model trained elsewhere); --background, --downscale and --images need them\n");
    return 2;
  }
  if (data) { /* a model trained elsewhere: made a run folder first */
    mgs_error ierr;
    mgs_error_clear(&ierr);
    if (mgs_run_import(argv[optind], data, white, downscale ? downscale : 1, image_dir, out, &ierr) != MGS_OK) { mgs_cli_fail("eval", &ierr); return 1; }
    argv[optind] = (char *)out;
  }
  int split = -1;
  for (int s = 0; s < MGS_SPLIT_COUNT; s++)
    if (!strcmp(split_s, mgs_split_name((mgs_split)s))) split = s;
  if (split < 0) { fprintf(stderr, "morsegs eval: unknown --split '%s' (train, val, test)\n", split_s); return 2; }
  const char *run = argv[optind];
  mgs_error err;
  mgs_error_clear(&err);
  mgs_dataset *ds = NULL;
  mgs_gaussians *g = NULL;
  mgs_raster *r = NULL;
  cJSON *root = NULL;
  float *clamped = NULL;
  char *evdir = NULL;
  int it = 0, rc = 1;
  mgs_status st = mgs_run_open(run, iteration, 0, &ds, &g, &it, &err);
  if (st) goto done;
  size_t nv = ds->n_views[split];
  if (nv == 0) {
    st = mgs_error_set(&err, MGS_ERR_ARG, "%s: the dataset has no %s views%s", ds->root, split_s,
                       !strcmp(split_s, "test") ? " (a run trained with --test-every 0 holds none: --split train evaluates its training views)" : "");
    goto done;
  }
  size_t use = max_views > 0 && (size_t)max_views < nv ? (size_t)max_views : nv;
  evdir = mgs_path_join(run, "eval");
  if (images && (st = mgs_mkdir_p(evdir, &err))) goto done;
  r = mgs_raster_create();
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  memcpy(rs.background, ds->background, sizeof rs.background);
  rs.sh_degree = g->sh_degree;
  root = cJSON_CreateObject();
  cJSON *res = cJSON_CreateObject();
  cJSON *per = cJSON_CreateArray();
  double sp = 0, ss = 0, t0 = mgs_now();
  printf("%-24s %8s %8s\n", "view", "PSNR", "SSIM");
  for (size_t k = 0; k < use; k++) {
    mgs_view *v = &ds->views[split][k * nv / use];
    if ((st = mgs_dataset_load_image(ds, v, &err))) goto done;
    mgs_raster_output ro;
    if ((st = mgs_raster_forward(r, g, &v->cam, &rs, &ro, &err))) goto done;
    size_t W = (size_t)ro.width, H = (size_t)ro.height, np = W * H * 3;
    float *tmp = realloc(clamped, np * sizeof(float));
    if (!tmp) { st = mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); goto done; }
    clamped = tmp;
    for (size_t i = 0; i < np; i++) clamped[i] = mgs_clampf(ro.color[i], 0, 1);
    const float *gt = v->image->data;
    double p = mgs_psnr(clamped, gt, ro.width, ro.height, 3), s = mgs_ssim(clamped, gt, ro.width, ro.height, 3, 0, NULL);
    sp += p; ss += s;
    printf("%-24s %8.3f %8.4f\n", v->name ? v->name : "?", p, s);
    cJSON *e = cJSON_CreateObject();
    cJSON_AddStringToObject(e, "view", v->name ? v->name : "");
    cJSON_AddNumberToObject(e, "PSNR", p);
    cJSON_AddNumberToObject(e, "SSIM", s);
    cJSON_AddItemToArray(per, e);
    if (images) {
      mgs_image *side = mgs_image_create((int)(3 * W), (int)H, 3);
      if (!side) { st = mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); goto done; }
      for (size_t y = 0; y < H; y++)
        for (size_t x = 0; x < W; x++)
          for (int ch = 0; ch < 3; ch++) {
            size_t i = (y * W + x) * 3 + ch;
            float a = clamped[i], b = gt[i];
            side->data[(y * 3 * W + x) * 3 + ch] = a;
            side->data[(y * 3 * W + W + x) * 3 + ch] = b;
            side->data[(y * 3 * W + 2 * W + x) * 3 + ch] = mgs_clampf(5.0f * (a > b ? a - b : b - a), 0, 1);
          }
      char name[512];
      snprintf(name, sizeof name, "%s.png", v->name ? v->name : "view");
      for (char *q = name; *q; q++) if (*q == '/') *q = '_';
      char *path = mgs_path_join(evdir, name);
      st = mgs_image_write(path, side, &err);
      free(path);
      mgs_image_destroy(side);
      if (st) goto done;
    }
    mgs_image_destroy(v->image);
    v->image = NULL;
    mgs_image_destroy(v->alpha);
    v->alpha = NULL;
  }
  int train_iters = -1;
  double train_s = read_train_seconds(run, &train_iters);
  cJSON_AddNumberToObject(res, "PSNR", sp / (double)use);
  cJSON_AddNumberToObject(res, "SSIM", ss / (double)use);
  cJSON_AddNumberToObject(res, "gaussians", (double)g->n);
  cJSON_AddNumberToObject(res, "iteration", it);
  if (train_s >= 0) cJSON_AddNumberToObject(res, "train_seconds", train_s);
  cJSON_AddStringToObject(res, "split", split_s);
  cJSON_AddNumberToObject(res, "views", (double)use);
  cJSON_AddNumberToObject(res, "render_ms_per_view", 1000.0 * (mgs_now() - t0) / (double)use);
  cJSON_AddItemToObject(res, "per_view", per);

  /* geometry against a ground-truth mesh, if there is one and the hook is linked */
  const char *gt_mesh = !geometry ? NULL : mesh ? mesh : ds->mesh_path;
  char table[4096] = "";
  if (gt_mesh) {
    char sub[96];
    snprintf(sub, sizeof sub, "point_cloud/iteration_%d/point_cloud.ply", it);
    char *ply = mgs_path_join(run, sub);
    cJSON *geo = cJSON_CreateObject();
    int grc = fused_only ? 0 : mgs_eval_geometry(ply, gt_mesh, geo, table, sizeof table);
    free(ply);
    if (grc == 0) {
      /* the depth-fused surface beside the α-field's (geometry.fused) */
      cJSON *fused = cJSON_CreateObject();
      size_t used = strlen(table);
      fo.iteration = it;
      if (mgs_eval_geometry_fused(run, &fo, gt_mesh, fused, table + used, sizeof table - used) == 0)
        cJSON_AddItemToObject(geo, "fused", fused);
      else {
        cJSON_Delete(fused);
        table[used] = 0;
        fprintf(stderr, "morsegs eval: note: the depth-fused surface's geometry skipped (the fusion failed)\n");
      }
      /* SuGaR's mesh when `morsegs vdb RUN --sugar-mesh` wrote one (geometry.sugar) */
      char *sugar_mesh = mgs_path_join(run, "mesh/sugar.ply");
      if (sugar_mesh && mgs_path_exists(sugar_mesh)) {
        cJSON *sg = cJSON_CreateObject();
        used = strlen(table);
        if (mgs_eval_geometry_mesh(sugar_mesh, gt_mesh, sg, table + used, sizeof table - used) == 0)
          cJSON_AddItemToObject(geo, "sugar", sg);
        else {
          cJSON_Delete(sg);
          table[used] = 0;
        }
      }
      free(sugar_mesh);
      cJSON_AddItemToObject(res, "geometry", geo);
    } else {
      cJSON_Delete(geo);
      table[0] = 0;
      fprintf(stderr, "morsegs eval: note: geometry metrics against %s skipped (the geometry evaluation failed)\n",
              gt_mesh);
    }
  }
  char key[64];
  snprintf(key, sizeof key, "ours_%d", it);
  cJSON_AddItemToObject(root, key, res);
  char *text = cJSON_Print(root);
  char *rpath = mgs_path_join(run, "results.json");
  st = text && rpath ? mgs_write_file_atomic(rpath, text, strlen(text), &err) : mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory");
  free(text);
  free(rpath);
  if (st) goto done;
  printf("\n%s, iteration %d, %s split (%zu views)\n", run, it, split_s, use);
  printf("  %-22s %10.3f dB\n", "PSNR", sp / (double)use);
  printf("  %-22s %10.4f\n", "SSIM", ss / (double)use);
  printf("  %-22s %10zu\n", "Gaussians", g->n);
  if (train_s >= 0) printf("  %-22s %10.1f s (%d iterations)\n", "training time", train_s, train_iters);
  if (table[0]) printf("%s%s", table, table[strlen(table) - 1] == '\n' ? "" : "\n");
  printf("  results: %s/results.json%s%s\n", run, images ? ", side-by-side: " : "", images ? evdir : "");
  rc = 0;
done:
  if (rc) mgs_cli_fail("eval", &err);
  cJSON_Delete(root);
  free(clamped);
  free(evdir);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  mgs_dataset_destroy(ds);
  return rc;
}
