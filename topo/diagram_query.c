/* Diagram queries: top-k, Betti numbers at a level, total persistence, filters
 * (declared in topo/mgs_diagram_tools.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "topo/mgs_diagram_tools.h"

static double abs_pers(const mgs_pair *p) { return fabs(p->death - p->birth); }
static int is_essential(const mgs_pair *p) { return isinf(p->birth) || isinf(p->death); }

typedef struct rank_item { double pers, birth; size_t idx; } rank_item;
static int cmp_rank(const void *x, const void *y) {
  const rank_item *a = x, *b = y;
  if (a->pers != b->pers) return a->pers > b->pers ? -1 : 1;
  if (a->birth != b->birth) return a->birth < b->birth ? -1 : 1;
  return a->idx < b->idx ? -1 : a->idx > b->idx;
}

size_t mgs_diagram_top_k(const mgs_diagram *d, int dim, size_t k, size_t *idx) {
  if (!d || !idx || k == 0) return 0;
  size_t n = 0;
  rank_item *items = malloc((d->n ? d->n : 1) * sizeof *items);
  if (!items) return 0;
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if (dim != MGS_DIM_ALL && p->dim != dim) continue;
    items[n++] = (rank_item){is_essential(p) ? INFINITY : abs_pers(p), p->birth, i};
  }
  qsort(items, n, sizeof *items, cmp_rank);
  size_t m = n < k ? n : k;
  for (size_t i = 0; i < m; i++) idx[i] = items[i].idx;
  free(items);
  return m;
}

void mgs_diagram_betti_persistent(const mgs_diagram *d, double t, double min_persistence, int betti[3]) {
  betti[0] = betti[1] = betti[2] = 0;
  if (!d) return;
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if (p->dim >= 0 && p->dim <= 2 && p->birth <= t && t < p->death && p->death - p->birth > min_persistence) betti[p->dim]++;
  }
}

void mgs_diagram_betti(const mgs_diagram *d, double t, int betti[3]) {
  mgs_diagram_betti_persistent(d, t, -INFINITY, betti);
}

void mgs_diagram_betti_superlevel(const mgs_diagram *d, double t, int betti[3]) {
  betti[0] = betti[1] = betti[2] = 0;
  if (!d) return;
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if (p->dim >= 0 && p->dim <= 2 && p->death < t && t <= p->birth) betti[p->dim]++;
  }
}

double mgs_diagram_total_persistence(const mgs_diagram *d, int dim, double q, double threshold) {
  double s = 0.0;
  if (!d) return 0.0;
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    if ((dim != MGS_DIM_ALL && p->dim != dim) || is_essential(p)) continue;
    double pers = abs_pers(p);
    if (pers < threshold) s += q == 1.0 ? pers : q == 2.0 ? pers * pers : pow(pers, q);
  }
  return s;
}

void mgs_diagram_filter_init(mgs_diagram_filter *f) {
  memset(f, 0, sizeof *f);
  f->dim = MGS_DIM_ALL;
  f->min_persistence = -INFINITY; f->max_persistence = INFINITY;
  f->birth_min = -INFINITY; f->birth_max = INFINITY;
  f->death_min = -INFINITY; f->death_max = INFINITY;
  f->include_essential = 1;
  for (int k = 0; k < 3; k++) { f->box_min[k] = -INFINITY; f->box_max[k] = INFINITY; }
}

int mgs_diagram_filter_accepts(const mgs_diagram_filter *f, const mgs_pair *p) {
  if (f->dim != MGS_DIM_ALL && p->dim != f->dim) return 0;
  int ess = is_essential(p);
  if (ess && !f->include_essential) return 0;
  double pers = ess ? INFINITY : abs_pers(p);
  if (pers < f->min_persistence || pers > f->max_persistence) return 0;
  if (p->birth < f->birth_min || p->birth > f->birth_max) return 0;
  if (p->death < f->death_min || p->death > f->death_max) return 0;
  if (f->use_box) {
    if (f->box_end == 1 && ess) return 0; /* no death cell */
    const double *x = f->box_end == 1 ? p->d.pos : p->b.pos;
    for (int k = 0; k < 3; k++)
      if (!(x[k] >= f->box_min[k] && x[k] <= f->box_max[k])) return 0;
  }
  return 1;
}

mgs_status mgs_diagram_select(const mgs_diagram *d, const mgs_diagram_filter *f,
                              size_t **idx, size_t *n, mgs_error *err) {
  *idx = NULL; *n = 0;
  if (!d || !f) return mgs_error_set(err, MGS_ERR_ARG, "diagram select: null argument");
  size_t cnt = 0;
  for (size_t i = 0; i < d->n; i++) cnt += mgs_diagram_filter_accepts(f, &d->pairs[i]);
  if (cnt == 0) return MGS_OK;
  size_t *out = malloc(cnt * sizeof *out);
  if (!out) return mgs_error_set(err, MGS_ERR_NOMEM, "diagram select: out of memory (%zu pairs)", cnt);
  size_t m = 0;
  for (size_t i = 0; i < d->n; i++) if (mgs_diagram_filter_accepts(f, &d->pairs[i])) out[m++] = i;
  *idx = out; *n = m;
  return MGS_OK;
}

mgs_diagram *mgs_diagram_filtered(const mgs_diagram *d, const mgs_diagram_filter *f, mgs_error *err) {
  if (!d || !f) { mgs_error_set(err, MGS_ERR_ARG, "diagram filter: null argument"); return NULL; }
  mgs_diagram *out = mgs_diagram_create();
  if (!out) { mgs_error_set(err, MGS_ERR_NOMEM, "diagram filter: out of memory"); return NULL; }
  out->n_cells = d->n_cells; out->n_critical = d->n_critical;
  out->n_active_voxels = d->n_active_voxels; out->seconds = d->seconds;
  for (size_t i = 0; i < d->n; i++)
    if (mgs_diagram_filter_accepts(f, &d->pairs[i]) && mgs_diagram_push(out, &d->pairs[i], err) != MGS_OK) {
      mgs_diagram_destroy(out);
      return NULL;
    }
  return out;
}

void mgs_diagram_counts(const mgs_diagram *d, size_t per_dim[3], size_t *essential, size_t *truncated) {
  per_dim[0] = per_dim[1] = per_dim[2] = 0;
  size_t e = 0, t = 0;
  if (d)
    for (size_t i = 0; i < d->n; i++) {
      const mgs_pair *p = &d->pairs[i];
      if (p->dim >= 0 && p->dim <= 2) per_dim[p->dim]++;
      e += is_essential(p);
      t += p->truncated != 0;
    }
  if (essential) *essential = e;
  if (truncated) *truncated = t;
}
