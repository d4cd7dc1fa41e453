/* PlayCanvas/SuperSplat's compressed 3DGS .ply -> a 3DGS model (core/ply_compressed.h).
 * The layout, as splat-transform writes and reads it: splat i belongs to chunk i / 256;
 * position and log-scale are 11-10-11-bit fractions of the chunk's [min, max] box; the
 * rotation keeps its largest component's index in the top 2 bits and the other three in
 * 10 bits each, in [-1/sqrt2, 1/sqrt2]; the colour is RGBA8 (RGB the DC colour
 * 0.5 + SH_C0 f_dc, a fraction of the chunk's colour range when the chunk has one; A the
 * opacity after the sigmoid); SH-rest coefficients are 8-bit over [-4, 4]. */
#include "core/ply_compressed.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CHUNK 256
#define SH_C0 0.28209479177387814

enum { C_MIN_X, C_MIN_Y, C_MIN_Z, C_MAX_X, C_MAX_Y, C_MAX_Z, C_MIN_SX, C_MIN_SY, C_MIN_SZ, C_MAX_SX, C_MAX_SY, C_MAX_SZ,
       C_MIN_R, C_MIN_G, C_MIN_B, C_MAX_R, C_MAX_G, C_MAX_B, C_N };
static const char *const chunk_names[C_N] = {"min_x", "min_y", "min_z", "max_x", "max_y", "max_z",
                                             "min_scale_x", "min_scale_y", "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z",
                                             "min_r", "min_g", "min_b", "max_r", "max_g", "max_b"};
static const char *const packed_names[4] = {"packed_position", "packed_rotation", "packed_scale", "packed_color"};

static int find_element(const ply_file *pf, const char *name) {
  for (int i = 0; i < pf->n_elems; i++)
    if (!strcmp(pf->elems[i].name, name)) return i;
  return -1;
}

int ply_is_compressed_gaussians(const ply_file *pf) {
  const int v = find_element(pf, "vertex");
  return v >= 0 && ply_find_property(&pf->elems[v], "packed_position") >= 0;
}

typedef struct {
  const char *path;
  int col[C_N];
  int colors;       /* the chunks carry colour bounds */
  float *chunks;    /* [chunk][C_N] */
  int pcol[4];
  int rcol[MGS_SH_REST_MAX];
  int n_rest, rest_per_channel, degree;
  size_t n, n_chunks;
  mgs_gaussians *g;
  double *xyz64;
} cread;

static mgs_status chunk_row(void *ctx, size_t row, const double *v, mgs_error *err) {
  cread *r = ctx;
  if (row == 0 && !(r->chunks = calloc(r->n_chunks * C_N, sizeof(float)))) /* the count is backed by the file now */
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu chunks", r->path, r->n_chunks);
  for (int k = 0; k < C_N; k++) {
    if (r->col[k] < 0) continue;
    const double x = v[r->col[k]];
    if (!isfinite(x))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: chunk %zu: property '%s' is not finite (%g)", r->path, row, chunk_names[k], x);
    r->chunks[row * C_N + k] = (float)x;
  }
  return MGS_OK;
}

static double unorm(uint32_t v, int bits) { return (double)(v & ((1u << bits) - 1u)) / (double)((1u << bits) - 1u); }
static double lerp(double a, double b, double t) { return a * (1 - t) + b * t; }

static mgs_status vertex_row(void *ctx, size_t row, const double *v, mgs_error *err) {
  cread *r = ctx;
  if (row == 0) { /* allocated only now: the container has checked the count against the file size */
    size_t first = 0;
    r->g = mgs_gaussians_create(r->n, r->degree);
    r->xyz64 = malloc(r->n * 3 * sizeof(double));
    if (!r->g || !r->xyz64 || mgs_gaussians_append(r->g, r->n, &first, err) != MGS_OK)
      return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu Gaussians", r->path, r->n);
  }
  const float *c = r->chunks + (row / CHUNK) * C_N;
  uint32_t p[4];
  for (int k = 0; k < 4; k++) p[k] = (uint32_t)v[r->pcol[k]];
  mgs_gaussians *g = r->g;
  const double t3[3] = {unorm(p[0] >> 21, 11), unorm(p[0] >> 11, 10), unorm(p[0], 11)};
  const double s3[3] = {unorm(p[2] >> 21, 11), unorm(p[2] >> 11, 10), unorm(p[2], 11)};
  for (int k = 0; k < 3; k++) {
    r->xyz64[row * 3 + (size_t)k] = lerp(c[C_MIN_X + k], c[C_MAX_X + k], t3[k]);
    g->log_scale[row * 3 + (size_t)k] = (float)lerp(c[C_MIN_SX + k], c[C_MAX_SX + k], s3[k]);
  }
  /* rotation: the three smaller components, the largest from the unit norm */
  const double norm = sqrt(2.0);
  const double a = (unorm(p[1] >> 20, 10) - 0.5) * norm, b = (unorm(p[1] >> 10, 10) - 0.5) * norm,
               d = (unorm(p[1], 10) - 0.5) * norm;
  const double m = sqrt(fmax(0.0, 1.0 - (a * a + b * b + d * d)));
  const int which = (int)(p[1] >> 30);
  const double small[3] = {a, b, d};
  for (int k = 0, j = 0; k < 4; k++) g->rot[row * 4 + (size_t)k] = (float)(k == which ? m : small[j++]);
  /* colour and opacity */
  const double col[4] = {unorm(p[3] >> 24, 8), unorm(p[3] >> 16, 8), unorm(p[3] >> 8, 8), unorm(p[3], 8)};
  for (int k = 0; k < 3; k++) {
    const double cc = r->colors ? lerp(c[C_MIN_R + k], c[C_MAX_R + k], col[k]) : col[k];
    g->sh_dc[row * 3 + (size_t)k] = (float)((cc - 0.5) / SH_C0);
  }
  /* 8 bits cannot say 0 or 1 exactly: 0 and 255 mean below 1/510 and above 1 - 1/510, and the
     logit stays finite there */
  const double w = fmin(fmax(col[3], 0.5 / 255.0), 1.0 - 0.5 / 255.0);
  g->opacity[row] = (float)-log(1.0 / w - 1.0);
  memset(g->sh_rest + row * MGS_SH_REST_MAX, 0, sizeof(float) * MGS_SH_REST_MAX);
  return MGS_OK;
}

static mgs_status sh_row(void *ctx, size_t row, const double *v, mgs_error *err) {
  cread *r = ctx;
  float *rest = r->g->sh_rest + row * MGS_SH_REST_MAX;
  const int R = r->rest_per_channel;
  for (int j = 0; j < r->n_rest; j++) {
    const double q = v[r->rcol[j]];
    const double n = q == 0 ? 0.0 : q == 255 ? 1.0 : (q + 0.5) / 256.0;
    rest[(j % R) * 3 + j / R] = (float)((n - 0.5) * 8.0); /* file: channel-major; memory: [k][c] */
  }
  (void)err;
  return MGS_OK;
}

mgs_status ply_read_compressed_gaussians(ply_file *pf, mgs_gaussians **g, double **xyz64, mgs_error *err) {
  *g = NULL;
  *xyz64 = NULL;
  cread r;
  memset(&r, 0, sizeof r);
  r.path = pf->path;
  const int ci = find_element(pf, "chunk"), vi = find_element(pf, "vertex"), si = find_element(pf, "sh");
  if (ci < 0) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: packed vertices but no 'chunk' element (not a compressed 3DGS .ply?)", pf->path);
  const ply_element *ce = &pf->elems[ci], *ve = &pf->elems[vi];
  for (int k = 0; k < C_N; k++) {
    r.col[k] = ply_find_property(ce, chunk_names[k]);
    if (r.col[k] >= 0 && (ce->props[r.col[k]].is_list || ce->props[r.col[k]].type != PLY_FLOAT32))
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: chunk property '%s' has type %s; expected float", pf->path, chunk_names[k],
                           ply_type_name(ce->props[r.col[k]].type));
    if (r.col[k] < 0 && k < C_MIN_R)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing chunk property '%s'", pf->path, chunk_names[k]);
  }
  int ncol = 0;
  for (int k = C_MIN_R; k < C_N; k++) ncol += r.col[k] >= 0;
  if (ncol != 0 && ncol != 6)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: the chunks have %d of the 6 colour bounds (min_r .. max_b)", pf->path, ncol);
  r.colors = ncol == 6;
  for (int k = 0; k < 4; k++) {
    r.pcol[k] = ply_find_property(ve, packed_names[k]);
    if (r.pcol[k] < 0) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing vertex property '%s'", pf->path, packed_names[k]);
    if (ve->props[r.pcol[k]].is_list || ve->props[r.pcol[k]].type != PLY_UINT32)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex property '%s' has type %s; expected uint", pf->path, packed_names[k],
                           ply_type_name(ve->props[r.pcol[k]].type));
  }
  const size_t n = ve->count;
  if (ce->count != (n + CHUNK - 1) / CHUNK)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %zu chunks for %zu vertices; expected %zu (one per 256)", pf->path, ce->count, n,
                         (n + CHUNK - 1) / CHUNK);
  int degree = 0;
  if (si >= 0) {
    const ply_element *se = &pf->elems[si];
    if (se->count != n)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %zu 'sh' rows for %zu vertices", pf->path, se->count, n);
    r.n_rest = se->n_props;
    degree = r.n_rest == 9 ? 1 : r.n_rest == 24 ? 2 : r.n_rest == 45 ? 3 : -1;
    if (degree < 0)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %d 'sh' properties; expected 9, 24 or 45 (SH degree 1..3)", pf->path, r.n_rest);
    r.rest_per_channel = (degree + 1) * (degree + 1) - 1;
    for (int j = 0; j < r.n_rest; j++) {
      char nm[32];
      snprintf(nm, sizeof nm, "f_rest_%d", j);
      r.rcol[j] = ply_find_property(se, nm);
      if (r.rcol[j] < 0) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing 'sh' property '%s'", pf->path, nm);
      if (se->props[r.rcol[j]].is_list || se->props[r.rcol[j]].type != PLY_UINT8)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: 'sh' property '%s' has type %s; expected uchar", pf->path, nm,
                             ply_type_name(se->props[r.rcol[j]].type));
    }
  }
  /* The counts are consistent; each row callback allocates at its row 0, after the
     container has checked the element's count against the bytes left. */
  r.n = n;
  r.n_chunks = ce->count;
  r.degree = degree;
  mgs_status st = MGS_OK;
  if (n == 0) {
    if (!(r.g = mgs_gaussians_create(0, degree)) || !(r.xyz64 = malloc(3 * sizeof(double)))) {
      st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", pf->path);
      goto done;
    }
  } else if ((st = ply_read_element(pf, ci, chunk_row, &r, err)) || (st = ply_read_element(pf, vi, vertex_row, &r, err)) ||
             (si >= 0 && (st = ply_read_element(pf, si, sh_row, &r, err)))) {
    goto done;
  }
  *g = r.g;
  *xyz64 = r.xyz64;
  r.g = NULL;
  r.xyz64 = NULL;
done:
  free(r.chunks);
  free(r.xyz64);
  mgs_gaussians_destroy(r.g);
  return st;
}
