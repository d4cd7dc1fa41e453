/* Plain point clouds (x y z [red green blue]) for initial points: read any .ply with a
 * vertex element holding numeric x y z, write the reference's storePly layout
 * (float x y z nx ny nz, uchar red green blue). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/mgs_fs.h"
#include "core/mgs_ply.h"
#include "core/ply_format.h"

void mgs_point_cloud_destroy(mgs_point_cloud *pc) {
  if (!pc) return;
  free(pc->xyz);
  free(pc->rgb);
  free(pc->xyz64);
  free(pc);
}

typedef struct {
  const char *path;
  const ply_element *el;
  int cx, cy, cz, cr, cg, cb;
  double colour_scale; /* 1/255 for uchar, 1/65535 for ushort, 1 for float */
  mgs_point_cloud *pc;
} pread;

static mgs_status alloc_cloud(mgs_point_cloud **out, size_t n) {
  mgs_point_cloud *pc = calloc(1, sizeof *pc);
  if (!pc) return MGS_ERR_NOMEM;
  pc->n = n;
  pc->xyz = malloc(sizeof(float) * 3 * (n ? n : 1));
  pc->rgb = malloc(sizeof(float) * 3 * (n ? n : 1));
  pc->xyz64 = malloc(sizeof(double) * 3 * (n ? n : 1));
  if (!pc->xyz || !pc->rgb || !pc->xyz64) { mgs_point_cloud_destroy(pc); return MGS_ERR_NOMEM; }
  *out = pc;
  return MGS_OK;
}

static mgs_status point_row(void *ctx, size_t row, const double *v, mgs_error *err) {
  pread *r = ctx;
  if (row == 0 && alloc_cloud(&r->pc, r->el->count) != MGS_OK)
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu points", r->path, r->el->count);
  const int cols[3] = {r->cx, r->cy, r->cz};
  static const char *names[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; k++) {
    float f = (float)v[cols[k]];
    if (!isfinite(f))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: vertex %zu: property '%s' is not finite (%g)", r->path, row, names[k], v[cols[k]]);
    r->pc->xyz[row * 3 + (size_t)k] = f;
    r->pc->xyz64[row * 3 + (size_t)k] = v[cols[k]];
  }
  if (r->cr >= 0) {
    const int cc[3] = {r->cr, r->cg, r->cb};
    for (int k = 0; k < 3; k++) {
      double c = v[cc[k]] * r->colour_scale;
      if (!isfinite(c))
        return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: vertex %zu: colour is not finite", r->path, row);
      r->pc->rgb[row * 3 + (size_t)k] = (float)(c < 0 ? 0 : c > 1 ? 1 : c);
    }
  } else {
    for (int k = 0; k < 3; k++) r->pc->rgb[row * 3 + (size_t)k] = 0.5f;
  }
  return MGS_OK;
}

static double colour_scale_for(ply_type t) {
  switch (t) {
    case PLY_UINT8: return 1.0 / 255.0;
    case PLY_UINT16: return 1.0 / 65535.0;
    case PLY_FLOAT32: case PLY_FLOAT64: return 1.0;
    default: return 0.0;
  }
}

mgs_status mgs_ply_read_points(const char *path, mgs_point_cloud **out, mgs_error *err) {
  *out = NULL;
  ply_file pf;
  mgs_status st = ply_open(path, &pf, err);
  if (st != MGS_OK) return st;
  int vi = -1;
  for (int i = 0; i < pf.n_elems; i++)
    if (strcmp(pf.elems[i].name, "vertex") == 0) { vi = i; break; }
  if (vi < 0) { ply_close(&pf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: no 'vertex' element", path); }
  const ply_element *el = &pf.elems[vi];
  pread r;
  memset(&r, 0, sizeof r);
  r.path = path;
  r.el = el;
  int *cols[3] = {&r.cx, &r.cy, &r.cz};
  static const char *xyz[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; k++) {
    *cols[k] = ply_find_property(el, xyz[k]);
    if (*cols[k] < 0) { ply_close(&pf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing vertex property '%s'", path, xyz[k]); }
    if (el->props[*cols[k]].is_list) { ply_close(&pf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex property '%s' is a list", path, xyz[k]); }
  }
  r.cr = ply_find_property(el, "red");
  r.cg = ply_find_property(el, "green");
  r.cb = ply_find_property(el, "blue");
  if ((r.cr >= 0) != (r.cg >= 0) || (r.cr >= 0) != (r.cb >= 0)) {
    ply_close(&pf);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex colours need all of red, green, blue", path);
  }
  if (r.cr >= 0) {
    ply_type t = el->props[r.cr].type;
    if (el->props[r.cg].type != t || el->props[r.cb].type != t || el->props[r.cr].is_list || el->props[r.cg].is_list ||
        el->props[r.cb].is_list || colour_scale_for(t) == 0.0) {
      ply_close(&pf);
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex colours must all be uchar, ushort or float (red is %s)", path, ply_type_name(t));
    }
    r.colour_scale = colour_scale_for(t);
  }
  if (el->count == 0) {
    st = alloc_cloud(&r.pc, 0) == MGS_OK ? ply_read_element(&pf, vi, point_row, &r, err)
                                         : mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  } else {
    st = ply_read_element(&pf, vi, point_row, &r, err);
  }
  ply_close(&pf);
  if (st != MGS_OK) { mgs_point_cloud_destroy(r.pc); return st; }
  *out = r.pc;
  return MGS_OK;
}

mgs_status mgs_ply_write_points(const char *path, const mgs_point_cloud *pc, mgs_error *err) {
  if (!pc) return mgs_error_set(err, MGS_ERR_ARG, "%s: no point cloud to write", path);
  for (size_t i = 0; i < pc->n * 3; i++)
    if (!isfinite(pc->xyz[i]) || (pc->rgb && !isfinite(pc->rgb[i])))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: refusing to write: point %zu is not finite", path, i / 3);
  mgs_atomic_file *af = NULL;
  FILE *fp = NULL;
  mgs_status st = mgs_atomic_open(path, &af, &fp, err);
  if (st != MGS_OK) return st;
  fprintf(fp, "ply\nformat binary_little_endian 1.0\nelement vertex %zu\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n", pc->n);
  for (size_t i = 0; i < pc->n; i++) {
    unsigned char row[27];
    for (int k = 0; k < 3; k++) ply_put_f32le(row + 4 * k, pc->xyz[i * 3 + (size_t)k]);
    for (int k = 0; k < 3; k++) ply_put_f32le(row + 12 + 4 * k, 0.0f);
    for (int k = 0; k < 3; k++) {
      float c = pc->rgb ? pc->rgb[i * 3 + (size_t)k] : 0.5f;
      c = c < 0 ? 0 : c > 1 ? 1 : c;
      row[24 + k] = (unsigned char)lrintf(c * 255.0f);
    }
    if (fwrite(row, 1, sizeof row, fp) != sizeof row) {
      mgs_atomic_abort(af);
      return mgs_error_set(err, MGS_ERR_IO, "%s: write failed (disk full?)", path);
    }
  }
  return mgs_atomic_commit(af, err);
}
