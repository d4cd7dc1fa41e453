/* morsegs render RUN --split test -o DIR: renders a trained run's views to PNGs, with the
 * dataset and settings recorded in RUN/cfg_args; --reference-layout writes the reference's
 * render.py folders (SPLIT/ours_N/{renders,gt}/00000.png), which its metrics.py reads. */
#include <dirent.h>
#include <getopt.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/mgs_cli.h"
#include "apps/mgs_render_maps_io.h"
#include "core/mgs_core.h"
#include "render/mgs_raster.h"
#include "train/mgs_train.h"

static void usage(FILE *f) {
  fprintf(f,
    "usage: morsegs render RUN -o DIR [options]\n"
    "       morsegs render RUN --reference-layout [-o DIR]\n"
    "  -o, --output DIR       folder for the PNGs (one per view, named after it)\n"
    "      --reference-layout as the reference's render.py: DIR (default RUN)/SPLIT/ours_N/renders/00000.png\n"
    "                         and gt/00000.png (the dataset's image as trained on), in view order, for its metrics.py\n"
    "      --split S          train, val, test (default) or all\n"
    "      --iteration N      which point_cloud/iteration_N (default: the latest)\n"
    "      --force            write into a non-empty DIR\n"
    "      --depth            also NAME_depth_expected.exr, NAME_depth_median.exr (camera z, 0 = background)\n"
    "                         and NAME_depth.png (colour-mapped median depth, near = red)\n"
    "      --depth-png16 S    depth maps as 16-bit PNGs of depth * S instead of EXR\n"
    "      --normal           also NAME_normal.exr (sum of w n, world space) and NAME_normal.png\n"
    "      --alpha            also NAME_alpha.png (16-bit)\n");
}

static int dir_nonempty(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return 0;
  struct dirent *e;
  int any = 0;
  while ((e = readdir(d)))
    if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) { any = 1; break; }
  closedir(d);
  return any;
}

/* Creates the output folder, refusing one inside the dataset (DATA is never written to). */
static mgs_status make_output(const char *out, const mgs_dataset *ds, mgs_error *err) {
  mgs_status st = mgs_mkdir_p(out, err);
  if (st) return st;
  char abs_out[PATH_MAX], abs_ds[PATH_MAX];
  if (realpath(out, abs_out) && realpath(ds->root, abs_ds) && !strncmp(abs_out, abs_ds, strlen(abs_ds)) &&
      (abs_out[strlen(abs_ds)] == 0 || abs_out[strlen(abs_ds)] == '/'))
    return mgs_error_set(err, MGS_ERR_ARG, "%s: output folder is inside the dataset %s; choose another -o", out, ds->root);
  return MGS_OK;
}

static void raster_settings(const mgs_dataset *ds, const mgs_gaussians *g, mgs_raster_settings *rs) {
  mgs_raster_settings_default(rs);
  memcpy(rs->background, ds->background, sizeof rs->background);
  rs->sh_degree = g->sh_degree;
}

/* One view's colours, clamped to [0, 1] as the reference saves them. */
static mgs_status render_view(mgs_raster *r, const mgs_gaussians *g, const mgs_camera *cam, const mgs_raster_settings *rs,
                              mgs_image **out, mgs_error *err) {
  mgs_raster_output ro;
  mgs_status st = mgs_raster_forward(r, g, cam, rs, &ro, err);
  if (st) return st;
  mgs_image *img = mgs_image_create(ro.width, ro.height, 3);
  if (!img) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  for (size_t k = 0; k < (size_t)ro.width * ro.height * 3; k++) img->data[k] = mgs_clampf(ro.color[k], 0, 1);
  *out = img;
  return MGS_OK;
}

/* The reference's render.py layout under root: SPLIT/ours_IT/renders/%05d.png and
 * gt/%05d.png for the train and test splits asked for. An existing ours_IT is kept unless
 * --force (nothing a user had is overwritten). */
static int reference_layout(const char *run, const char *root, int iteration, int first, int last, int force) {
  mgs_error err;
  mgs_error_clear(&err);
  mgs_dataset *ds = NULL;
  mgs_gaussians *g = NULL;
  mgs_raster *r = NULL;
  mgs_image *img = NULL;
  char *dir = NULL;
  int it = 0, rc = 1;
  size_t written = 0;
  mgs_status st = mgs_run_open(run, iteration, 0, &ds, &g, &it, &err);
  if (st) goto done;
  if ((st = make_output(root, ds, &err))) goto done;
  for (int s = first; s <= last; s++) { /* refuse before writing anything */
    if (s == MGS_SPLIT_VAL || ds->n_views[s] == 0) continue;
    char sub[128];
    snprintf(sub, sizeof sub, "%s/ours_%d", mgs_split_name((mgs_split)s), it);
    free(dir);
    if (!(dir = mgs_path_join(root, sub))) { st = mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); goto done; }
    if (mgs_is_dir(dir) && dir_nonempty(dir) && !force) {
      st = mgs_error_set(&err, MGS_ERR_IO, "%s exists (use --force to write into it)", dir);
      goto done;
    }
  }
  r = mgs_raster_create();
  mgs_raster_settings rs;
  raster_settings(ds, g, &rs);
  for (int s = first; s <= last; s++) {
    if (s == MGS_SPLIT_VAL) continue; /* the reference has train and test only */
    for (size_t i = 0; i < ds->n_views[s]; i++) {
      mgs_view *v = &ds->views[s][i];
      char sub[160];
      static const char *const kind[2] = {"renders", "gt"};
      for (int k = 0; k < 2; k++) {
        snprintf(sub, sizeof sub, "%s/ours_%d/%s", mgs_split_name((mgs_split)s), it, kind[k]);
        free(dir);
        if (!(dir = mgs_path_join(root, sub))) { st = mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); goto done; }
        if (i == 0 && (st = mgs_mkdir_p(dir, &err))) goto done;
        if (k == 0) {
          if ((st = render_view(r, g, &v->cam, &rs, &img, &err))) goto done;
        } else {
          if ((st = mgs_dataset_load_image(ds, v, &err))) goto done;
          img = v->image;
        }
        char name[32], *path;
        snprintf(name, sizeof name, "%05zu.png", i);
        if (!(path = mgs_path_join(dir, name))) { st = mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); goto done; }
        st = mgs_image_write(path, img, &err);
        free(path);
        if (k == 0) mgs_image_destroy(img);
        img = NULL;
        if (st) goto done;
      }
      mgs_image_destroy(v->image); /* one view's image at a time */
      mgs_image_destroy(v->alpha);
      v->image = v->alpha = NULL;
      written++;
    }
  }
  printf("rendered %zu views of %s (iteration %d, %zu Gaussians) into %s/{train,test}/ours_%d/{renders,gt}\n", written, run, it,
         g->n, root, it);
  rc = 0;
done:
  if (rc) mgs_cli_fail("render", &err);
  free(dir);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  mgs_dataset_destroy(ds);
  return rc;
}

int mgs_cmd_render(int argc, char **argv) {
  static const struct option opts[] = {{"output", required_argument, 0, 'o'}, {"split", required_argument, 0, 's'},
                                       {"iteration", required_argument, 0, 'i'}, {"force", no_argument, 0, 'f'},
                                       {"depth", no_argument, 0, 'D'}, {"normal", no_argument, 0, 'N'},
                                       {"alpha", no_argument, 0, 'A'}, {"depth-png16", required_argument, 0, 'P'},
                                       {"reference-layout", no_argument, 0, 'R'}, {"help", no_argument, 0, 'h'},
                                       {0, 0, 0, 0}};
  const char *out = NULL, *split = "test";
  int iteration = -1, force = 0, layout = 0, c;
  mgs_maps_io_opts mo = {0, 0, 0, 0, 1000.0};
  optind = 1;
  while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
    switch (c) {
      case 'o': out = optarg; break;
      case 's': split = optarg; break;
      case 'i': {
        char *end;
        long v = strtol(optarg, &end, 10);
        if (!*optarg || *end || v < 0 || v > INT_MAX) { fprintf(stderr, "morsegs render: --iteration needs an integer >= 0\n"); return 2; }
        iteration = (int)v;
        break;
      }
      case 'f': force = 1; break;
      case 'R': layout = 1; break;
      case 'D': mo.depth = 1; break;
      case 'N': mo.normal = 1; break;
      case 'A': mo.alpha = 1; break;
      case 'P': {
        char *end;
        mo.depth_scale = strtod(optarg, &end);
        if (!*optarg || *end || !(mo.depth_scale > 0) || mo.depth_scale > 1e9) {
          fprintf(stderr, "morsegs render: --depth-png16 needs a positive scale\n");
          return 2;
        }
        mo.png16 = mo.depth = 1;
        break;
      }
      case 'h': usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (optind != argc - 1 || (!out && !layout)) {
    fprintf(stderr, "morsegs render: %s\n", optind == argc - 1 ? "-o DIR is required" : "exactly one RUN folder is expected");
    usage(stderr);
    return 2;
  }
  if (layout && (mo.depth || mo.normal || mo.alpha)) {
    fprintf(stderr, "morsegs render: --reference-layout writes renders and gt only (no --depth, --normal, --alpha)\n");
    return 2;
  }
  if (!out) out = argv[optind];
  int first = -1, last = -1;
  for (int s = 0; s < MGS_SPLIT_COUNT; s++)
    if (!strcmp(split, mgs_split_name((mgs_split)s))) first = last = s;
  if (!strcmp(split, "all")) { first = 0; last = MGS_SPLIT_COUNT - 1; }
  if (first < 0) { fprintf(stderr, "morsegs render: unknown --split '%s' (train, val, test, all)\n", split); return 2; }
  const char *run = argv[optind];
  if (layout) return reference_layout(run, out, iteration, first, last, force);
  if (mgs_is_dir(out) && dir_nonempty(out) && !force) {
    fprintf(stderr, "morsegs render: %s: output folder is not empty (use --force to write into it)\n", out);
    return 1;
  }
  mgs_error err;
  mgs_error_clear(&err);
  mgs_dataset *ds = NULL;
  mgs_gaussians *g = NULL;
  mgs_raster *r = NULL;
  int it = 0, rc = 1;
  size_t written = 0;
  mgs_status st = mgs_run_open(run, iteration, 0, &ds, &g, &it, &err);
  if (st) goto done;
  if ((st = make_output(out, ds, &err))) goto done;
  r = mgs_raster_create();
  mgs_raster_settings rs;
  raster_settings(ds, g, &rs);
  for (int s = first; s <= last; s++)
    for (size_t i = 0; i < ds->n_views[s]; i++) {
      mgs_view *v = &ds->views[s][i];
      mgs_image *img = NULL;
      if ((st = render_view(r, g, &v->cam, &rs, &img, &err))) goto done;
      char name[512];
      snprintf(name, sizeof name, "%s%s%s.png", last > first ? mgs_split_name((mgs_split)s) : "", last > first ? "_" : "",
               v->name ? v->name : "view");
      for (char *p = name; *p; p++) if (*p == '/') *p = '_';
      char *path = mgs_path_join(out, name);
      st = mgs_image_write(path, img, &err);
      free(path);
      mgs_image_destroy(img);
      if (st) goto done;
      if (mo.depth || mo.normal || mo.alpha) {
        mgs_render_maps maps;
        unsigned which = (mo.depth ? MGS_MAP_DEPTH_EXPECTED | MGS_MAP_DEPTH_MEDIAN : 0) | (mo.normal ? MGS_MAP_NORMAL : 0);
        name[strlen(name) - 4] = 0; /* without .png */
        if ((st = mgs_raster_maps(r, which, &maps, &err)) || (st = mgs_write_render_maps(out, name, &maps, &mo, &err)))
          goto done;
      }
      written++;
    }
  printf("rendered %zu views of %s (iteration %d, %zu Gaussians) into %s\n", written, run, it, g->n, out);
  rc = 0;
done:
  if (rc) mgs_cli_fail("render", &err);
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  mgs_dataset_destroy(ds);
  return rc;
}
