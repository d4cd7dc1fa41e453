/* What `morsegs experiment` records at each evaluation point of a run (measure/mgs_measure.h):
 *   - the figures of `morsegs eval RUN --iteration N` (PSNR, SSIM, Gaussian count, Chamfer,
 *     F-score, H2 floaters), read back from the results.json that eval wrote, so the report
 *     shows exactly what eval reports;
 *   - a floater measure a viewer would notice: the opacity mass Σα of the Gaussians whose
 *     centre lies farther than EXP_VISIBLE_DIST_REL x the GT diagonal from the GT surface
 *     (H2's definition counts only nearly transparent ones, opacity < 0.01, which a viewer
 *     barely sees);
 *   - topology of the model's α-surface: the SDF of {A = τ} at the same voxel size as the
 *     GT mesh's SDF (GT diagonal / --topo-res, default EXP_TOPO_RES), its persistence diagram (band wide enough
 *     for the persistence threshold, topo's mgs_topo_band_for_threshold), Betti numbers at
 *     level 0 (all classes, and those persisting over the threshold) and the bottleneck
 *     distance to the GT diagram (seed Theorem 1 made measurable). */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "measure/mgs_measure.h"
#include "core/mgs_core.h"
#include "render/mgs_mesh_distance.h"
#include "topo/mgs_diagram_tools.h"
#include "topo/mgs_persistence.h"
#include "vdb/mgs_vdb.h"
#include "vdb/mgs_vdb_mesh_sdf.h"

void exp_betti_at_zero(const mgs_diagram *d, double thr, int all[3], int persistent[3]) {
  mgs_diagram_betti(d, 0.0, all);
  mgs_diagram_betti_persistent(d, 0.0, thr, persistent);
}

static mgs_status diagram_of_sdf(const mgs_vdb_grid *sdf, double w, mgs_diagram **out, mgs_error *err) {
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.half_width = w;
  return mgs_topo_persistence_vdb(sdf, &o, out, err);
}

void exp_truth_free(exp_truth *t) {
  mgs_diagram_destroy(t->diagram);
  mgs_mesh_distance_destroy((mgs_mesh_distance *)t->mesh_distance);
  memset(t, 0, sizeof *t);
}

mgs_status exp_truth_build(const char *mesh_path, int res, const char *save_dir, exp_truth *t, mgs_error *err) {
  memset(t, 0, sizeof *t);
  t->res = res > 0 ? res : EXP_TOPO_RES;
  for (int k = 0; k < 3; k++) t->betti[k] = t->betti_persistent[k] = -1;
  if (!mesh_path) return MGS_OK;
  snprintf(t->mesh, sizeof t->mesh, "%s", mesh_path);
  mgs_mesh *m = NULL;
  mgs_vdb_grid *sdf = NULL;
  mgs_status st = mgs_mesh_read(mesh_path, &m, err);
  if (st) return st;
  double lo[3], hi[3];
  mgs_mesh_bounds(m, lo, hi);
  t->diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  if (!(t->diag > 0)) { mgs_mesh_destroy(m); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: the mesh has no extent", mesh_path); }
  t->voxel = t->diag / t->res;
  t->pers_threshold = EXP_PERS_REL * t->diag;
  t->visible_dist = EXP_VISIBLE_DIST_REL * t->diag;
  t->band = mgs_topo_band_for_threshold(t->pers_threshold, 0.0, t->voxel);
  if (t->band < 3) t->band = 3;
  t->half_width = t->band * t->voxel;
  mgs_mesh_distance *md = NULL;
  if ((st = mgs_mesh_distance_create(m, &md, err))) goto done;
  t->mesh_distance = md;
  if ((st = mgs_vdb_sdf_from_mesh(m, t->voxel, t->band, &sdf, err))) goto done;
  if ((st = diagram_of_sdf(sdf, t->half_width, &t->diagram, err))) goto done;
  exp_betti_at_zero(t->diagram, t->pers_threshold, t->betti, t->betti_persistent);
  if (save_dir) {
    char *p = mgs_path_join(save_dir, "gt_diagram.json");
    char meta[4600];
    snprintf(meta, sizeof meta, "{\"source\":\"GT mesh SDF\",\"voxel\":%.9g,\"half_width\":%.9g}", t->voxel, t->half_width);
    st = p ? mgs_diagram_write_json(p, t->diagram, meta, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    free(p);
  }
done:
  mgs_vdb_grid_destroy(sdf);
  mgs_mesh_destroy(m);
  if (st) exp_truth_free(t);
  return st;
}

static double num_or_nan(const cJSON *o, const char *key) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
  return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

mgs_status exp_read_eval(const char *run_dir, int iteration, exp_point *p, mgs_error *err) {
  char *path = mgs_path_join(run_dir, "results.json"), *text = NULL;
  size_t n = 0;
  mgs_status st = path ? mgs_read_file(path, &text, &n, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  if (st) { free(path); return st; }
  cJSON *j = cJSON_Parse(text);
  char key[64];
  snprintf(key, sizeof key, "ours_%d", iteration);
  const cJSON *r = cJSON_GetObjectItemCaseSensitive(j, key);
  if (!cJSON_IsObject(r)) {
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: no \"%s\" entry (morsegs eval did not evaluate iteration %d)", path, key, iteration);
  } else {
    p->psnr = num_or_nan(r, "PSNR");
    p->ssim = num_or_nan(r, "SSIM");
    p->gaussians = num_or_nan(r, "gaussians");
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(r, "geometry");
    p->chamfer = num_or_nan(g, "chamfer");
    p->fscore = num_or_nan(g, "fscore");
    p->floaters = num_or_nan(g, "floaters");
    p->floaters_fraction = num_or_nan(g, "floaters_fraction");
    const cJSON *fu = cJSON_GetObjectItemCaseSensitive(g, "fused"), *sg = cJSON_GetObjectItemCaseSensitive(g, "sugar");
    p->chamfer_fused = num_or_nan(fu, "chamfer");
    p->fscore_fused = num_or_nan(fu, "fscore");
    p->chamfer_mesh = num_or_nan(sg, "chamfer");
    p->fscore_mesh = num_or_nan(sg, "fscore");
    if (!isfinite(p->psnr) || !isfinite(p->gaussians))
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: \"%s\" has no PSNR or Gaussian count", path, key);
  }
  cJSON_Delete(j);
  free(text);
  free(path);
  return st;
}

mgs_status exp_measure_topology(const char *ply, const exp_truth *t, exp_point *p, mgs_error *err) {
  p->floater_mass = p->floater_mass_fraction = p->bottleneck = NAN;
  for (int k = 0; k < 3; k++) p->betti[k] = p->betti_persistent[k] = -1;
  if (!t->diagram) return MGS_OK; /* no GT mesh: nothing to compare with */
  mgs_gaussians *g = NULL;
  mgs_vdb_grid *alpha = NULL, *sdf = NULL;
  mgs_diagram *d = NULL;
  float *dist = NULL;
  mgs_status st = mgs_ply_read_gaussians(ply, &g, err);
  if (st) return st;
  if ((st = mgs_vdb_check_gaussians(g, ply, err))) goto done;
  /* viewer-visible floaters */
  dist = malloc((g->n ? g->n : 1) * sizeof *dist);
  if (!dist) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto done; }
  mgs_mesh_distance_query((const mgs_mesh_distance *)t->mesh_distance, g->n, g->mean, dist, NULL);
  double mass = 0, total = 0;
  for (size_t i = 0; i < g->n; i++) {
    double a = mgs_gaussian_alpha(g, i);
    total += a;
    if (dist[i] > t->visible_dist) mass += a;
  }
  p->floater_mass = mass;
  p->floater_mass_fraction = total > 0 ? mass / total : 0.0;
  /* the model's SDF at the GT's voxel size and band */
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = t->voxel;
  ap.half_width = t->band;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.tau = EXP_SURFACE_TAU;
  sp.half_width = t->band;
  if ((st = mgs_vdb_alpha_field(g, &ap, &alpha, NULL, err))) goto done;
  if ((st = mgs_vdb_sdf_from_alpha(alpha, &sp, &sdf, err))) goto done;
  if ((st = diagram_of_sdf(sdf, t->half_width, &d, err))) goto done;
  exp_betti_at_zero(d, t->pers_threshold, p->betti, p->betti_persistent);
  if ((st = mgs_diagram_bottleneck(d, t->diagram, MGS_DIM_ALL, &p->bottleneck, err))) goto done;
done:
  mgs_diagram_destroy(d);
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(alpha);
  mgs_gaussians_destroy(g);
  free(dist);
  return st;
}

/* ---------------------------------------------------------------- RUN/result.json */

static void add_num(cJSON *o, const char *k, double v) {
  if (isfinite(v)) cJSON_AddNumberToObject(o, k, v);
  else if (isinf(v)) cJSON_AddStringToObject(o, k, v > 0 ? "inf" : "-inf");
  else cJSON_AddNullToObject(o, k);
}

static double get_num(const cJSON *o, const char *k) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
  if (cJSON_IsNumber(v)) return v->valuedouble;
  if (cJSON_IsString(v) && !strcmp(v->valuestring, "inf")) return INFINITY;
  if (cJSON_IsString(v) && !strcmp(v->valuestring, "-inf")) return -INFINITY;
  return NAN;
}

static void add_ints(cJSON *o, const char *k, const int *v) { cJSON_AddItemToObject(o, k, cJSON_CreateIntArray(v, 3)); }

static void get_ints(const cJSON *o, const char *k, int *v) {
  const cJSON *a = cJSON_GetObjectItemCaseSensitive(o, k);
  for (int i = 0; i < 3; i++) {
    const cJSON *e = cJSON_GetArrayItem(a, i);
    v[i] = cJSON_IsNumber(e) ? e->valueint : -1;
  }
}

mgs_status exp_run_write(const char *path, const exp_run *r, mgs_error *err) {
  cJSON *o = cJSON_CreateObject();
  cJSON_AddStringToObject(o, "format", "morsegs-experiment-run");
  cJSON_AddNumberToObject(o, "version", 1);
  cJSON_AddStringToObject(o, "dataset", r->dataset);
  cJSON_AddStringToObject(o, "variant", r->variant);
  cJSON_AddNumberToObject(o, "seed", r->seed);
  cJSON_AddNumberToObject(o, "knob_factor", r->factor);
  cJSON_AddNumberToObject(o, "iterations", r->iters);
  add_num(o, "train_seconds", r->train_seconds);
  add_num(o, "analysis_seconds", r->analysis_seconds);
  add_num(o, "run_seconds", r->run_seconds);
  add_num(o, "train_cpu_seconds", r->train_cpu_seconds);
  add_num(o, "eval_cpu_seconds", r->eval_cpu_seconds);
  if (r->evaluator[0]) cJSON_AddStringToObject(o, "evaluator", r->evaluator);
  cJSON *pts = cJSON_AddArrayToObject(o, "points");
  for (int i = 0; i < r->n_points; i++) {
    const exp_point *p = &r->pt[i];
    cJSON *e = cJSON_CreateObject();
    cJSON_AddNumberToObject(e, "iteration", p->iteration);
    add_num(e, "wall_seconds", p->wall_seconds);
    add_num(e, "PSNR", p->psnr);
    add_num(e, "SSIM", p->ssim);
    add_num(e, "gaussians", p->gaussians);
    add_num(e, "chamfer", p->chamfer);
    add_num(e, "fscore", p->fscore);
    add_num(e, "chamfer_fused", p->chamfer_fused);
    add_num(e, "fscore_fused", p->fscore_fused);
    add_num(e, "chamfer_mesh", p->chamfer_mesh);
    add_num(e, "fscore_mesh", p->fscore_mesh);
    add_num(e, "floaters", p->floaters);
    add_num(e, "floaters_fraction", p->floaters_fraction);
    add_num(e, "floater_mass", p->floater_mass);
    add_num(e, "floater_mass_fraction", p->floater_mass_fraction);
    add_ints(e, "betti", p->betti);
    add_ints(e, "betti_persistent", p->betti_persistent);
    add_num(e, "bottleneck", p->bottleneck);
    add_num(e, "measure_seconds", p->measure_seconds);
    cJSON_AddItemToArray(pts, e);
  }
  char *text = cJSON_Print(o);
  cJSON_Delete(o);
  mgs_status st = text ? mgs_write_file_atomic(path, text, strlen(text), err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  free(text);
  return st;
}

mgs_status exp_run_read(const char *path, exp_run *r, mgs_error *err) {
  char *text = NULL;
  size_t n = 0;
  mgs_status st = mgs_read_file(path, &text, &n, err);
  if (st) return st;
  memset(r, 0, sizeof *r);
  cJSON *o = cJSON_Parse(text);
  free(text);
  const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(o, "format");
  const cJSON *ds = cJSON_GetObjectItemCaseSensitive(o, "dataset"), *va = cJSON_GetObjectItemCaseSensitive(o, "variant");
  const cJSON *pts = cJSON_GetObjectItemCaseSensitive(o, "points");
  if (!cJSON_IsString(fmt) || strcmp(fmt->valuestring, "morsegs-experiment-run") || !cJSON_IsString(ds) ||
      !cJSON_IsString(va) || !cJSON_IsArray(pts) || cJSON_GetArraySize(pts) < 1 || cJSON_GetArraySize(pts) > EXP_MAX_POINTS) {
    cJSON_Delete(o);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a morsegs experiment run record", path);
  }
  snprintf(r->dataset, sizeof r->dataset, "%s", ds->valuestring);
  snprintf(r->variant, sizeof r->variant, "%s", va->valuestring);
  r->seed = (int)get_num(o, "seed");
  r->factor = get_num(o, "knob_factor");
  r->iters = (int)get_num(o, "iterations");
  r->train_seconds = get_num(o, "train_seconds");
  r->analysis_seconds = get_num(o, "analysis_seconds");
  r->run_seconds = get_num(o, "run_seconds");
  r->train_cpu_seconds = get_num(o, "train_cpu_seconds");
  r->eval_cpu_seconds = get_num(o, "eval_cpu_seconds");
  const cJSON *ev = cJSON_GetObjectItem(o, "evaluator");
  snprintf(r->evaluator, sizeof r->evaluator, "%s", cJSON_IsString(ev) ? ev->valuestring : "");
  const cJSON *e;
  cJSON_ArrayForEach(e, pts) {
    exp_point *p = &r->pt[r->n_points++];
    p->iteration = (int)get_num(e, "iteration");
    p->wall_seconds = get_num(e, "wall_seconds");
    p->psnr = get_num(e, "PSNR");
    p->ssim = get_num(e, "SSIM");
    p->gaussians = get_num(e, "gaussians");
    p->chamfer = get_num(e, "chamfer");
    p->fscore = get_num(e, "fscore");
    p->chamfer_fused = get_num(e, "chamfer_fused");
    p->fscore_fused = get_num(e, "fscore_fused");
    p->chamfer_mesh = get_num(e, "chamfer_mesh");
    p->fscore_mesh = get_num(e, "fscore_mesh");
    p->floaters = get_num(e, "floaters");
    p->floaters_fraction = get_num(e, "floaters_fraction");
    p->floater_mass = get_num(e, "floater_mass");
    p->floater_mass_fraction = get_num(e, "floater_mass_fraction");
    get_ints(e, "betti", p->betti);
    get_ints(e, "betti_persistent", p->betti_persistent);
    p->bottleneck = get_num(e, "bottleneck");
    p->measure_seconds = get_num(e, "measure_seconds");
  }
  cJSON_Delete(o);
  if (!isfinite(r->factor) || r->iters < 1) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: bad knob factor or iteration count", path);
  return MGS_OK;
}
