/* The persistence pipeline shared by the dense and sparse paths: sort the reduced complex,
 * pair (D0 union-find, D2 union-find on the dual, D1 reduction), and turn rank pairs into a
 * diagram. With the discrete gradient (default) the reduced complex is the Morse complex of
 * the critical cells (topo/gradient_lowerstar.c, topo/morse_boundary.c): the lower-star
 * matching pairs cells of equal value only, so every sublevel set is a union of matched pairs
 * and critical cells and the filtered Morse complex has the same diagram (Mischaikow-Nanda
 * 2013). Critical cells are still ordered by (value, dim, key), a filtration of the Morse
 * complex since a Morse boundary holds cells of lower dimension and value <= the cell's.
 *
 * Why the reduced complex gives the box's diagram exactly:
 *  - Top: every cell of value +w (= top) enters at the last filtration value, when the box
 *    is complete and contractible. So the box's pairs with death < top are the pairs of
 *    K_{<top}; every class of K_{<top} still alive at the end (an essential class there)
 *    dies at top in the box, except one H0 class (the oldest), which stays essential.
 *    Classes born at top have zero persistence. Hence cells at top are never built.
 *  - Bottom: the cells of value -w (= lo) form a subcomplex C entering at one value. The
 *    matching "odd-x cell with its right x-face; even-x cell with its left x-coface when that
 *    is in C" is acyclic (V-paths move strictly left) and pairs cells of equal value, so the
 *    Morse complex has the same persistence (Mischaikow-Nanda 2013). Its unmatched C cells
 *    are the left ends of x-runs; the flow maps an even-x face in C to its run's left end
 *    and an odd-x face in C to nothing (cub_boundary). Interior regions thus cost their
 *    x-run ends (a surface), not their volume. */
#include <stdlib.h>
#include <string.h>
#include "core/mgs_log.h"
#include "topo/cubical_internal.h"

void mgs_topo_opts_default(mgs_topo_opts *o) {
  memset(o, 0, sizeof *o);
  o->construction = MGS_TOPO_V;
  o->filtration = MGS_TOPO_SUBLEVEL;
  o->half_width = INFINITY;
  o->min_persistence = 0;
  o->voxel_size = 1;
}

/* Order-preserving map of a float to uint32. */
static inline uint32_t fkey(float v) {
  uint32_t u;
  memcpy(&u, &v, 4);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

static int cmp_cell(const void *pa, const void *pb) {
  const cub_cell *a = pa, *b = pb;
  if (a->v != b->v) return a->v < b->v ? -1 : 1;
  int da = cub_key_dim(a->key), db = cub_key_dim(b->key);
  if (da != db) return da < db ? -1 : 1;
  return a->key < b->key ? -1 : (a->key > b->key);
}

/* LSD radix sort on (value, dim, key): 63-bit key (3 x 21 bits), then dim, then value. */
static mgs_status sort_cells(cub_cell *c, size_t n, mgs_error *err) {
  if (n < 4096) { qsort(c, n, sizeof *c, cmp_cell); return MGS_OK; }
  cub_cell *tmp = malloc(n * sizeof *tmp);
  if (!tmp) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (sort of %zu cells)", n);
  size_t *cnt = malloc(65536 * sizeof *cnt);
  if (!cnt) { free(tmp); return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (sort)"); }
  /* passes: key bits 0-15, 16-31, 32-47, 48-62, dim (2 bits), value 0-15, value 16-31 */
  for (int pass = 0; pass < 7; pass++) {
    memset(cnt, 0, 65536 * sizeof *cnt);
    uint32_t minb = UINT32_MAX, maxb = 0;
#define DIGIT(e) (pass < 4 ? (uint32_t)(((e).key >> (16 * pass)) & 0xffff) \
                 : pass == 4 ? (uint32_t)cub_key_dim((e).key) : pass == 5 ? (fkey((e).v) & 0xffff) : (fkey((e).v) >> 16))
    for (size_t i = 0; i < n; i++) {
      uint32_t d = DIGIT(c[i]);
      cnt[d]++;
      if (d < minb) minb = d;
      if (d > maxb) maxb = d;
    }
    if (minb == maxb) continue; /* all equal: this pass keeps the order */
    size_t sum = 0;
    for (size_t d = 0; d < 65536; d++) { size_t x = cnt[d]; cnt[d] = sum; sum += x; }
    for (size_t i = 0; i < n; i++) tmp[cnt[DIGIT(c[i])]++] = c[i];
#undef DIGIT
    memcpy(c, tmp, n * sizeof *c);
  }
  free(cnt);
  free(tmp);
  return MGS_OK;
}

static void cell_pos(const cub_run *run, uint64_t key, mgs_pair_end *e) {
  int32_t p[3];
  cub_unkey(key, &p[0], &p[1], &p[2]);
  e->cell = key;
  cub_cell_voxel(run->f, p[0], p[1], p[2], e->voxel);
  double off = run->f->construction == MGS_TOPO_V ? 0.0 : 0.5; /* T: voxel x spans a = 2x+1 */
  for (int i = 0; i < 3; i++) e->pos[i] = run->origin[i] + run->voxel_size * (0.5 * p[i] - off);
}

mgs_status cub_persistence(const cub_run *run, cub_cells *cells, mgs_diagram **out,
                           mgs_topo_stats *stats, mgs_error *err) {
  double t0 = mgs_now();
  const cub_field *f = run->f;
  cub_complex cx = {0};
  cx.f = f;
  cx.cells = cells->c;
  cx.n = cells->n;
  mgs_status st = MGS_OK;
  uint8_t *flags = NULL;
  cub_pairs pairs = {0};
  mgs_diagram *d = NULL;
  if (cx.n >= UINT32_MAX) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: %zu cells exceed the 2^32 limit", cx.n); goto done; }
  if ((st = sort_cells(cx.cells, cx.n, err)) != MGS_OK) goto done;
  {
    size_t cap = 16;
    while (cap < 2 * cx.n) cap <<= 1;
    cx.slot = malloc(cap * sizeof *cx.slot);
    if (!cx.slot) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (index of %zu cells)", cx.n); goto done; }
    memset(cx.slot, 0xff, cap * sizeof *cx.slot);
    cx.mask = cap - 1;
    for (size_t i = 0; i < cx.n; i++) {
      size_t h = cub_hash(cx.cells[i].key) & cx.mask;
      while (cx.slot[h] != UINT32_MAX) h = (h + 1) & cx.mask;
      cx.slot[h] = (uint32_t)i;
      cx.n_dim[cub_key_dim(cx.cells[i].key)]++;
    }
  }
  if (run->gradient) {
    double tm = mgs_now();
    if ((st = cub_morse_boundaries(&cx, err)) != MGS_OK) goto done;
    if (stats) stats->seconds_morse = mgs_now() - tm;
  }
  flags = calloc(cx.n ? cx.n : 1, 1);
  if (!flags) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (flags)"); goto done; }
  if ((st = cub_pairs_d0(&cx, flags, &pairs, err)) != MGS_OK) goto done;
  {
    int dual = 0; /* the dual union-find by default; the twist reduction on request or fallback */
    if (!run->opts->d2_reduction && (st = cub_pairs_d2_dual(&cx, flags, &pairs, &dual, err)) != MGS_OK) goto done;
    if (!dual && (st = cub_pairs_d2(&cx, flags, &pairs, err)) != MGS_OK) goto done;
    if (stats) stats->d2_union_find = dual;
  }
  if ((st = cub_pairs_d1(&cx, flags, &pairs, err)) != MGS_OK) goto done;

  d = mgs_diagram_create();
  if (!d) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (diagram)"); goto done; }
  /* the oldest essential H0 class is the box's one essential class */
  uint32_t oldest = UINT32_MAX;
  for (size_t i = 0; i < pairs.n; i++)
    if (pairs.p[i].dim == 0 && pairs.p[i].death == UINT32_MAX && pairs.p[i].birth < oldest) oldest = pairs.p[i].birth;
  size_t nonzero = 0, truncated = 0, per_dim[3] = {0, 0, 0};
  for (size_t i = 0; i < pairs.n; i++) {
    const cub_pair *p = &pairs.p[i];
    mgs_pair q;
    memset(&q, 0, sizeof q);
    q.dim = (int)p->dim;
    q.birth = cx.cells[p->birth].v;
    int essential_here = p->death == UINT32_MAX;
    if (!essential_here) q.death = cx.cells[p->death].v;
    else if (p->dim == 0 && p->birth == oldest) q.death = INFINITY;
    else q.death = isfinite(f->top) ? (double)f->top : INFINITY;
    if (!(q.death - q.birth > 0)) continue;
    nonzero++;
    if (!(q.death - q.birth > run->opts->min_persistence)) continue;
    cell_pos(run, cx.cells[p->birth].key, &q.b);
    if (!essential_here) cell_pos(run, cx.cells[p->death].key, &q.d);
    q.truncated = (isfinite(f->top) && q.death == (double)f->top) || (isfinite(f->lo) && q.birth == (double)f->lo);
    truncated += (size_t)q.truncated;
    per_dim[q.dim]++;
    if ((st = mgs_diagram_push(d, &q, err)) != MGS_OK) goto done;
  }
  mgs_diagram_sort(d);
  d->n_cells = stats ? stats->cells_total : cx.n;
  /* cells of positive-persistence pairs and essential classes: what an optimal discrete
   * gradient would leave */
  size_t persistent = 0;
  for (size_t i = 0; i < pairs.n; i++) {
    const cub_pair *p = &pairs.p[i];
    if (p->death == UINT32_MAX) persistent += 1;
    else if (cx.cells[p->death].v > cx.cells[p->birth].v) persistent += 2;
  }
  (void)nonzero;
  /* critical cells after the discrete gradient (the full-reduction path has none: all) */
  d->n_critical = cx.n;
  d->seconds = mgs_now() - t0;
  if (stats) {
    size_t band = run->gradient ? run->band_cells : cx.n;
    stats->band_cells = band;
    stats->cells_built = cx.n;
    stats->critical_cells = cx.n;
    stats->persistent_cells = persistent;
    stats->reduction_ratio = band ? 1.0 - (double)cx.n / (double)band : 0;
    for (int k = 0; k < 3; k++) stats->pairs_d[k] = per_dim[k];
    stats->truncated = truncated;
    stats->seconds_pairs = d->seconds;
    size_t bytes = cells->cap * sizeof(cub_cell) + (cx.mask + 1) * sizeof(uint32_t) + cx.n * (1 + 4 + 4) +
                   (cx.bstart ? (cx.n + 1) * sizeof(uint64_t) + cx.bstart[cx.n] * sizeof(uint32_t) : 0);
    if (bytes > stats->peak_bytes) stats->peak_bytes = bytes;
    d->n_active_voxels = stats->active_voxels;
  }
  *out = d;
  d = NULL;
done:
  mgs_diagram_destroy(d);
  free(flags);
  free(pairs.p);
  free(cx.slot);
  free(cx.bstart);
  free(cx.bpool);
  return st;
}

/* ---------------------------------------------------------------- dense path */
typedef struct dense_ctx { const float *v; int nx, ny, nz; } dense_ctx;

static float dense_voxel(const void *ctx, int32_t x, int32_t y, int32_t z) {
  const dense_ctx *d = ctx;
  if (x < 0 || y < 0 || z < 0 || x >= d->nx || y >= d->ny || z >= d->nz) return INFINITY;
  return d->v[((size_t)x * d->ny + y) * d->nz + z];
}

mgs_status mgs_topo_check_opts(const mgs_topo_opts *o, mgs_error *err) {
  if (o->construction != MGS_TOPO_V && o->construction != MGS_TOPO_T)
    return mgs_error_set(err, MGS_ERR_ARG, "persistence: unknown construction %d", (int)o->construction);
  if (o->filtration != MGS_TOPO_SUBLEVEL && o->filtration != MGS_TOPO_SUPERLEVEL)
    return mgs_error_set(err, MGS_ERR_ARG, "persistence: unknown filtration %d", (int)o->filtration);
  if (!(o->half_width > 0)) return mgs_error_set(err, MGS_ERR_ARG, "persistence: band half-width must be > 0 (got %g)", o->half_width);
  if (!(o->min_persistence >= 0)) return mgs_error_set(err, MGS_ERR_ARG, "persistence: min persistence must be >= 0 (got %g)", o->min_persistence);
  if (!(o->voxel_size > 0) || !isfinite(o->voxel_size)) return mgs_error_set(err, MGS_ERR_ARG, "persistence: voxel size must be finite and > 0 (got %g)", o->voxel_size);
  return MGS_OK;
}

mgs_status mgs_topo_persistence_dense_stats(const float *values, int nx, int ny, int nz,
                                            const mgs_topo_opts *opts_in, mgs_diagram **out,
                                            mgs_topo_stats *stats_out, mgs_error *err) {
  double t0 = mgs_now();
  mgs_topo_opts opts;
  if (opts_in) opts = *opts_in; else mgs_topo_opts_default(&opts);
  if (!values || !out) return mgs_error_set(err, MGS_ERR_ARG, "persistence: null argument");
  *out = NULL;
  mgs_status st = mgs_topo_check_opts(&opts, err);
  if (st != MGS_OK) return st;
  if (nx < 1 || ny < 1 || nz < 1 || nx > 500000 || ny > 500000 || nz > 500000)
    return mgs_error_set(err, MGS_ERR_ARG, "persistence: bad dense dimensions %dx%dx%d", nx, ny, nz);
  size_t nv = (size_t)nx * ny * nz;
  float w = (float)opts.half_width;
  float *cl = malloc(nv * sizeof *cl);
  if (!cl) return mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%zu voxels)", nv);
  for (size_t i = 0; i < nv; i++) {
    float v = values[i];
    if (!isfinite(v)) {
      free(cl);
      return mgs_error_set(err, MGS_ERR_NUMERIC, "persistence: non-finite value at voxel %zu", i);
    }
    if (opts.filtration == MGS_TOPO_SUPERLEVEL) v = -v;
    cl[i] = (v < -w ? -w : (v > w ? w : v)) + 0.0f; /* -0 -> +0: one total order */
  }
  dense_ctx dc = {cl, nx, ny, nz};
  cub_field f = {dense_voxel, &dc, -w, w, (int)opts.construction, NULL};
  int ext = opts.construction == MGS_TOPO_V ? -1 : 1; /* doubled extent: 2n-1 (V) or 2n+1 (T) */
  int32_t ea = 2 * nx + ext, eb = 2 * ny + ext, ec = 2 * nz + ext;
  mgs_topo_stats stats;
  memset(&stats, 0, sizeof stats);
  stats.active_voxels = nv;
  stats.cells_total = (size_t)ea * eb * ec;
  stats.effective_w = opts.half_width;
  cub_cells cells = {0};
  int gradient = !opts.full_reduction, dual = opts.construction == MGS_TOPO_T;
  size_t band = 0;
  if (gradient) {
    /* critical cells of the lower stars of the voxels strictly inside (lo, top) */
    cub_lower_star_tables();
    for (int32_t x = 0; x < nx && st == MGS_OK; x++)
      for (int32_t y = 0; y < ny && st == MGS_OK; y++)
        for (int32_t z = 0; z < nz && st == MGS_OK; z++) {
          float fv = cl[((size_t)x * ny + y) * nz + z];
          if (!(fv > f.lo && fv < f.top)) continue;
          float nb[27];
          for (int i = 0; i < 27; i++) nb[i] = dense_voxel(&dc, x + i / 9 - 1, y + i / 3 % 3 - 1, z + i % 3 - 1);
          if (dual)
            for (int i = 0; i < 27; i++) nb[i] = -nb[i]; /* T: lower stars of -f, read dually */
          size_t nl;
          if (!cub_lower_star_count(nb, &nl)) { band += nl; continue; } /* regular: no critical cell */
          cub_ls ls;
          cub_lower_star(nb, &ls);
          band += ls.n;
          cub_cell cc[27];
          size_t k = cub_ls_critical(&ls, x, y, z, dual, fv, cc);
          for (size_t i = 0; i < k && st == MGS_OK; i++) st = cub_cells_push(&cells, cc[i].key, cc[i].v, err);
        }
  }
  for (int32_t a = 0; a < ea && st == MGS_OK; a++)
    for (int32_t b = 0; b < eb && st == MGS_OK; b++)
      for (int32_t c = 0; c < ec; c++) {
        /* gradient path: only the -w cells (x-run ends) are added here */
        if (gradient && !dual && dense_voxel(&dc, a >> 1, b >> 1, c >> 1) != f.lo) continue;
        float v = cub_cell_value(&f, a, b, c);
        if (gradient && v != f.lo) continue;
        if (cub_keep(&f, v, a, b, c)) {
          band++;
          if ((st = cub_cells_push(&cells, cub_key(a, b, c), v, err)) != MGS_OK) break;
        }
      }
  stats.seconds_build = mgs_now() - t0;
  stats.peak_bytes = nv * sizeof(float);
  cub_run run = {&f, &opts, opts.voxel_size, {opts.origin[0], opts.origin[1], opts.origin[2]}, 0, gradient, band};
  if (st == MGS_OK) st = cub_persistence(&run, &cells, out, &stats, err);
  cub_cells_free(&cells);
  free(cl);
  stats.seconds = mgs_now() - t0;
  if (*out) (*out)->seconds = stats.seconds;
  if (stats_out) *stats_out = stats;
  return st;
}

mgs_status mgs_topo_persistence_dense(const float *values, int nx, int ny, int nz,
                                      const mgs_topo_opts *opts, mgs_diagram **out,
                                      mgs_error *err) {
  return mgs_topo_persistence_dense_stats(values, nx, ny, nz, opts, out, NULL, err);
}
