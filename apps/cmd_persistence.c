/* morsegs persistence IN.vdb [-o OUTDIR]: the persistence diagram of a level set or fog
 * volume (ours or from Houdini/Blender) and everything drawn from it.
 *
 * Filtrations:
 *   level set (default for grids of class level set): sublevel sets {sdf ≤ t} of the SDF
 *     clamped to [−w, w], w = the band (--band W voxels, default the grid's background =
 *     its half-width); Betti numbers at t = 0 (the solid).
 *   fog volume (default for fog grids): superlevel sets {density ≥ t}. The engine runs the
 *     sublevel filtration of −density and we negate back, so the diagram holds density
 *     values with birth ≥ death (essential deaths = −inf): a class is born when the
 *     threshold comes down to `birth` and dies at `death`. Betti numbers at t = --level
 *     (default 0.5): classes with death < t ≤ birth.
 * Outputs (OUTDIR, default IN-stem + "_persistence"): diagram.txt (GUDHI layout), diagram.json
 * (cells, positions, truncated flags, statistics), diagram.png/.svg, barcode.png/.svg,
 * betti.txt, critical.vdb (PointDataGrid "critical": one point per pair at its birth cell,
 * attributes index = dimension, birth, death, persistence). Everything is computed before
 * anything is written; files go to a staging directory first and are renamed into place,
 * so a failure leaves no partial output. Existing outputs need --force. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "core/mgs_origin.h"
#include "apps/mgs_cli.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "topo/mgs_diagram_plot.h"
#include "topo/mgs_diagram_tools.h"
#include "topo/mgs_levelset_check.h"
#include "topo/mgs_persistence.h"
#include "vdb/mgs_vdb.h"

static const char *outputs[] = {"diagram.txt", "diagram.json", "diagram.png", "diagram.svg",
                                "barcode.png", "barcode.svg", "betti.txt", "critical.vdb"};
#define N_OUTPUTS (sizeof outputs / sizeof outputs[0])

static void usage(FILE *f) {
  fprintf(f,
          "usage: morsegs persistence IN.vdb [options]\n"
          "  -o, --output OUTDIR        output directory (default: IN-stem_persistence)\n"
          "  --grid NAME                grid to analyse (default: the first level set, else the\n"
          "                             first float grid)\n"
          "  --band W                   clamp the SDF to [-W, W] voxels (default: the grid's\n"
          "                             background, i.e. its narrow-band half-width; never wider)\n"
          "  --min-persistence P        keep pairs with |death - birth| > P (0)\n"
          "  --construction V|T         voxels as vertices (V, lower star; default) or as cubes (T)\n"
          "  --sublevel | --superlevel  filtration (default: sublevel for level sets, superlevel\n"
          "                             for fog volumes; superlevel = sublevel of -f, negated back)\n"
          "  --level T                  level for the Betti numbers (default 0 for sublevel,\n"
          "                             0.5 for superlevel)\n"
          "  --no-check                 skip the narrow-band validity check of level sets\n"
          "                             (finite, |value| <= background, inactive tiles = +-background,\n"
          "                             at most 3 voxel sizes of change across a voxel face)\n"
          "  --force                    overwrite existing outputs\n"
          "outputs: diagram.txt diagram.json diagram.png diagram.svg barcode.png barcode.svg\n"
          "         betti.txt critical.vdb\n");
}

static int parse_double(const char *s, double *v) {
  char *end = NULL;
  *v = strtod(s, &end);
  return end && end != s && *end == 0 && isfinite(*v);
}

static const char *class_name(mgs_vdb_class c) {
  return c == MGS_VDB_CLASS_LEVEL_SET ? "level set" : c == MGS_VDB_CLASS_FOG ? "fog volume" : "scalar grid";
}

/* IN-stem + "_persistence" in the current directory. */
static char *default_outdir(const char *in) {
  const char *base = strrchr(in, '/');
  base = base ? base + 1 : in;
  size_t n = strlen(base);
  if (n > 4 && !strcmp(base + n - 4, ".vdb")) n -= 4;
  char *s = malloc(n + 16);
  if (s) { memcpy(s, base, n); strcpy(s + n, "_persistence"); }
  return s;
}

static mgs_status write_betti(const char *path, const char *in, const char *grid, int superlevel,
                              double level, const int b[3], mgs_error *err) {
  char buf[2048];
  int n = snprintf(buf, sizeof buf,
                   "# morsegs persistence: Betti numbers of %s of '%s' in %s\n"
                   "level %.17g\nb0 %d\nb1 %d\nb2 %d\n",
                   superlevel ? "the superlevel set {f >= level}" : "the sublevel set {f <= level}", grid, in,
                   level, b[0], b[1], b[2]);
  return mgs_write_file_atomic(path, buf, (size_t)n, err);
}

static mgs_status write_critical(const char *path, const mgs_diagram *d, double voxel_size,
                                 const char *in, mgs_error *err) {
  size_t n = d->n;
  float *xyz = malloc((n ? n : 1) * 3 * sizeof *xyz);
  float *birth = malloc((n ? n : 1) * sizeof *birth), *death = malloc((n ? n : 1) * sizeof *death);
  float *pers = malloc((n ? n : 1) * sizeof *pers);
  int32_t *index = malloc((n ? n : 1) * sizeof *index);
  mgs_vdb_points *pts = NULL;
  mgs_status st;
  if (!xyz || !birth || !death || !pers || !index) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu points", path, n);
    goto done;
  }
  double origin[3]; /* far grids: float positions relative to a local origin, the point grid moved back in double */
  {
    double c[3] = {0, 0, 0}, ss = 0;
    for (size_t i = 0; i < n; i++) for (int k = 0; k < 3; k++) c[k] += d->pairs[i].b.pos[k] / (double)n;
    for (size_t i = 0; i < n; i++) for (int k = 0; k < 3; k++) ss += (d->pairs[i].b.pos[k] - c[k]) * (d->pairs[i].b.pos[k] - c[k]);
    mgs_origin_choose(c, n ? sqrt(ss / (double)n) : 1.0, origin);
  }
  for (size_t i = 0; i < n; i++) {
    const mgs_pair *p = &d->pairs[i];
    for (int k = 0; k < 3; k++) xyz[3 * i + k] = (float)(p->b.pos[k] - origin[k]);
    index[i] = p->dim;
    birth[i] = (float)p->birth;
    death[i] = (float)p->death;
    pers[i] = (float)fabs(p->death - p->birth);
  }
  st = mgs_vdb_points_create_critical(n, xyz, index, birth, death, pers, voxel_size, &pts, err);
  if (st == MGS_OK) mgs_vdb_points_translate(pts, origin);
  if (st == MGS_OK) {
    mgs_vdb_file_meta meta;
    mgs_vdb_file_meta_default(&meta);
    meta.voxel_size = voxel_size;
    snprintf(meta.source, sizeof meta.source, "%s", in);
    const mgs_vdb_points *pp[1] = {pts};
    st = mgs_vdb_write(path, NULL, 0, pp, 1, &meta, err);
  }
done:
  mgs_vdb_points_destroy(pts);
  free(xyz); free(birth); free(death); free(pers); free(index);
  return st;
}

/* All outputs into `dir` (an empty staging directory). */
static mgs_status write_all(const char *dir, const mgs_diagram *d, const char *meta_json,
                            const char *in, const char *grid, int superlevel, double level,
                            const int betti[3], double voxel_size, mgs_error *err) {
  char title[512];
  snprintf(title, sizeof title, "%s: %s (%s)", in, grid, superlevel ? "superlevel" : "sublevel");
  mgs_status st = MGS_OK;
  for (size_t i = 0; i < N_OUTPUTS && st == MGS_OK; i++) {
    char *path = mgs_path_join(dir, outputs[i]);
    if (!path) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    switch (i) {
      case 0: st = mgs_diagram_write_text(path, d, err); break;
      case 1: st = mgs_diagram_write_json(path, d, meta_json, err); break;
      case 2: case 3: st = mgs_diagram_plot(d, path, title, err); break;
      case 4: case 5: st = mgs_diagram_plot_barcode(d, path, title, err); break;
      case 6: st = write_betti(path, in, grid, superlevel, level, betti, err); break;
      default: st = write_critical(path, d, voxel_size, in, err); break;
    }
    free(path);
  }
  return st;
}

/* Moves the staged files into outdir (each rename atomic). */
static mgs_status publish(const char *staging, const char *outdir, int outdir_existed, mgs_error *err) {
  if (!outdir_existed) {
    if (rename(staging, outdir) != 0)
      return mgs_error_set(err, MGS_ERR_IO, "%s: cannot create the output directory", outdir);
    return MGS_OK;
  }
  for (size_t i = 0; i < N_OUTPUTS; i++) {
    char *a = mgs_path_join(staging, outputs[i]), *b = mgs_path_join(outdir, outputs[i]);
    int ok = a && b && rename(a, b) == 0;
    free(a); free(b);
    if (!ok) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot move %s into place", outdir, outputs[i]);
  }
  mgs_error ignore;
  mgs_remove_tree(staging, &ignore);
  return MGS_OK;
}

int mgs_cmd_persistence(int argc, char **argv) {
  static const struct option opts[] = {
      {"output", required_argument, 0, 'o'},     {"grid", required_argument, 0, 'g'},
      {"band", required_argument, 0, 'b'},       {"min-persistence", required_argument, 0, 'p'},
      {"construction", required_argument, 0, 'c'}, {"superlevel", no_argument, 0, 'U'},
      {"sublevel", no_argument, 0, 'L'},         {"level", required_argument, 0, 't'},
      {"no-check", no_argument, 0, 'N'},         {"force", no_argument, 0, 'f'},
      {"help", no_argument, 0, 'h'},             {0, 0, 0, 0}};
  const char *outdir_arg = NULL, *grid_name = NULL;
  double band = NAN, min_pers = 0, level = NAN;
  int construction = MGS_TOPO_V, filtration = -1, force = 0, check = 1, c;
  optind = 1;
  while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
    switch (c) {
      case 'o': outdir_arg = optarg; break;
      case 'g': grid_name = optarg; break;
      case 'b':
        if (!parse_double(optarg, &band) || !(band > 0)) {
          fprintf(stderr, "morsegs persistence: --band '%s' must be a positive number of voxels\n", optarg);
          return 2;
        }
        break;
      case 'p':
        if (!parse_double(optarg, &min_pers) || min_pers < 0) {
          fprintf(stderr, "morsegs persistence: --min-persistence '%s' must be a number >= 0\n", optarg);
          return 2;
        }
        break;
      case 'c':
        if (!strcmp(optarg, "V") || !strcmp(optarg, "v")) construction = MGS_TOPO_V;
        else if (!strcmp(optarg, "T") || !strcmp(optarg, "t")) construction = MGS_TOPO_T;
        else {
          fprintf(stderr, "morsegs persistence: --construction '%s' must be V or T\n", optarg);
          return 2;
        }
        break;
      case 'U': filtration = MGS_TOPO_SUPERLEVEL; break;
      case 'L': filtration = MGS_TOPO_SUBLEVEL; break;
      case 't':
        if (!parse_double(optarg, &level)) {
          fprintf(stderr, "morsegs persistence: --level '%s' must be a number\n", optarg);
          return 2;
        }
        break;
      case 'N': check = 0; break;
      case 'f': force = 1; break;
      case 'h': usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (optind != argc - 1) { usage(stderr); return 2; }
  const char *in = argv[optind];
  mgs_error err;
  mgs_error_clear(&err);
  double t0 = mgs_now();

  if (!mgs_path_exists(in)) {
    mgs_error_set(&err, MGS_ERR_IO, "%s: no such file", in);
    return mgs_cli_fail("persistence", &err);
  }
  char *outdir = outdir_arg ? mgs_strdup(outdir_arg) : default_outdir(in);
  if (!outdir) { mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); return mgs_cli_fail("persistence", &err); }
  int rc = 1, outdir_existed = mgs_path_exists(outdir);
  mgs_vdb_grid *g = NULL;
  mgs_diagram *d = NULL;
  char *staging = NULL, *meta_json = NULL;
  mgs_status st = MGS_OK;

  /* refuse to overwrite before doing any work */
  if (outdir_existed && !mgs_is_dir(outdir)) {
    st = mgs_error_set(&err, MGS_ERR_EXISTS, "%s: exists and is not a directory", outdir);
    goto done;
  }
  if (outdir_existed && !force)
    for (size_t i = 0; i < N_OUTPUTS; i++) {
      char *p = mgs_path_join(outdir, outputs[i]);
      int ex = p && mgs_path_exists(p);
      free(p);
      if (ex) {
        st = mgs_error_set(&err, MGS_ERR_EXISTS, "%s/%s exists (use --force to overwrite)", outdir, outputs[i]);
        goto done;
      }
    }

  if ((st = mgs_vdb_read_grid(in, grid_name, &g, &err)) != MGS_OK) goto done;
  const char *gname = mgs_vdb_grid_name(g);
  mgs_vdb_class cls = mgs_vdb_grid_class(g);
  double h = mgs_vdb_grid_voxel_size(g), bg = mgs_vdb_grid_background(g);
  size_t active = mgs_vdb_grid_active_voxel_count(g);
  if (filtration < 0) filtration = cls == MGS_VDB_CLASS_FOG ? MGS_TOPO_SUPERLEVEL : MGS_TOPO_SUBLEVEL;
  int superlevel = filtration == MGS_TOPO_SUPERLEVEL;
  if (cls == MGS_VDB_CLASS_LEVEL_SET && superlevel) {
    st = mgs_error_set(&err, MGS_ERR_ARG, "%s: grid '%s' is a level set: its topology is that of the sublevel filtration (drop --superlevel)", in, gname);
    goto done;
  }
  if (active == 0) {
    st = mgs_error_set(&err, MGS_ERR_FORMAT, "%s: grid '%s' has no active voxels", in, gname);
    goto done;
  }
  if (cls == MGS_VDB_CLASS_LEVEL_SET && check && (st = mgs_topo_check_level_set(g, in, &err)) != MGS_OK) goto done;
  if (isnan(level)) level = superlevel ? 0.5 : 0.0;

  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.construction = (mgs_topo_construction)construction;
  o.filtration = (mgs_topo_filtration)filtration;
  o.min_persistence = min_pers;
  o.half_width = isnan(band) ? INFINITY : band * h;
  mgs_topo_stats stats;
  memset(&stats, 0, sizeof stats);
  if ((st = mgs_topo_persistence_vdb_stats(g, &o, &d, &stats, &err)) != MGS_OK) {
    /* the engine's messages do not know the file */
    char msg[MGS_ERROR_MSG_MAX];
    snprintf(msg, sizeof msg, "%s", err.msg);
    mgs_error_set(&err, st, "%s: %s", in, msg);
    goto done;
  }
  if (superlevel) /* the engine reports -f values: back to density units */
    for (size_t i = 0; i < d->n; i++) { d->pairs[i].birth = -d->pairs[i].birth; d->pairs[i].death = -d->pairs[i].death; }
  mgs_diagram_sort(d);
  if (superlevel) { /* sort put -f order; keep (dim, birth descending) for readability */
    for (size_t i = 0; i < d->n; i++) { d->pairs[i].birth = -d->pairs[i].birth; d->pairs[i].death = -d->pairs[i].death; }
    mgs_diagram_sort(d);
    for (size_t i = 0; i < d->n; i++) { d->pairs[i].birth = -d->pairs[i].birth; d->pairs[i].death = -d->pairs[i].death; }
  }
  int betti[3];
  if (superlevel) mgs_diagram_betti_superlevel(d, level, betti);
  else mgs_diagram_betti(d, level, betti);
  size_t per_dim[3], ess, trunc;
  mgs_diagram_counts(d, per_dim, &ess, &trunc);

  char meta[4096];
  char *esc_in = NULL;
  { /* JSON-escape the two user strings */
    size_t n = strlen(in) + strlen(gname);
    esc_in = malloc(2 * n + 64);
    if (!esc_in) { st = mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); goto done; }
    char *q = esc_in;
    const char *parts[2] = {in, gname};
    for (int k = 0; k < 2; k++) {
      for (const char *s = parts[k]; *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\') *q++ = '\\';
        if (ch < 0x20) { *q++ = '?'; continue; }
        *q++ = (char)ch;
      }
      *q++ = 0;
    }
  }
  const char *esc_grid = esc_in + strlen(esc_in) + 1;
  char clamp[64];
  if (isfinite(stats.effective_w)) snprintf(clamp, sizeof clamp, "%.17g", stats.effective_w);
  else snprintf(clamp, sizeof clamp, "\"none\"");
  snprintf(meta, sizeof meta,
           "{\"tool\":\"morsegs persistence\",\"source\":\"%s\",\"grid\":\"%s\",\"grid_class\":\"%s\","
           "\"filtration\":\"%s\",\"construction\":\"%s\",\"voxel_size\":%.17g,\"background\":%.17g,"
           "\"clamp\":%s,\"min_persistence\":%.17g,\"level\":%.17g,\"betti\":[%d,%d,%d],"
           "\"active_voxels\":%zu,\"leaves\":%zu,\"tiles\":%zu,\"cells_total\":%zu,\"band_cells\":%zu,\"cells_built\":%zu,"
           "\"critical_cells\":%zu,\"reduction_ratio\":%.6f,\"truncated\":%zu,\"engine_seconds\":%.6f}",
           esc_in, esc_grid, class_name(cls), superlevel ? "superlevel (sublevel of -f, negated back)" : "sublevel",
           construction == MGS_TOPO_V ? "V" : "T", h, bg,
           clamp,
           min_pers, level, betti[0], betti[1], betti[2], active, stats.leaves, stats.tiles, stats.cells_total,
           stats.band_cells, stats.cells_built, stats.critical_cells, stats.reduction_ratio, stats.truncated, stats.seconds);
  free(esc_in);
  meta_json = mgs_strdup(meta);

  /* stage and publish */
  {
    char suffix[64];
    snprintf(suffix, sizeof suffix, ".staging-%ld", (long)getpid());
    if (outdir_existed) staging = mgs_path_join(outdir, suffix + 1);
    else {
      char *parent = mgs_path_dirname(outdir);
      st = parent ? mgs_mkdir_p(parent, &err) : mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory");
      free(parent);
      if (st != MGS_OK) goto done;
      staging = malloc(strlen(outdir) + sizeof suffix);
      if (staging) { strcpy(staging, outdir); strcat(staging, suffix); }
    }
    if (!staging || !meta_json) { st = mgs_error_set(&err, MGS_ERR_NOMEM, "out of memory"); goto done; }
    if ((st = mgs_mkdir_p(staging, &err)) != MGS_OK) goto done;
    st = write_all(staging, d, meta_json, in, gname, superlevel, level, betti, h, &err);
    if (st == MGS_OK) st = publish(staging, outdir, outdir_existed, &err);
    if (st != MGS_OK) { mgs_error ignore; mgs_remove_tree(staging, &ignore); goto done; }
  }

  printf("morsegs persistence: %s, grid '%s' (%s, %zu active voxels, voxel size %g)\n", in, gname, class_name(cls), active, h);
  if (isfinite(stats.effective_w))
    printf("  filtration: %s, %s-construction, values clamped to [%g, %g]\n", superlevel ? "superlevel" : "sublevel",
           construction == MGS_TOPO_V ? "V" : "T", -stats.effective_w, stats.effective_w);
  else
    printf("  filtration: %s, %s-construction, no clamp\n", superlevel ? "superlevel (of density)" : "sublevel",
           construction == MGS_TOPO_V ? "V" : "T");
  printf("  pairs: H0 %zu, H1 %zu, H2 %zu (essential %zu, truncated by the band %zu)\n", per_dim[0], per_dim[1],
         per_dim[2], ess, trunc);
  if (trunc && isfinite(stats.effective_w) && h > 0) {
    /* Bars alive at the level are exact up to persistence w - |level|; longer ones need a
     * wider band, which only a rebuild of the SDF can give. */
    const double exact = stats.effective_w - fabs(level);
    printf("  note: bars reaching the clamp: %zu (their true persistence may be longer); bars alive at %g are exact\n"
           "        up to persistence %g; to resolve persistence P, rebuild the SDF with `morsegs vdb --band W`,\n"
           "        W = floor((|level| + P) / %g) + 1 voxels\n",
           trunc, level, exact > 0 ? exact : 0.0, h);
  }
  if (min_pers > 0 && isfinite(stats.effective_w) && h > 0 && !superlevel) {
    const int need = mgs_topo_band_for_threshold(min_pers, level, h);
    if (need < 0 || need * h > stats.effective_w * (1 + 1e-9))
      printf("  warning: --min-persistence %g needs a band of %d voxels to be exact at %g; this grid's is %g voxels\n",
             min_pers, need, level, stats.effective_w / h);
  }
  printf("  Betti numbers at %s %g: b0=%d b1=%d b2=%d\n", superlevel ? "density >=" : "t =", level, betti[0], betti[1], betti[2]);
  printf("  cells: %zu in the band (%zu in the box), %zu critical after the discrete gradient (reduction %.1f %%)\n",
         stats.band_cells, stats.cells_total, stats.critical_cells, 100.0 * stats.reduction_ratio);
  printf("  time: %.3f s (persistence %.3f s)\n", mgs_now() - t0, stats.seconds);
  printf("  wrote %s/{diagram.txt,diagram.json,diagram.png,diagram.svg,barcode.png,barcode.svg,betti.txt,critical.vdb}\n", outdir);
  rc = 0;
done:
  mgs_diagram_plot_release();
  if (st != MGS_OK) rc = mgs_cli_fail("persistence", &err);
  mgs_diagram_destroy(d);
  mgs_vdb_grid_destroy(g);
  free(staging);
  free(meta_json);
  free(outdir);
  return rc;
}
