/* Spawn and prune sets for the trainer (declared in topo/mgs_topo_select.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "topo/mgs_topo_select.h"
#include "vdb/mgs_vdb.h"

/* ---------------------------------------------------------------- spawn */

mgs_status mgs_topo_select_positions(const mgs_diagram *d, const mgs_diagram_filter *f,
                                     mgs_topo_place where, double **xyz, size_t **pair_idx,
                                     size_t *n, mgs_error *err) {
  *xyz = NULL; *n = 0;
  if (pair_idx) *pair_idx = NULL;
  if (!d || !f) return mgs_error_set(err, MGS_ERR_ARG, "topo select: null argument");
  size_t *idx, m;
  mgs_status st = mgs_diagram_select(d, f, &idx, &m, err);
  if (st != MGS_OK) return st;
  if (m == 0) return MGS_OK;
  double *pos = malloc(3 * m * sizeof *pos);
  if (!pos) { free(idx); return mgs_error_set(err, MGS_ERR_NOMEM, "topo select: out of memory (%zu pairs)", m); }
  size_t k = 0;
  for (size_t i = 0; i < m; i++) {
    const mgs_pair *p = &d->pairs[idx[i]];
    if (where == MGS_TOPO_PLACE_DEATH && !isfinite(p->death)) continue; /* no death cell */
    const double *x = where == MGS_TOPO_PLACE_DEATH ? p->d.pos : p->b.pos;
    memcpy(&pos[3 * k], x, 3 * sizeof *x);
    idx[k++] = idx[i];
  }
  if (k == 0) { free(pos); free(idx); return MGS_OK; }
  *xyz = pos; *n = k;
  if (pair_idx) *pair_idx = idx; else free(idx);
  return MGS_OK;
}

void mgs_topo_filter_surface_gaps(mgs_diagram_filter *f, double min_persistence, double max_death) {
  mgs_diagram_filter_init(f);
  f->dim = 1;
  f->min_persistence = min_persistence;
  f->death_min = nextafter(0.0, 1.0); /* strictly positive */
  f->death_max = max_death;
  f->include_essential = 0;
}

void mgs_topo_filter_literal_minima(mgs_diagram_filter *f, double min_persistence) {
  mgs_diagram_filter_init(f);
  f->dim = 0;
  f->min_persistence = min_persistence;
  f->include_essential = 0;
}

/* ---------------------------------------------------------------- components */

static size_t box_index(const int32_t dims[3], int64_t x, int64_t y, int64_t z) {
  return ((size_t)x * (size_t)dims[1] + (size_t)y) * (size_t)dims[2] + (size_t)z;
}

typedef struct comp_order { size_t n; int32_t id; } comp_order;
static int cmp_comp(const void *a, const void *b) {
  const comp_order *x = a, *y = b;
  if (x->n != y->n) return x->n > y->n ? -1 : 1;
  return x->id - y->id;
}

mgs_status mgs_topo_components_dense(const mgs_topo_field *f, double level, int connectivity,
                                     mgs_topo_components **out, mgs_error *err) {
  *out = NULL;
  if (!f || !f->values) return mgs_error_set(err, MGS_ERR_ARG, "topo components: null field");
  if (connectivity != 6 && connectivity != 26)
    return mgs_error_set(err, MGS_ERR_ARG, "topo components: connectivity %d is not 6 or 26", connectivity);
  if (f->dims[0] <= 0 || f->dims[1] <= 0 || f->dims[2] <= 0 || !(f->voxel_size > 0))
    return mgs_error_set(err, MGS_ERR_ARG, "topo components: empty box or voxel size <= 0");
  const int32_t *dims = f->dims;
  size_t nvox = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
  mgs_topo_components *c = calloc(1, sizeof *c);
  int32_t *label = c ? malloc(nvox * sizeof *label) : NULL;
  size_t cap_stack = 1024, cap_comp = 16;
  size_t *stack = malloc(cap_stack * sizeof *stack);
  mgs_topo_component *comp = malloc(cap_comp * sizeof *comp);
  double *csum = malloc(cap_comp * 3 * sizeof *csum);
  if (!c || !label || !stack || !comp || !csum) goto nomem;
  for (size_t i = 0; i < nvox; i++) label[i] = -1;
  double h = f->voxel_size, h3 = h * h * h;
  size_t ncomp = 0;
  int offs[26][3], noff = 0;
  for (int dx = -1; dx <= 1; dx++)
    for (int dy = -1; dy <= 1; dy++)
      for (int dz = -1; dz <= 1; dz++) {
        int l1 = abs(dx) + abs(dy) + abs(dz);
        if (l1 == 0 || (connectivity == 6 && l1 != 1)) continue;
        offs[noff][0] = dx; offs[noff][1] = dy; offs[noff][2] = dz; noff++;
      }
  for (size_t seed = 0; seed < nvox; seed++) {
    if (label[seed] >= 0 || !(f->values[seed] <= level)) continue;
    if (ncomp == cap_comp) {
      cap_comp *= 2;
      mgs_topo_component *nc = realloc(comp, cap_comp * sizeof *nc);
      if (!nc) goto nomem;
      comp = nc;
      double *ns = realloc(csum, cap_comp * 3 * sizeof *ns);
      if (!ns) goto nomem;
      csum = ns;
    }
    if (ncomp >= (size_t)INT32_MAX) goto nomem;
    int32_t id = (int32_t)ncomp++;
    mgs_topo_component *cc = &comp[id];
    memset(cc, 0, sizeof *cc);
    cc->min_value = INFINITY;
    double *s = &csum[3 * id];
    s[0] = s[1] = s[2] = 0;
    for (int k = 0; k < 3; k++) { cc->lo[k] = INT32_MAX; cc->hi[k] = INT32_MIN; }
    size_t top = 0;
    stack[top++] = seed;
    label[seed] = id;
    while (top) {
      size_t v = stack[--top];
      int64_t z = (int64_t)(v % (size_t)dims[2]);
      int64_t y = (int64_t)((v / (size_t)dims[2]) % (size_t)dims[1]);
      int64_t x = (int64_t)(v / ((size_t)dims[2] * (size_t)dims[1]));
      int32_t ijk[3] = {(int32_t)(x + f->origin[0]), (int32_t)(y + f->origin[1]), (int32_t)(z + f->origin[2])};
      cc->n_voxels++;
      if (f->density) cc->mass += (double)f->density[v] * h3;
      if (f->values[v] < cc->min_value) { cc->min_value = f->values[v]; memcpy(cc->min_voxel, ijk, sizeof ijk); }
      for (int k = 0; k < 3; k++) {
        if (ijk[k] < cc->lo[k]) cc->lo[k] = ijk[k];
        if (ijk[k] > cc->hi[k]) cc->hi[k] = ijk[k];
        s[k] += ijk[k];
      }
      for (int o = 0; o < noff; o++) {
        int64_t nx = x + offs[o][0], ny = y + offs[o][1], nz = z + offs[o][2];
        if (nx < 0 || ny < 0 || nz < 0 || nx >= dims[0] || ny >= dims[1] || nz >= dims[2]) continue;
        size_t w = box_index(dims, nx, ny, nz);
        if (label[w] >= 0 || !(f->values[w] <= level)) continue;
        label[w] = id;
        if (top == cap_stack) {
          size_t *ns = realloc(stack, 2 * cap_stack * sizeof *ns);
          if (!ns) goto nomem;
          stack = ns; cap_stack *= 2;
        }
        stack[top++] = w;
      }
    }
    cc->volume = (double)cc->n_voxels * h3;
    for (int k = 0; k < 3; k++) cc->centroid[k] = s[k] / (double)cc->n_voxels * h + f->translation[k];
  }
  /* renumber: largest first */
  comp_order *ord = malloc((ncomp ? ncomp : 1) * sizeof *ord);
  int32_t *remap = malloc((ncomp ? ncomp : 1) * sizeof *remap);
  mgs_topo_component *sorted = malloc((ncomp ? ncomp : 1) * sizeof *sorted);
  if (!ord || !remap || !sorted) { free(ord); free(remap); free(sorted); goto nomem; }
  for (size_t i = 0; i < ncomp; i++) ord[i] = (comp_order){comp[i].n_voxels, (int32_t)i};
  qsort(ord, ncomp, sizeof *ord, cmp_comp);
  for (size_t i = 0; i < ncomp; i++) { remap[ord[i].id] = (int32_t)i; sorted[i] = comp[ord[i].id]; }
  for (size_t i = 0; i < nvox; i++) if (label[i] >= 0) label[i] = remap[label[i]];
  free(ord); free(remap); free(comp); free(csum); free(stack);
  c->n = ncomp;
  c->comp = sorted;
  c->label = label;
  memcpy(c->origin, f->origin, sizeof c->origin);
  memcpy(c->dims, f->dims, sizeof c->dims);
  c->voxel_size = h;
  memcpy(c->translation, f->translation, sizeof c->translation);
  *out = c;
  return MGS_OK;
nomem:
  free(c); free(label); free(stack); free(comp); free(csum);
  return mgs_error_set(err, MGS_ERR_NOMEM, "topo components: out of memory (%zu voxels)", nvox);
}

mgs_status mgs_topo_components_vdb(const mgs_vdb_grid *sdf, const mgs_vdb_grid *density,
                                   double level, int connectivity, size_t max_voxels,
                                   mgs_topo_components **out, mgs_error *err) {
  *out = NULL;
  if (!sdf) return mgs_error_set(err, MGS_ERR_ARG, "topo components: null grid");
  int32_t lo[3], hi[3];
  if (!mgs_vdb_grid_active_bbox(sdf, lo, hi))
    return mgs_error_set(err, MGS_ERR_ARG, "topo components: grid '%s' is empty", mgs_vdb_grid_name(sdf));
  if (density && fabs(mgs_vdb_grid_voxel_size(density) - mgs_vdb_grid_voxel_size(sdf)) > 1e-9 * mgs_vdb_grid_voxel_size(sdf))
    return mgs_error_set(err, MGS_ERR_ARG, "topo components: density grid's voxel size differs from the SDF's");
  mgs_topo_field f;
  memset(&f, 0, sizeof f);
  double n = 1;
  for (int k = 0; k < 3; k++) {
    f.origin[k] = lo[k] - 1;
    f.dims[k] = hi[k] - lo[k] + 3;
    n *= f.dims[k];
  }
  if (max_voxels == 0) max_voxels = (size_t)1 << 31;
  if (n > (double)max_voxels)
    return mgs_error_set(err, MGS_ERR_NOMEM, "topo components: the active box of '%s' holds %.0f voxels (limit %zu)",
                         mgs_vdb_grid_name(sdf), n, max_voxels);
  size_t nv = (size_t)n, slab = (size_t)f.dims[1] * (size_t)f.dims[2];
  float *vals = malloc(nv * sizeof *vals);
  float *dens = density ? malloc(nv * sizeof *dens) : NULL;
  int32_t *ijk = malloc(slab * 3 * sizeof *ijk);
  if (!vals || !ijk || (density && !dens)) {
    free(vals); free(dens); free(ijk);
    return mgs_error_set(err, MGS_ERR_NOMEM, "topo components: out of memory (%zu voxels)", nv);
  }
  for (int32_t x = 0; x < f.dims[0]; x++) {
    size_t k = 0;
    for (int32_t y = 0; y < f.dims[1]; y++)
      for (int32_t z = 0; z < f.dims[2]; z++, k++) {
        ijk[3 * k] = f.origin[0] + x; ijk[3 * k + 1] = f.origin[1] + y; ijk[3 * k + 2] = f.origin[2] + z;
      }
    mgs_vdb_values(sdf, slab, ijk, vals + (size_t)x * slab, NULL);
    if (density) mgs_vdb_values(density, slab, ijk, dens + (size_t)x * slab, NULL);
  }
  free(ijk);
  f.values = vals;
  f.density = dens;
  f.voxel_size = mgs_vdb_grid_voxel_size(sdf);
  mgs_vdb_grid_translation(sdf, f.translation);
  mgs_status st = mgs_topo_components_dense(&f, level, connectivity, out, err);
  free(vals); free(dens);
  return st;
}

void mgs_topo_components_destroy(mgs_topo_components *c) {
  if (!c) return;
  free(c->comp);
  free(c->label);
  free(c);
}

int32_t mgs_topo_component_at(const mgs_topo_components *c, const int32_t ijk[3]) {
  if (!c) return -1;
  int64_t x = (int64_t)ijk[0] - c->origin[0], y = (int64_t)ijk[1] - c->origin[1], z = (int64_t)ijk[2] - c->origin[2];
  if (x < 0 || y < 0 || z < 0 || x >= c->dims[0] || y >= c->dims[1] || z >= c->dims[2]) return -1;
  return c->label[box_index(c->dims, x, y, z)];
}

size_t mgs_topo_floater_components(const mgs_topo_components *c, double max_volume,
                                   double max_mass, int32_t *ids) {
  size_t m = 0;
  if (!c) return 0;
  for (size_t i = 1; i < c->n; i++) { /* 0 is the largest: the object itself */
    const mgs_topo_component *cc = &c->comp[i];
    if ((max_volume > 0 && cc->volume < max_volume) || (max_mass > 0 && cc->mass < max_mass)) {
      if (ids) ids[m] = (int32_t)i;
      m++;
    }
  }
  return m;
}

/* ---------------------------------------------------------------- prune candidates */

typedef struct touch_ctx {
  const mgs_topo_components *c;
  const uint8_t *selected;  /* per component */
  int32_t lo[3], hi[3];     /* union bbox of the selected components */
  const mgs_gaussians *g;
  double k;
  uint8_t *hit;
} touch_ctx;

static void touch_range(void *ctx, size_t b, size_t e) {
  touch_ctx *t = ctx;
  const mgs_topo_components *c = t->c;
  double h = c->voxel_size;
  for (size_t i = b; i < e; i++) {
    const float *ls = &t->g->log_scale[3 * i], *mu = &t->g->mean[3 * i];
    double smax = exp(fmax(fmax(ls[0], ls[1]), ls[2]));
    double r = t->k * smax / h; /* radius in index units */
    double ctr[3];
    int64_t a[3], z[3];
    int empty = !isfinite(r);
    for (int k = 0; k < 3 && !empty; k++) {
      ctr[k] = ((double)mu[k] - c->translation[k]) / h;
      if (!isfinite(ctr[k])) { empty = 1; break; }
      double lo = ceil(ctr[k] - r - 0.5), hi = floor(ctr[k] + r + 0.5);
      if (lo < t->lo[k]) lo = t->lo[k];
      if (hi > t->hi[k]) hi = t->hi[k];
      if (lo > hi) empty = 1;
      a[k] = (int64_t)lo; z[k] = (int64_t)hi;
    }
    t->hit[i] = 0;
    if (empty) continue;
    double r2 = r * r;
    for (int64_t x = a[0]; x <= z[0] && !t->hit[i]; x++) {
      double dx = fmax(fabs(ctr[0] - (double)x) - 0.5, 0.0);
      if (dx * dx > r2) continue;
      for (int64_t y = a[1]; y <= z[1] && !t->hit[i]; y++) {
        double dy = fmax(fabs(ctr[1] - (double)y) - 0.5, 0.0);
        if (dx * dx + dy * dy > r2) continue;
        for (int64_t w = a[2]; w <= z[2]; w++) {
          double dz = fmax(fabs(ctr[2] - (double)w) - 0.5, 0.0);
          if (dx * dx + dy * dy + dz * dz > r2) continue;
          int32_t ijk[3] = {(int32_t)x, (int32_t)y, (int32_t)w};
          int32_t id = mgs_topo_component_at(c, ijk);
          if (id >= 0 && t->selected[id]) { t->hit[i] = 1; break; }
        }
      }
    }
  }
}

mgs_status mgs_topo_gaussians_touching(const mgs_topo_components *c, const int32_t *ids,
                                       size_t n_ids, const mgs_gaussians *g, double k_sigma,
                                       size_t **idx, size_t *n, mgs_error *err) {
  *idx = NULL; *n = 0;
  if (!c || !g || (n_ids && !ids)) return mgs_error_set(err, MGS_ERR_ARG, "topo prune: null argument");
  if (!(k_sigma > 0)) return mgs_error_set(err, MGS_ERR_ARG, "topo prune: k_sigma = %g must be > 0", k_sigma);
  if (n_ids == 0 || g->n == 0) return MGS_OK;
  touch_ctx t;
  memset(&t, 0, sizeof t);
  uint8_t *sel = calloc(c->n ? c->n : 1, 1);
  uint8_t *hit = malloc(g->n);
  if (!sel || !hit) { free(sel); free(hit); return mgs_error_set(err, MGS_ERR_NOMEM, "topo prune: out of memory"); }
  for (int k = 0; k < 3; k++) { t.lo[k] = INT32_MAX; t.hi[k] = INT32_MIN; }
  for (size_t i = 0; i < n_ids; i++) {
    if (ids[i] < 0 || (size_t)ids[i] >= c->n) {
      free(sel); free(hit);
      return mgs_error_set(err, MGS_ERR_ARG, "topo prune: component id %d out of range (%zu components)", ids[i], c->n);
    }
    sel[ids[i]] = 1;
    for (int k = 0; k < 3; k++) {
      if (c->comp[ids[i]].lo[k] < t.lo[k]) t.lo[k] = c->comp[ids[i]].lo[k];
      if (c->comp[ids[i]].hi[k] > t.hi[k]) t.hi[k] = c->comp[ids[i]].hi[k];
    }
  }
  t.c = c; t.selected = sel; t.g = g; t.k = k_sigma; t.hit = hit;
  mgs_parallel_for(0, g->n, 256, touch_range, &t);
  size_t m = 0;
  for (size_t i = 0; i < g->n; i++) m += hit[i];
  mgs_status st = MGS_OK;
  if (m) {
    size_t *out = malloc(m * sizeof *out);
    if (!out) st = mgs_error_set(err, MGS_ERR_NOMEM, "topo prune: out of memory");
    else {
      size_t k = 0;
      for (size_t i = 0; i < g->n; i++) if (hit[i]) out[k++] = i;
      *idx = out; *n = m;
    }
  }
  free(sel); free(hit);
  return st;
}
