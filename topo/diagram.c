/* Persistence diagram storage: create/destroy/push/sort (see topo/mgs_diagram.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "topo/mgs_diagram.h"

mgs_diagram *mgs_diagram_create(void) { return calloc(1, sizeof(mgs_diagram)); }

void mgs_diagram_destroy(mgs_diagram *d) {
  if (!d) return;
  free(d->pairs);
  free(d);
}

mgs_status mgs_diagram_push(mgs_diagram *d, const mgs_pair *p, mgs_error *err) {
  if (!d || !p) return mgs_error_set(err, MGS_ERR_ARG, "diagram push: null argument");
  if (d->n == d->capacity) {
    size_t cap = d->capacity ? d->capacity * 2 : 16;
    mgs_pair *np = realloc(d->pairs, cap * sizeof *np);
    if (!np) return mgs_error_set(err, MGS_ERR_NOMEM, "diagram push: out of memory (%zu pairs)", cap);
    d->pairs = np;
    d->capacity = cap;
  }
  d->pairs[d->n++] = *p;
  return MGS_OK;
}

/* Total order: dim, birth, death (inf last); ties broken by the birth voxel so the output
 * does not depend on the engine's emission order. */
static int cmp_pair(const void *a, const void *b) {
  const mgs_pair *x = a, *y = b;
  if (x->dim != y->dim) return x->dim < y->dim ? -1 : 1;
  if (x->birth != y->birth) return x->birth < y->birth ? -1 : 1;
  if (x->death != y->death) return x->death < y->death ? -1 : 1;
  for (int i = 0; i < 3; i++)
    if (x->b.voxel[i] != y->b.voxel[i]) return x->b.voxel[i] < y->b.voxel[i] ? -1 : 1;
  return 0;
}

void mgs_diagram_sort(mgs_diagram *d) {
  if (d && d->n > 1) qsort(d->pairs, d->n, sizeof *d->pairs, cmp_pair);
}
