/* Boundaries of the Morse complex by V-path traversal, Z/2 (V construction, and T through
 * duality: the T gradient is the dual of the lower-star gradient of -f on the voxel grid).
 *
 * Why: after the discrete gradient (topo/gradient_lowerstar.c) only critical cells are
 * sorted and paired; their boundary in the Morse complex is the Z/2 count of gradient paths
 * from the faces of a critical p-cell to critical (p-1)-cells. A face that is critical counts
 * itself; a face paired with a lower cell is a dead end; a face sigma paired with a p-cell
 * tau' is replaced by the other faces of tau'. Eliminating faces in decreasing (value, key of
 * the lower-star vertex, classification time) order is a topological order of the gradient
 * paths, so each cell is expanded once and Z/2 cancellation is exact. Cells of value -w use
 * the x-run matching of topo/persistence.c (an even-x face slides to its run's left end, an
 * odd-x face is a dead end). Boundaries of all critical cells are computed in parallel
 * (mgs_parallel_for, per-thread scratch) and stored as CSR by rank. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "topo/cubical_internal.h"

/* ---------------------------------------------------------------- per-thread scratch */
typedef struct hent { float v; uint8_t time; uint64_t mkey, cell, partner; } hent;
enum { M_ABSENT = 0, M_ODD = 1, M_EVEN = 2, M_DONE = 3 };
typedef struct mslot { uint64_t key; uint8_t st; } mslot;
#define LS_CACHE 4096
typedef struct lsent { uint64_t vkey; cub_ls ls; } lsent;

typedef struct scratch {
  hent *heap; size_t nh, caph;
  mslot *map; size_t mask, used; /* parity map, cleared through `touched` */
  uint32_t *touched; size_t ntouched, captouched;
  uint32_t *res; size_t nres, capres;
  lsent *cache;
  int dual; /* T construction */
  mgs_status st; char msg[200];
} scratch;

static int grow(void **p, size_t *cap, size_t need, size_t elt) {
  if (need <= *cap) return 1;
  size_t c = *cap ? *cap : 64;
  while (c < need) c *= 2;
  void *q = realloc(*p, c * elt);
  if (!q) return 0;
  *p = q;
  *cap = c;
  return 1;
}

/* a < b in elimination priority. V: the larger (value, vertex key, time) first. T: the
 * gradient is the dual of the lower-star gradient of g = -f, whose paths run the other way:
 * the smaller (g, voxel key, time) first; v holds g there. */
static int hless_v(const hent *a, const hent *b) {
  if (a->v != b->v) return a->v < b->v;
  if (a->mkey != b->mkey) return a->mkey < b->mkey;
  return a->time < b->time;
}
static int hless(const scratch *s, const hent *a, const hent *b) { return s->dual ? hless_v(b, a) : hless_v(a, b); }
static int heap_push(scratch *s, const hent *e) {
  if (!grow((void **)&s->heap, &s->caph, s->nh + 1, sizeof *s->heap)) return 0;
  size_t i = s->nh++;
  while (i > 0) {
    size_t p = (i - 1) / 2;
    if (!hless(s, &s->heap[p], e)) break;
    s->heap[i] = s->heap[p];
    i = p;
  }
  s->heap[i] = *e;
  return 1;
}
static hent heap_pop(scratch *s) {
  hent top = s->heap[0], last = s->heap[--s->nh];
  size_t i = 0, n = s->nh;
  for (;;) {
    size_t c = 2 * i + 1;
    if (c >= n) break;
    if (c + 1 < n && hless(s, &s->heap[c], &s->heap[c + 1])) c++;
    if (!hless(s, &last, &s->heap[c])) break;
    s->heap[i] = s->heap[c];
    i = c;
  }
  if (n) s->heap[i] = last;
  return top;
}

static int map_rehash(scratch *s, size_t cap) {
  mslot *old = s->map;
  size_t oldcap = s->mask + 1;
  s->map = malloc(cap * sizeof *s->map);
  if (!s->map) { s->map = old; return 0; }
  for (size_t i = 0; i < cap; i++) s->map[i].key = CUB_KEY_NONE;
  s->mask = cap - 1;
  s->ntouched = 0;
  if (old) {
    for (size_t i = 0; i < oldcap; i++)
      if (old[i].key != CUB_KEY_NONE) {
        size_t h = cub_hash(old[i].key) & s->mask;
        while (s->map[h].key != CUB_KEY_NONE) h = (h + 1) & s->mask;
        s->map[h] = old[i];
        s->touched[s->ntouched++] = (uint32_t)h;
      }
    free(old);
  }
  return 1;
}
/* slot of key (inserted as M_ABSENT if new) */
static mslot *map_slot(scratch *s, uint64_t key) {
  if (2 * (s->ntouched + 1) > s->mask + 1) {
    if (!grow((void **)&s->touched, &s->captouched, 2 * (s->mask + 1), sizeof *s->touched)) return NULL;
    if (!map_rehash(s, 2 * (s->mask + 1))) return NULL;
  }
  size_t h = cub_hash(key) & s->mask;
  while (s->map[h].key != CUB_KEY_NONE && s->map[h].key != key) h = (h + 1) & s->mask;
  if (s->map[h].key == CUB_KEY_NONE) {
    if (!grow((void **)&s->touched, &s->captouched, s->ntouched + 1, sizeof *s->touched)) return NULL;
    s->map[h].key = key;
    s->map[h].st = M_ABSENT;
    s->touched[s->ntouched++] = (uint32_t)h;
  }
  return &s->map[h];
}
static void map_clear(scratch *s) {
  for (size_t i = 0; i < s->ntouched; i++) s->map[s->touched[i]].key = CUB_KEY_NONE;
  s->ntouched = 0;
}

/* ---------------------------------------------------------------- gradient queries */
/* Value of cell (a,b,c) and the voxel owning it in the gradient. V: its lower-star vertex,
 * the max by (value, key). T: the vertex of the dual cell in the lower star of g = -f, i.e.
 * the adjacent voxel of min value, the larger key on ties. Doubled coordinates of the cell
 * relative to that voxel: V 2m + d, T 2m + 1 + d (d in {-1,0,1}^3, the star index). */
static float cell_owner(const cub_field *f, int32_t a, int32_t b, int32_t c, int32_t m[3]) {
  if (f->construction == MGS_TOPO_V) {
    int32_t x0 = a >> 1, y0 = b >> 1, z0 = c >> 1;
    int nx = (a & 1) + 1, ny = (b & 1) + 1, nz = (c & 1) + 1;
    float best = -INFINITY;
    m[0] = x0; m[1] = y0; m[2] = z0;
    for (int i = 0; i < nx; i++)
      for (int j = 0; j < ny; j++)
        for (int k = 0; k < nz; k++) {
          float v = f->voxel(f->ctx, x0 + i, y0 + j, z0 + k);
          if (v >= best) { best = v; m[0] = x0 + i; m[1] = y0 + j; m[2] = z0 + k; }
        }
    return best;
  }
  /* T: odd a is voxel (a-1)/2; even a lies between voxels a/2-1 and a/2 */
  int32_t x0 = (a - 1) >> 1, y0 = (b - 1) >> 1, z0 = (c - 1) >> 1;
  int nx = !(a & 1) + 1, ny = !(b & 1) + 1, nz = !(c & 1) + 1;
  float best = INFINITY;
  m[0] = x0; m[1] = y0; m[2] = z0;
  for (int i = 0; i < nx; i++)
    for (int j = 0; j < ny; j++)
      for (int k = 0; k < nz; k++) {
        float v = f->voxel(f->ctx, x0 + i, y0 + j, z0 + k);
        if (v <= best) { best = v; m[0] = x0 + i; m[1] = y0 + j; m[2] = z0 + k; }
      }
  return best;
}

static const cub_ls *lower_star_at(scratch *s, const cub_field *f, const int32_t m[3]) {
  uint64_t vk = cub_key(2 * m[0], 2 * m[1], 2 * m[2]);
  lsent *e = &s->cache[cub_hash(vk) & (LS_CACHE - 1)];
  if (e->vkey != vk) {
    float nb[27];
    for (int i = 0; i < 27; i++)
      nb[i] = f->voxel(f->ctx, m[0] + i / 9 - 1, m[1] + i / 3 % 3 - 1, m[2] + i % 3 - 1);
    if (s->dual)
      for (int i = 0; i < 27; i++) nb[i] = -nb[i];
    cub_lower_star(nb, &e->ls);
    e->vkey = vk;
  }
  return &e->ls;
}

static int fail(scratch *s, mgs_status st, const char *msg, int32_t a, int32_t b, int32_t c) {
  if (s->st == MGS_OK) {
    s->st = st;
    snprintf(s->msg, sizeof s->msg, "persistence: %s (cell %d,%d,%d)", msg, a, b, c);
  }
  return 0;
}

static int add_result(scratch *s, const cub_complex *cx, uint64_t key, int32_t a, int32_t b, int32_t c) {
  uint32_t r = cub_rank_get(cx, key);
  if (r == UINT32_MAX) return fail(s, MGS_ERR_FORMAT, "critical cell missing from the band (broken narrow band?)", a, b, c);
  if (!grow((void **)&s->res, &s->capres, s->nres + 1, sizeof *s->res)) return fail(s, MGS_ERR_NOMEM, "out of memory", a, b, c);
  s->res[s->nres++] = r;
  return 1;
}

/* One face met by the flow. Returns 0 on error. */
static int visit(scratch *s, const cub_complex *cx, int32_t a, int32_t b, int32_t c) {
  const cub_field *f = cx->f;
  int32_t m[3];
  float v = cell_owner(f, a, b, c, m);
  if (v == f->lo) {
    if (a & 1) return 1; /* matched with its right x-face: dead end */
    a = cub_lo_run_start(f, a, b, c);
    return add_result(s, cx, cub_key(a, b, c), a, b, c);
  }
  if (!(v < f->top)) return fail(s, MGS_ERR_FORMAT, "flow reached the background (broken narrow band?)", a, b, c);
  const cub_ls *ls = lower_star_at(s, f, m);
  int base = s->dual; /* T cells sit at 2m + 1 + d */
  int ci = (a - 2 * m[0] - base + 1) * 9 + (b - 2 * m[1] - base + 1) * 3 + (c - 2 * m[2] - base + 1);
  uint8_t st = ls->state[ci];
  uint64_t key = cub_key(a, b, c);
  if (st == CUB_LS_CRIT) return add_result(s, cx, key, a, b, c);
  if (st != CUB_LS_PAIR) return fail(s, MGS_ERR_FORMAT, "internal: cell outside its lower star", a, b, c);
  int p = ls->partner[ci];
  /* paired with a face (V) / with a coface of the dual cell, i.e. a face in T: dead end */
  if ((cub_ls_dim(p) < cub_ls_dim(ci)) != s->dual) return 1;
  mslot *sl = map_slot(s, key);
  if (!sl) return fail(s, MGS_ERR_NOMEM, "out of memory (flow)", a, b, c);
  switch (sl->st) {
  case M_ABSENT: {
    sl->st = M_ODD;
    hent e = {s->dual ? -v : v, ls->time[ci], cub_key(2 * m[0], 2 * m[1], 2 * m[2]), key,
              cub_key(2 * m[0] + base + p / 9 - 1, 2 * m[1] + base + p / 3 % 3 - 1, 2 * m[2] + base + p % 3 - 1)};
    if (!heap_push(s, &e)) return fail(s, MGS_ERR_NOMEM, "out of memory (flow)", a, b, c);
    return 1;
  }
  case M_ODD: sl->st = M_EVEN; return 1;
  case M_EVEN: sl->st = M_ODD; return 1;
  default: return fail(s, MGS_ERR_FORMAT, "internal: gradient path order violated", a, b, c);
  }
}

static int faces_visit(scratch *s, const cub_complex *cx, uint64_t key, uint64_t skip) {
  int32_t p[3];
  cub_unkey(key, &p[0], &p[1], &p[2]);
  for (int ax = 0; ax < 3; ax++) {
    if (!(p[ax] & 1)) continue;
    for (int sg = -1; sg <= 1; sg += 2) {
      int32_t q[3] = {p[0], p[1], p[2]};
      q[ax] += sg;
      if (cub_key(q[0], q[1], q[2]) == skip) continue;
      if (!visit(s, cx, q[0], q[1], q[2])) return 0;
    }
  }
  return 1;
}

/* Morse boundary of critical cell `rank` into s->res (ascending ranks, Z/2). */
static int morse_boundary(scratch *s, const cub_complex *cx, uint32_t rank) {
  s->nres = 0;
  s->nh = 0;
  int ok = faces_visit(s, cx, cx->cells[rank].key, CUB_KEY_NONE);
  while (ok && s->nh) {
    hent e = heap_pop(s);
    mslot *sl = map_slot(s, e.cell);
    if (!sl) { ok = fail(s, MGS_ERR_NOMEM, "out of memory (flow)", 0, 0, 0); break; }
    int odd = sl->st == M_ODD;
    sl->st = M_DONE;
    if (odd) ok = faces_visit(s, cx, e.partner, e.cell);
  }
  map_clear(s);
  if (!ok) return 0;
  /* sort and keep odd multiplicities */
  uint32_t *r = s->res;
  size_t n = s->nres;
  for (size_t i = 1; i < n; i++) {
    uint32_t x = r[i];
    size_t j = i;
    while (j > 0 && r[j - 1] > x) { r[j] = r[j - 1]; j--; }
    r[j] = x;
  }
  size_t k = 0;
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && r[j] == r[i]) j++;
    if ((j - i) & 1) r[k++] = r[i];
    i = j;
  }
  s->nres = k;
  return 1;
}

/* ---------------------------------------------------------------- parallel driver */
#define CHUNK 256
typedef struct chunk { uint32_t *buf; size_t len; uint32_t cnt[CHUNK]; } chunk;
typedef struct drive {
  const cub_complex *cx;
  scratch *sc;  /* per thread */
  chunk *ch;
  size_t nchunks;
} drive;

static void drive_range(void *vctx, size_t b, size_t e) {
  drive *d = vctx;
  scratch *s = &d->sc[mgs_parallel_thread_index()];
  for (size_t ci = b; ci < e; ci++) {
    chunk *c = &d->ch[ci];
    size_t r0 = ci * CHUNK, r1 = r0 + CHUNK < d->cx->n ? r0 + CHUNK : d->cx->n;
    size_t cap = 0;
    for (size_t r = r0; r < r1; r++) {
      c->cnt[r - r0] = 0;
      if (s->st != MGS_OK || cub_key_dim(d->cx->cells[r].key) == 0) continue;
      if (!morse_boundary(s, d->cx, (uint32_t)r)) continue;
      if (!grow((void **)&c->buf, &cap, c->len + s->nres + 1, sizeof *c->buf)) { fail(s, MGS_ERR_NOMEM, "out of memory (boundaries)", 0, 0, 0); continue; }
      memcpy(c->buf + c->len, s->res, s->nres * sizeof *s->res);
      c->len += s->nres;
      c->cnt[r - r0] = (uint32_t)s->nres;
    }
  }
}

mgs_status cub_morse_boundaries(cub_complex *cx, mgs_error *err) {
  cub_lower_star_tables();
  int nt = mgs_parallel_max_threads();
  if (nt < 1) nt = 1;
  size_t nchunks = (cx->n + CHUNK - 1) / CHUNK;
  drive d = {cx, calloc((size_t)nt, sizeof(scratch)), calloc(nchunks ? nchunks : 1, sizeof(chunk)), nchunks};
  mgs_status st = MGS_OK;
  if (!d.sc || !d.ch) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (Morse boundaries)"); goto done; }
  for (int t = 0; t < nt; t++) {
    scratch *s = &d.sc[t];
    s->cache = malloc(LS_CACHE * sizeof *s->cache);
    if (!s->cache || !grow((void **)&s->touched, &s->captouched, 512, sizeof *s->touched) || !map_rehash(s, 1024)) {
      st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (Morse boundaries)");
      goto done;
    }
    for (size_t i = 0; i < LS_CACHE; i++) s->cache[i].vkey = CUB_KEY_NONE;
    s->dual = cx->f->construction == MGS_TOPO_T;
  }
  mgs_parallel_for(0, nchunks, 1, drive_range, &d);
  for (int t = 0; t < nt; t++)
    if (d.sc[t].st != MGS_OK) { st = mgs_error_set(err, d.sc[t].st, "%s", d.sc[t].msg); goto done; }
  size_t total = 0;
  for (size_t i = 0; i < nchunks; i++) total += d.ch[i].len;
  cx->bstart = malloc((cx->n + 1) * sizeof *cx->bstart);
  cx->bpool = malloc((total ? total : 1) * sizeof *cx->bpool);
  if (!cx->bstart || !cx->bpool) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (Morse boundaries)"); goto done; }
  size_t pos = 0;
  for (size_t i = 0; i < nchunks; i++) {
    size_t r0 = i * CHUNK, r1 = r0 + CHUNK < cx->n ? r0 + CHUNK : cx->n;
    if (d.ch[i].len) memcpy(cx->bpool + pos, d.ch[i].buf, d.ch[i].len * sizeof *cx->bpool);
    for (size_t r = r0; r < r1; r++) { cx->bstart[r] = pos; pos += d.ch[i].cnt[r - r0]; }
  }
  cx->bstart[cx->n] = pos;
done:
  if (d.sc)
    for (int t = 0; t < nt; t++) {
      scratch *s = &d.sc[t];
      free(s->heap); free(s->map); free(s->touched); free(s->res); free(s->cache);
    }
  if (d.ch)
    for (size_t i = 0; i < nchunks; i++) free(d.ch[i].buf);
  free(d.sc);
  free(d.ch);
  return st;
}
