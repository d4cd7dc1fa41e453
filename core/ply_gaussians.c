/* The 3DGS .ply layout (SPEC §4): read any encoding / property order (and SuperSplat's
 * compressed layout, core/ply_compressed.h), write the reference's binary little-endian layout. f_rest is channel-major in the file
 * (f_rest_{c*R+k}) and [i][k][c] in memory. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mgs_fs.h"
#include "core/mgs_origin.h"
#include "core/mgs_ply.h"
#include "core/ply_compressed.h"
#include "core/ply_format.h"
#include "core/splat_format.h"
#include "core/ksplat_format.h"
#include "core/sog_format.h"
#include "core/spz_format.h"

enum { G_X, G_Y, G_Z, G_DC0, G_DC1, G_DC2, G_OPACITY, G_S0, G_S1, G_S2, G_R0, G_R1, G_R2, G_R3, G_FIXED };
static const char *const fixed_names[G_FIXED] = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                                                 "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};

static int sh_rest_per_channel(int deg) { return (deg + 1) * (deg + 1) - 1; }

typedef struct {
  const char *path;
  const ply_element *el;
  int col_fixed[G_FIXED];
  int col_rest[MGS_SH_REST_MAX];
  int n_rest, degree, rest_per_channel;
  mgs_gaussians *g;
  double *xyz64; /* the means as stored (world, double), placed in the local frame after reading */
} gread;

static mgs_status read_row(void *ctx, size_t row, const double *v, mgs_error *err) {
  gread *r = ctx;
  if (row == 0) {
    /* Allocated only now: the container has checked the count against the file size. */
    r->g = mgs_gaussians_create(r->el->count, r->degree);
    r->xyz64 = malloc(r->el->count * 3 * sizeof(double));
    size_t first = 0;
    if (!r->g || !r->xyz64 || mgs_gaussians_append(r->g, r->el->count, &first, err) != MGS_OK)
      return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu Gaussians", r->path, r->el->count);
  }
  mgs_gaussians *g = r->g;
  float f[G_FIXED];
  for (int k = 0; k < G_FIXED; k++) {
    if (r->col_fixed[k] < 0) { f[k] = MGS_SURFEL_LOG_SCALE2; continue; } /* a surfel's scale_2 */
    f[k] = (float)v[r->col_fixed[k]];
    if (!isfinite(f[k]))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: vertex %zu: property '%s' is not finite (%g)", r->path, row,
                           fixed_names[k], v[r->col_fixed[k]]);
  }
  for (int k = 0; k < 3; k++) r->xyz64[row * 3 + (size_t)k] = v[r->col_fixed[G_X + k]];
  g->sh_dc[row * 3 + 0] = f[G_DC0];
  g->sh_dc[row * 3 + 1] = f[G_DC1];
  g->sh_dc[row * 3 + 2] = f[G_DC2];
  g->opacity[row] = f[G_OPACITY];
  for (int k = 0; k < 3; k++) g->log_scale[row * 3 + k] = f[G_S0 + k];
  for (int k = 0; k < 4; k++) g->rot[row * 4 + k] = f[G_R0 + k];
  float *rest = g->sh_rest + row * MGS_SH_REST_MAX;
  memset(rest, 0, sizeof(float) * MGS_SH_REST_MAX);
  const int R = r->rest_per_channel;
  for (int j = 0; j < r->n_rest; j++) {
    float x = (float)v[r->col_rest[j]];
    if (!isfinite(x))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: vertex %zu: property 'f_rest_%d' is not finite (%g)", r->path, row, j,
                           v[r->col_rest[j]]);
    int c = j / R, k = j % R; /* file: channel-major */
    rest[k * 3 + c] = x;      /* memory: [k][c] */
  }
  return MGS_OK;
}

static int float_type(ply_type t) { return t == PLY_FLOAT32 || t == PLY_FLOAT64; }

/* The origin of a model without one: the means' mean, against their RMS spread (the
 * rule of core/mgs_origin.h: (0,0,0) unless the model is far from it). */
static void choose_origin(const double *xyz, size_t n, double origin[3]) {
  double c[3] = {0, 0, 0}, ss = 0;
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) c[k] += xyz[3 * i + (size_t)k];
  for (int k = 0; k < 3; k++) c[k] = n ? c[k] / (double)n : 0;
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) ss += (xyz[3 * i + (size_t)k] - c[k]) * (xyz[3 * i + (size_t)k] - c[k]);
  mgs_origin_choose(c, n ? sqrt(ss / (double)n) : 1.0, origin);
}

/* The means into the local frame, in double before they become float; takes g and xyz64. */
static mgs_status place_means(const char *path, mgs_gaussians *g, double *xyz64, const double *origin, mgs_gaussians **out,
                              mgs_error *err) {
  if (origin) for (int k = 0; k < 3; k++) g->origin[k] = origin[k];
  else choose_origin(xyz64, g->n, g->origin);
  for (size_t i = 0; i < g->n; i++)
    for (int k = 0; k < 3; k++) {
      float f = (float)(xyz64[3 * i + (size_t)k] - g->origin[k]);
      if (!isfinite(f)) {
        mgs_status st = mgs_error_set(err, MGS_ERR_NUMERIC, "%s: vertex %zu: property '%s' is not finite in float (%g)", path,
                                      i, fixed_names[G_X + k], xyz64[3 * i + (size_t)k]);
        free(xyz64);
        mgs_gaussians_destroy(g);
        return st;
      }
      g->mean[3 * i + (size_t)k] = f;
    }
  free(xyz64);
  *out = g;
  return MGS_OK;
}

mgs_status mgs_ply_read_gaussians(const char *path, mgs_gaussians **out, mgs_error *err) {
  static const double zero[3] = {0, 0, 0};
  return mgs_ply_read_gaussians_local(path, zero, out, err);
}

mgs_status mgs_ply_read_gaussians_local(const char *path, const double *origin, mgs_gaussians **out, mgs_error *err) {
  *out = NULL;
  /* the splat formats told by their file name; each decodes everything but the placed means */
  static const struct {
    int (*is_path)(const char *path);
    mgs_status (*read)(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err);
  } named[] = {
      {splat_is_path, splat_read_gaussians},   /* the web viewers' .splat (core/splat_format.h) */
      {ksplat_is_path, ksplat_read_gaussians}, /* GaussianSplats3D's .ksplat (core/ksplat_format.h) */
      {sog_is_path, sog_read_gaussians},       /* PlayCanvas's SOG: a .sog or its meta.json (core/sog_format.h) */
      {spz_is_path, spz_read_gaussians},       /* Niantic's .spz (core/spz_format.h) */
  };
  for (size_t k = 0; k < sizeof named / sizeof named[0]; k++) {
    if (!named[k].is_path(path)) continue;
    mgs_gaussians *g = NULL;
    double *xyz64 = NULL;
    mgs_status st = named[k].read(path, &g, &xyz64, err);
    return st != MGS_OK ? st : place_means(path, g, xyz64, origin, out, err);
  }
  ply_file pf;
  mgs_status st = ply_open(path, &pf, err);
  if (st != MGS_OK) return st;
  int vi = -1;
  for (int i = 0; i < pf.n_elems; i++)
    if (strcmp(pf.elems[i].name, "vertex") == 0) { vi = i; break; }
  if (vi < 0) { ply_close(&pf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: no 'vertex' element", path); }
  if (ply_is_compressed_gaussians(&pf)) { /* SuperSplat / splat-transform's *.compressed.ply */
    mgs_gaussians *g = NULL;
    double *xyz64 = NULL;
    st = ply_read_compressed_gaussians(&pf, &g, &xyz64, err);
    ply_close(&pf);
    return st != MGS_OK ? st : place_means(path, g, xyz64, origin, out, err);
  }
  const ply_element *el = &pf.elems[vi];
  gread r;
  memset(&r, 0, sizeof r);
  r.path = path;
  r.el = el;
  /* two scale columns: a 2DGS model, as hbb1/2d-gaussian-splatting writes it */
  const int surfel = ply_find_property(el, "scale_2") < 0 && ply_find_property(el, "scale_0") >= 0 &&
                     ply_find_property(el, "scale_1") >= 0;
  for (int k = 0; k < G_FIXED; k++) {
    int c = ply_find_property(el, fixed_names[k]);
    if (c < 0 && surfel && k == G_S2) { r.col_fixed[k] = -1; continue; }
    if (c < 0) { ply_close(&pf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing vertex property '%s' (not a 3DGS .ply?)", path, fixed_names[k]); }
    if (el->props[c].is_list || !float_type(el->props[c].type)) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex property '%s' has type %s%s; expected float", path, fixed_names[k],
                         el->props[c].is_list ? "list " : "", ply_type_name(el->props[c].type));
      ply_close(&pf);
      return st;
    }
    r.col_fixed[k] = c;
  }
  /* f_rest_0..M-1 must be present without gaps; M decides the degree. */
  int n_rest = 0, max_idx = -1;
  for (int i = 0; i < el->n_props; i++) {
    const char *nm = el->props[i].name;
    if (strncmp(nm, "f_rest_", 7) != 0) continue;
    char *e = NULL;
    long idx = strtol(nm + 7, &e, 10);
    if (!e || *e || e == nm + 7 || idx < 0 || idx > 1000) continue; /* not ours: ignore */
    if (el->props[i].is_list || !float_type(el->props[i].type)) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex property '%s' has type %s; expected float", path, nm, ply_type_name(el->props[i].type));
      ply_close(&pf);
      return st;
    }
    n_rest++;
    if (idx > max_idx) max_idx = (int)idx;
  }
  int degree = -1;
  for (int d = 0; d <= 3; d++)
    if (n_rest == 3 * sh_rest_per_channel(d)) degree = d;
  if (degree < 0) {
    ply_close(&pf);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %d f_rest properties; expected 0, 9, 24 or 45 (SH degree 0..3)", path, n_rest);
  }
  if (max_idx != n_rest - 1) {
    ply_close(&pf);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: f_rest properties are not numbered 0..%d", path, n_rest - 1);
  }
  for (int j = 0; j < n_rest; j++) {
    char nm[32];
    snprintf(nm, sizeof nm, "f_rest_%d", j);
    r.col_rest[j] = ply_find_property(el, nm);
    if (r.col_rest[j] < 0) { ply_close(&pf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing vertex property '%s'", path, nm); }
  }
  r.n_rest = n_rest;
  r.degree = degree;
  r.rest_per_channel = sh_rest_per_channel(degree);
  if (el->count == 0) {
    r.g = mgs_gaussians_create(0, degree);
    st = r.g ? ply_read_element(&pf, vi, read_row, &r, err)
             : mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  } else {
    st = ply_read_element(&pf, vi, read_row, &r, err);
  }
  ply_close(&pf);
  if (st != MGS_OK) {
    mgs_gaussians_destroy(r.g);
    free(r.xyz64);
    return st;
  }
  r.g->kind = surfel ? MGS_MODEL_2DGS : MGS_MODEL_3DGS;
  return place_means(path, r.g, r.xyz64, origin, out, err);
}

/* ---- writing ---- */

static mgs_status check_finite_named(const char *path, const mgs_gaussians *g, int R, mgs_error *err) {
  static const struct { mgs_param_group grp; const char *name; int dim; } groups[] = {
    {MGS_PARAM_MEAN, "x/y/z", 3}, {MGS_PARAM_SH_DC, "f_dc", 3}, {MGS_PARAM_OPACITY, "opacity", 1},
    {MGS_PARAM_LOG_SCALE, "scale", 3}, {MGS_PARAM_ROT, "rot", 4}};
  const float *arr[] = {g->mean, g->sh_dc, g->opacity, g->log_scale, g->rot};
  for (size_t i = 0; i < g->n; i++) {
    for (int q = 0; q < 5; q++)
      for (int k = 0; k < groups[q].dim; k++)
        if (!isfinite(arr[q][i * (size_t)groups[q].dim + (size_t)k]))
          return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: refusing to write: Gaussian %zu has a non-finite %s[%d]", path, i, groups[q].name, k);
    for (int k = 0; k < R; k++)
      for (int c = 0; c < 3; c++)
        if (!isfinite(g->sh_rest[i * MGS_SH_REST_MAX + (size_t)(k * 3 + c)]))
          return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: refusing to write: Gaussian %zu has a non-finite f_rest_%d", path, i, c * R + k);
  }
  return MGS_OK;
}

mgs_status mgs_ply_write_gaussians(const char *path, const mgs_gaussians *g, mgs_error *err) {
  if (!g) return mgs_error_set(err, MGS_ERR_ARG, "%s: no model to write", path);
  if (g->sh_degree < 0 || g->sh_degree > 3)
    return mgs_error_set(err, MGS_ERR_ARG, "%s: SH degree %d out of range 0..3", path, g->sh_degree);
  const int R = sh_rest_per_channel(g->sh_degree);
  mgs_status st = check_finite_named(path, g, R, err);
  if (st != MGS_OK) return st;

  mgs_atomic_file *af = NULL;
  FILE *fp = NULL;
  st = mgs_atomic_open(path, &af, &fp, err);
  if (st != MGS_OK) return st;
  /* The header exactly as the reference (plyfile) writes it; a model with an origin gets
     double x y z (world = origin + mean, in double): float32 cannot hold a position at
     1e5..1e6 to the model's precision, and PLY readers (plyfile, ours) take doubles. */
  const int world64 = !mgs_origin_is_zero(g->origin);
  fprintf(fp, "ply\nformat binary_little_endian 1.0\nelement vertex %zu\n", g->n);
  fputs(world64 ? "property double x\nproperty double y\nproperty double z\n" : "property float x\nproperty float y\nproperty float z\n", fp);
  fputs("property float nx\nproperty float ny\nproperty float nz\n"
        "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n", fp);
  for (int j = 0; j < 3 * R; j++) fprintf(fp, "property float f_rest_%d\n", j);
  /* a 2DGS model: two scale columns, as its authors write it */
  const int ns = g->kind == MGS_MODEL_2DGS ? 2 : 3;
  fputs("property float opacity\nproperty float scale_0\nproperty float scale_1\n", fp);
  if (ns == 3) fputs("property float scale_2\n", fp);
  fputs("property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n", fp);

  const int nf = 3 + 3 + 3 + 3 * R + 1 + ns + 4;
  const size_t row_bytes = (size_t)nf * 4 + (world64 ? 12 : 0);
  enum { ROWS_PER_CHUNK = 4096 };
  unsigned char *buf = malloc(row_bytes * ROWS_PER_CHUNK);
  if (!buf) {
    mgs_atomic_abort(af);
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  }
  for (size_t i0 = 0; i0 < g->n; i0 += ROWS_PER_CHUNK) {
    size_t i1 = i0 + ROWS_PER_CHUNK < g->n ? i0 + ROWS_PER_CHUNK : g->n;
    unsigned char *p = buf;
    for (size_t i = i0; i < i1; i++) {
      if (world64)
        for (int k = 0; k < 3; k++, p += 8) ply_put_f64le(p, g->origin[k] + (double)g->mean[i * 3 + (size_t)k]);
      else
        for (int k = 0; k < 3; k++, p += 4) ply_put_f32le(p, g->mean[i * 3 + (size_t)k]);
      for (int k = 0; k < 3; k++, p += 4) ply_put_f32le(p, 0.0f); /* normals: unused, as the reference */
      for (int k = 0; k < 3; k++, p += 4) ply_put_f32le(p, g->sh_dc[i * 3 + (size_t)k]);
      for (int c = 0; c < 3; c++)
        for (int k = 0; k < R; k++, p += 4) ply_put_f32le(p, g->sh_rest[i * MGS_SH_REST_MAX + (size_t)(k * 3 + c)]);
      ply_put_f32le(p, g->opacity[i]);
      p += 4;
      for (int k = 0; k < ns; k++, p += 4) ply_put_f32le(p, g->log_scale[i * 3 + (size_t)k]);
      for (int k = 0; k < 4; k++, p += 4) ply_put_f32le(p, g->rot[i * 4 + (size_t)k]);
    }
    size_t bytes = (size_t)(p - buf);
    if (fwrite(buf, 1, bytes, fp) != bytes) {
      free(buf);
      mgs_atomic_abort(af);
      return mgs_error_set(err, MGS_ERR_IO, "%s: write failed (disk full?)", path);
    }
  }
  free(buf);
  return mgs_atomic_commit(af, err);
}

mgs_status mgs_ply_read_gaussians_kind(const char *path, mgs_model_kind kind, const double *origin, mgs_gaussians **out,
                                       mgs_error *err) {
  mgs_status st = mgs_ply_read_gaussians_local(path, origin, out, err);
  if (st != MGS_OK || (*out)->kind == kind) return st;
  mgs_model_kind got = (*out)->kind;
  mgs_gaussians_destroy(*out);
  *out = NULL;
  return mgs_error_set(err, MGS_ERR_FORMAT, "%s: a %s model (%d scale columns), expected a %s model (%d)", path,
                       mgs_model_kind_name(got), got == MGS_MODEL_2DGS ? 2 : 3, mgs_model_kind_name(kind),
                       kind == MGS_MODEL_2DGS ? 2 : 3);
}
