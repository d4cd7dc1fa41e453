/* Bottleneck and Wasserstein distances between persistence diagrams
 * (declared in topo/mgs_diagram_tools.h).
 *
 * Bottleneck: the distance is the smallest r for which the bipartite graph
 *   left = A ∪ proj(B), right = B ∪ proj(A)
 * with edges a–b (‖a−b‖∞ ≤ r), a–proj(a) and proj(b)–b (half-persistence ≤ r) and every
 * proj(b)–proj(a) (cost 0) has a perfect matching (Efrat, Itai & Katz; GUDHI, hera).
 * Such a matching exists iff some matching of the plain A–B graph covers every "big" point
 * (one whose half-persistence exceeds r): unmatched small points go to their own
 * projections and the leftover projections pair up at cost 0. By the Mendelsohn–Dulmage
 * theorem a matching covering A_big ∪ B_big exists iff one covers A_big and one covers
 * B_big, so each feasibility test is two Hopcroft–Karp runs on the sparse A–B graph,
 * without the dense projection block. The answer is one of the candidate edge lengths, so
 * a binary search over them (or over double bit patterns, which are ordered like the
 * values for non-negative doubles) returns it exactly. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "topo/mgs_diagram_tools.h"

/* ------------------------------------------------------------------ helpers */

static double half_pers(double b, double d) { return fabs(d - b) * 0.5; }
static double linf(double b1, double d1, double b2, double d2) {
  return fmax(fabs(b1 - b2), fabs(d1 - d2));
}

static int cmp_double(const void *x, const void *y) {
  double a = *(const double *)x, b = *(const double *)y;
  return a < b ? -1 : a > b ? 1 : 0;
}

/* ------------------------------------------------------------ Hopcroft–Karp */

typedef struct hk_graph {
  size_t nl, nr;
  size_t *off;   /* CSR offsets, nl+1 */
  size_t *adj;   /* right vertex ids */
  size_t *match_l, *match_r, *dist, *queue, *stack_u, *stack_e;
} hk_graph;

#define HK_NONE ((size_t)-1)
#define HK_INF ((size_t)-1)

static int hk_bfs(hk_graph *g) {
  size_t head = 0, tail = 0;
  int found = 0;
  for (size_t u = 0; u < g->nl; u++) {
    if (g->match_l[u] == HK_NONE) { g->dist[u] = 0; g->queue[tail++] = u; }
    else g->dist[u] = HK_INF;
  }
  while (head < tail) {
    size_t u = g->queue[head++];
    for (size_t e = g->off[u]; e < g->off[u + 1]; e++) {
      size_t w = g->match_r[g->adj[e]];
      if (w == HK_NONE) found = 1;
      else if (g->dist[w] == HK_INF) { g->dist[w] = g->dist[u] + 1; g->queue[tail++] = w; }
    }
  }
  return found;
}

/* Iterative DFS along the BFS layers (no recursion: diagrams can be large). */
static int hk_dfs(hk_graph *g, size_t root, size_t *edge_pos) {
  size_t top = 0;
  g->stack_u[top++] = root;
  while (top) {
    size_t u = g->stack_u[top - 1];
    int advanced = 0;
    while (edge_pos[u] < g->off[u + 1]) {
      size_t e = edge_pos[u]++;
      size_t v = g->adj[e];
      size_t w = g->match_r[v];
      if (w == HK_NONE) {
        /* augment along the stack: each stacked u takes the edge it stands on */
        g->stack_e[top - 1] = e;
        for (size_t s = top; s-- > 0;) {
          size_t uu = g->stack_u[s], vv = g->adj[g->stack_e[s]];
          g->match_l[uu] = vv;
          g->match_r[vv] = uu;
        }
        return 1;
      }
      if (g->dist[w] == g->dist[u] + 1) {
        g->stack_e[top - 1] = e;
        g->stack_u[top++] = w;
        advanced = 1;
        break;
      }
    }
    if (!advanced) { g->dist[u] = HK_INF; top--; }
  }
  return 0;
}

static size_t hk_max_matching(hk_graph *g, size_t *edge_pos) {
  for (size_t u = 0; u < g->nl; u++) g->match_l[u] = HK_NONE;
  for (size_t v = 0; v < g->nr; v++) g->match_r[v] = HK_NONE;
  size_t size = 0;
  /* greedy start: most vertices match at once, leaving few phases */
  for (size_t u = 0; u < g->nl; u++)
    for (size_t e = g->off[u]; e < g->off[u + 1]; e++)
      if (g->match_r[g->adj[e]] == HK_NONE) {
        g->match_l[u] = g->adj[e]; g->match_r[g->adj[e]] = u; size++; break;
      }
  while (hk_bfs(g)) {
    for (size_t u = 0; u < g->nl; u++) edge_pos[u] = g->off[u];
    for (size_t u = 0; u < g->nl; u++)
      if (g->match_l[u] == HK_NONE && hk_dfs(g, u, edge_pos)) size++;
  }
  return size;
}

/* ------------------------------------------------------------ bottleneck */

typedef struct bn_ctx {
  const double *ba, *da, *bb, *db;
  size_t na, nb;
  size_t *order_a, *order_b;   /* points sorted by birth, for range queries */
  double *sorted_ba, *sorted_bb; /* births in that order */
  int ok;            /* 0 after an allocation failure */
} bn_ctx;

/* Does some matching of the A–B graph (edges ‖a−b‖∞ ≤ r) cover every point of `side`
 * (0 = A, 1 = B) whose half-persistence exceeds r? */
static int bn_covers(bn_ctx *c, double r, int side) {
  const double *lb = side ? c->bb : c->ba, *ld = side ? c->db : c->da;
  const double *rb = side ? c->ba : c->bb, *rd = side ? c->da : c->db;
  size_t nl_all = side ? c->nb : c->na, nr = side ? c->na : c->nb;
  size_t nl = 0;
  for (size_t i = 0; i < nl_all; i++) if (half_pers(lb[i], ld[i]) > r) nl++;
  if (nl == 0) return 1;
  if (nl > nr) return 0;
  /* right side sorted by birth for a range scan */
  const size_t *ord = side ? c->order_a : c->order_b;
  const double *sb = side ? c->sorted_ba : c->sorted_bb;
  hk_graph g = {0};
  size_t *edge_pos = NULL, cap = 0, ne = 0;
  int result = 0;
  g.nl = nl; g.nr = nr;
  g.off = malloc((nl + 1) * sizeof *g.off);
  g.match_l = malloc(nl * sizeof(size_t)); g.match_r = malloc(nr * sizeof(size_t));
  g.dist = malloc(nl * sizeof(size_t)); g.queue = malloc(nl * sizeof(size_t));
  g.stack_u = malloc(nl * sizeof(size_t)); g.stack_e = malloc(nl * sizeof(size_t));
  edge_pos = malloc(nl * sizeof(size_t));
  if (!g.off || !g.match_l || !g.match_r || !g.dist || !g.queue || !g.stack_u || !g.stack_e || !edge_pos) goto fail;
  size_t u = 0;
  for (size_t i = 0; i < nl_all; i++) {
    if (!(half_pers(lb[i], ld[i]) > r)) continue;
    g.off[u] = ne;
    /* first right point with birth ≥ lb − r */
    size_t lo = 0, hi = nr;
    while (lo < hi) { size_t mid = (lo + hi) / 2; if (sb[mid] < lb[i] - r) lo = mid + 1; else hi = mid; }
    for (size_t k = lo; k < nr && sb[k] <= lb[i] + r; k++) {
      size_t j = ord[k];
      if (linf(lb[i], ld[i], rb[j], rd[j]) <= r) {
        if (ne == cap) {
          size_t ncap = cap ? cap * 2 : 1024;
          size_t *na_ = realloc(g.adj, ncap * sizeof *na_);
          if (!na_) goto fail;
          g.adj = na_; cap = ncap;
        }
        g.adj[ne++] = j;
      }
    }
    u++;
  }
  g.off[nl] = ne;
  result = hk_max_matching(&g, edge_pos) == nl;
  goto done;
fail:
  c->ok = 0;
done:
  free(g.off); free(g.adj); free(g.match_l); free(g.match_r);
  free(g.dist); free(g.queue); free(g.stack_u); free(g.stack_e); free(edge_pos);
  return result;
}

static int bn_feasible(bn_ctx *c, double r) { return bn_covers(c, r, 0) && bn_covers(c, r, 1); }

static uint64_t dbits(double x) { uint64_t u; memcpy(&u, &x, sizeof u); return u; }
static double bitsd(uint64_t u) { double x; memcpy(&x, &u, sizeof x); return x; }

typedef struct key_idx { double key; size_t idx; } key_idx;
static int cmp_key_idx(const void *x, const void *y) {
  const key_idx *a = x, *b = y;
  if (a->key != b->key) return a->key < b->key ? -1 : 1;
  return a->idx < b->idx ? -1 : a->idx > b->idx;
}

/* ord/sorted: the indices of `b` in increasing order and the values in that order. */
static int sort_by_birth(const double *b, size_t n, size_t **ord, double **sorted) {
  key_idx *t = malloc((n ? n : 1) * sizeof *t);
  *ord = malloc((n ? n : 1) * sizeof **ord);
  *sorted = malloc((n ? n : 1) * sizeof **sorted);
  if (!t || !*ord || !*sorted) { free(t); return 0; }
  for (size_t i = 0; i < n; i++) t[i] = (key_idx){b[i], i};
  qsort(t, n, sizeof *t, cmp_key_idx);
  for (size_t i = 0; i < n; i++) { (*ord)[i] = t[i].idx; (*sorted)[i] = t[i].key; }
  free(t);
  return 1;
}

double mgs_bottleneck_points(const double *ba, const double *da, size_t na,
                             const double *bb, const double *db, size_t nb, int force_bisect) {
  if (na == 0 && nb == 0) return 0.0;
  bn_ctx c = {ba, da, bb, db, na, nb, NULL, NULL, NULL, NULL, 1};
  /* upper bound: everything to the diagonal (always feasible, and a candidate) */
  double hi = 0.0;
  for (size_t i = 0; i < na; i++) hi = fmax(hi, half_pers(ba[i], da[i]));
  for (size_t j = 0; j < nb; j++) hi = fmax(hi, half_pers(bb[j], db[j]));
  if (na == 0 || nb == 0) return hi;
  double result = hi;
  if (!sort_by_birth(ba, na, &c.order_a, &c.sorted_ba) || !sort_by_birth(bb, nb, &c.order_b, &c.sorted_bb)) {
    result = NAN;
    goto out;
  }
  double n_cand = (double)na * (double)nb + (double)na + (double)nb;
  if (!force_bisect && n_cand <= 4e6) {
    size_t nc = 0;
    double *cand = malloc((size_t)n_cand * sizeof *cand);
    if (!cand) { result = NAN; goto out; }
    for (size_t i = 0; i < na; i++) {
      double h = half_pers(ba[i], da[i]);
      if (h <= hi) cand[nc++] = h;
      for (size_t j = 0; j < nb; j++) {
        double v = linf(ba[i], da[i], bb[j], db[j]);
        if (v <= hi) cand[nc++] = v;
      }
    }
    for (size_t j = 0; j < nb; j++) { double h = half_pers(bb[j], db[j]); if (h <= hi) cand[nc++] = h; }
    qsort(cand, nc, sizeof *cand, cmp_double);
    size_t nu = 0;
    for (size_t k = 0; k < nc; k++) if (nu == 0 || cand[k] != cand[nu - 1]) cand[nu++] = cand[k];
    /* smallest feasible candidate; the largest (= hi) is feasible */
    size_t lo = 0, up = nu - 1;
    while (lo < up) {
      size_t mid = lo + (up - lo) / 2;
      if (bn_feasible(&c, cand[mid])) up = mid; else lo = mid + 1;
    }
    result = cand[lo];
    free(cand);
  } else {
    /* non-negative doubles are ordered like their bit patterns */
    uint64_t lo = 0, up = dbits(hi);
    while (lo < up) {
      uint64_t mid = lo + (up - lo) / 2;
      if (bn_feasible(&c, bitsd(mid))) up = mid; else lo = mid + 1;
      if (!c.ok) break;
    }
    result = bitsd(lo);
  }
  if (!c.ok) result = NAN;
out:
  free(c.order_a); free(c.sorted_ba); free(c.order_b); free(c.sorted_bb);
  return result;
}

/* ------------------------------------------------------------ Wasserstein */

static double dist_q(double b1, double d1, double b2, double d2, double q) {
  double x = fabs(b1 - b2), y = fabs(d1 - d2);
  if (isinf(q)) return fmax(x, y);
  if (q == 1.0) return x + y;
  if (q == 2.0) return hypot(x, y);
  return pow(pow(x, q) + pow(y, q), 1.0 / q);
}
static double diag_q(double b, double d, double q) {
  double h = half_pers(b, d);
  return isinf(q) ? h : h * pow(2.0, 1.0 / q);
}
static double powp(double x, double p) { return p == 1.0 ? x : p == 2.0 ? x * x : pow(x, p); }

typedef struct w_ctx {
  const double *ba, *da, *bb, *db;
  size_t na, nb;
  double p, q;
  double *diag_a, *diag_b; /* diagonal costs ^p */
} w_ctx;

static double w_cost(const w_ctx *c, size_t i, size_t j) {
  if (i < c->na) {
    if (j < c->nb) return powp(dist_q(c->ba[i], c->da[i], c->bb[j], c->db[j], c->q), c->p);
    return c->diag_a[i]; /* any projection slot: the slots are interchangeable */
  }
  if (j < c->nb) return c->diag_b[j];
  return 0.0;
}

/* Hungarian algorithm with potentials (O(N^3)) on the precomputed N×N cost matrix;
 * returns the minimum total cost of a perfect assignment, or NAN on no memory. */
static double hungarian(const w_ctx *c, size_t n) {
  double *cost = malloc(n * n * sizeof *cost);
  double *u = calloc(n + 1, sizeof *u), *v = calloc(n + 1, sizeof *v), *minv = malloc((n + 1) * sizeof *minv);
  size_t *pcol = calloc(n + 1, sizeof *pcol), *way = calloc(n + 1, sizeof *way);
  unsigned char *used = malloc(n + 1);
  double total = NAN;
  if (!cost || !u || !v || !minv || !pcol || !way || !used) goto out;
  for (size_t i = 0; i < n; i++)
    for (size_t j = 0; j < n; j++) cost[i * n + j] = w_cost(c, i, j);
  for (size_t i = 1; i <= n; i++) {
    pcol[0] = i;
    size_t j0 = 0;
    for (size_t j = 0; j <= n; j++) { minv[j] = INFINITY; used[j] = 0; }
    do {
      used[j0] = 1;
      size_t i0 = pcol[j0], j1 = 0;
      double delta = INFINITY, ui0 = u[i0];
      const double *row = cost + (i0 - 1) * n - 1; /* row[j], j = 1..n */
      for (size_t j = 1; j <= n; j++) {
        if (used[j]) continue;
        double cur = row[j] - ui0 - v[j];
        if (cur < minv[j]) { minv[j] = cur; way[j] = j0; }
        if (minv[j] < delta) { delta = minv[j]; j1 = j; }
      }
      for (size_t j = 0; j <= n; j++) {
        if (used[j]) { u[pcol[j]] += delta; v[j] -= delta; }
        else minv[j] -= delta;
      }
      j0 = j1;
    } while (pcol[j0] != 0);
    do { size_t j1 = way[j0]; pcol[j0] = pcol[j1]; j0 = j1; } while (j0);
  }
  /* the cost of the assignment itself (not the potentials: no drift) */
  total = 0.0;
  for (size_t j = 1; j <= n; j++) total += cost[(pcol[j] - 1) * n + (j - 1)];
out:
  free(cost); free(u); free(v); free(minv); free(pcol); free(way); free(used);
  return total;
}

typedef struct pers_idx { double pers; size_t idx; int side; } pers_idx;
static int cmp_pers_desc(const void *x, const void *y) {
  const pers_idx *a = x, *b = y;
  if (a->pers != b->pers) return a->pers > b->pers ? -1 : 1;
  if (a->side != b->side) return a->side - b->side;
  return a->idx < b->idx ? -1 : a->idx > b->idx;
}

double mgs_wasserstein_points(const double *ba, const double *da, size_t na,
                              const double *bb, const double *db, size_t nb,
                              double p, double internal_p, double *error_bound) {
  return mgs_wasserstein_points_limit(ba, da, na, bb, db, nb, p, internal_p, MGS_WASSERSTEIN_EXACT_MAX, error_bound);
}

double mgs_wasserstein_points_limit(const double *ba, const double *da, size_t na,
                                    const double *bb, const double *db, size_t nb,
                                    double p, double internal_p, size_t exact_max,
                                    double *error_bound) {
  if (error_bound) *error_bound = 0.0;
  if (exact_max < 2) exact_max = 2;
  if (isinf(p)) return mgs_bottleneck_points(ba, da, na, bb, db, nb, 0);
  double q = internal_p;
  double result = NAN;
  double *kb[4] = {NULL, NULL, NULL, NULL};
  pers_idx *all = NULL;
  w_ctx c = {ba, da, bb, db, na, nb, p, q, NULL, NULL};
  if (na + nb > exact_max) {
    /* keep the most persistent points; the dropped ones are matched to the diagonal */
    size_t n = na + nb, keep = exact_max;
    all = malloc(n * sizeof *all);
    for (int s = 0; s < 4; s++) kb[s] = malloc((n ? n : 1) * sizeof(double));
    if (!all || !kb[0] || !kb[1] || !kb[2] || !kb[3]) goto out;
    for (size_t i = 0; i < na; i++) all[i] = (pers_idx){half_pers(ba[i], da[i]), i, 0};
    for (size_t j = 0; j < nb; j++) all[na + j] = (pers_idx){half_pers(bb[j], db[j]), j, 1};
    qsort(all, n, sizeof *all, cmp_pers_desc);
    size_t ka = 0, kbn = 0;
    double drop_a = 0, drop_b = 0;
    for (size_t k = 0; k < n; k++) {
      const pers_idx *e = &all[k];
      if (k < keep) {
        if (e->side == 0) { kb[0][ka] = ba[e->idx]; kb[1][ka++] = da[e->idx]; }
        else { kb[2][kbn] = bb[e->idx]; kb[3][kbn++] = db[e->idx]; }
      } else if (e->side == 0) drop_a += powp(diag_q(ba[e->idx], da[e->idx], q), p);
      else drop_b += powp(diag_q(bb[e->idx], db[e->idx], q), p);
    }
    result = mgs_wasserstein_points_limit(kb[0], kb[1], ka, kb[2], kb[3], kbn, p, q, exact_max, NULL);
    if (error_bound) *error_bound = pow(drop_a, 1.0 / p) + pow(drop_b, 1.0 / p);
    goto out;
  }
  if (na + nb == 0) { result = 0.0; goto out; }
  c.diag_a = malloc((na ? na : 1) * sizeof(double));
  c.diag_b = malloc((nb ? nb : 1) * sizeof(double));
  if (!c.diag_a || !c.diag_b) goto out;
  for (size_t i = 0; i < na; i++) c.diag_a[i] = powp(diag_q(ba[i], da[i], q), p);
  for (size_t j = 0; j < nb; j++) c.diag_b[j] = powp(diag_q(bb[j], db[j], q), p);
  if (na == 0 || nb == 0) {
    double s = 0;
    for (size_t i = 0; i < na; i++) s += c.diag_a[i];
    for (size_t j = 0; j < nb; j++) s += c.diag_b[j];
    result = pow(s, 1.0 / p);
    goto out;
  }
  double total = hungarian(&c, na + nb);
  result = isnan(total) ? NAN : pow(fmax(total, 0.0), 1.0 / p);
out:
  free(c.diag_a); free(c.diag_b); free(all);
  for (int s = 0; s < 4; s++) free(kb[s]);
  return result;
}

/* ------------------------------------------------------------ diagrams */

/* Essential kinds: 0 death=+inf, 1 death=-inf, 2 birth=-inf, 3 birth=+inf (finite other
 * end is the coordinate); 4 both infinite (no coordinate). -1: finite pair. */
static int essential_kind(const mgs_pair *p, double *coord) {
  int bi = isinf(p->birth), di = isinf(p->death);
  if (!bi && !di) return -1;
  if (bi && di) { *coord = 0; return 4; }
  if (di) { *coord = p->birth; return p->death > 0 ? 0 : 1; }
  *coord = p->death;
  return p->birth < 0 ? 2 : 3;
}

typedef struct dim_split {
  double *b, *d; size_t n;       /* finite points */
  double *ess[5]; size_t ne[5];  /* essential coordinates per kind */
} dim_split;

static void split_free(dim_split *s) {
  free(s->b); free(s->d);
  for (int k = 0; k < 5; k++) free(s->ess[k]);
}

static mgs_status split_dim(const mgs_diagram *dg, int dim, dim_split *s, mgs_error *err) {
  memset(s, 0, sizeof *s);
  size_t n = dg ? dg->n : 0;
  s->b = malloc((n ? n : 1) * sizeof(double));
  s->d = malloc((n ? n : 1) * sizeof(double));
  for (int k = 0; k < 5; k++) s->ess[k] = malloc((n ? n : 1) * sizeof(double));
  if (!s->b || !s->d || !s->ess[0] || !s->ess[1] || !s->ess[2] || !s->ess[3] || !s->ess[4])
    return mgs_error_set(err, MGS_ERR_NOMEM, "diagram distance: out of memory (%zu pairs)", n);
  for (size_t i = 0; i < n; i++) {
    const mgs_pair *p = &dg->pairs[i];
    if (p->dim != dim) continue;
    if (isnan(p->birth) || isnan(p->death))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "diagram distance: pair %zu (dim %d) has a NaN end", i, dim);
    double coord;
    int kind = essential_kind(p, &coord);
    if (kind < 0) { s->b[s->n] = p->birth; s->d[s->n++] = p->death; }
    else s->ess[kind][s->ne[kind]++] = coord;
  }
  for (int k = 0; k < 5; k++) qsort(s->ess[k], s->ne[k], sizeof(double), cmp_double);
  return MGS_OK;
}

/* One dimension: bottleneck value (p = INFINITY) or Σ cost^p (finite p). */
static mgs_status dist_dim(const mgs_diagram *a, const mgs_diagram *b, int dim, double p,
                           double q, double *out, double *bound, mgs_error *err) {
  dim_split sa, sb;
  mgs_status st = split_dim(a, dim, &sa, err);
  if (st == MGS_OK) st = split_dim(b, dim, &sb, err);
  else memset(&sb, 0, sizeof sb);
  if (st != MGS_OK) { split_free(&sa); split_free(&sb); return st; }
  double ess = 0.0; /* max |Δ| (bottleneck) or Σ |Δ|^p */
  int infinite = 0;
  for (int k = 0; k < 5 && !infinite; k++) {
    if (sa.ne[k] != sb.ne[k]) { infinite = 1; break; }
    if (k == 4) continue;
    for (size_t i = 0; i < sa.ne[k]; i++) {
      double delta = fabs(sa.ess[k][i] - sb.ess[k][i]);
      if (isinf(p)) ess = fmax(ess, delta); else ess += powp(delta, p);
    }
  }
  if (bound) *bound = 0.0;
  if (infinite) *out = INFINITY;
  else if (isinf(p)) {
    double v = mgs_bottleneck_points(sa.b, sa.d, sa.n, sb.b, sb.d, sb.n, 0);
    if (isnan(v)) st = mgs_error_set(err, MGS_ERR_NOMEM, "bottleneck distance: out of memory (%zu and %zu points)", sa.n, sb.n);
    *out = fmax(v, ess);
  } else {
    double v = mgs_wasserstein_points(sa.b, sa.d, sa.n, sb.b, sb.d, sb.n, p, q, bound);
    if (isnan(v)) st = mgs_error_set(err, MGS_ERR_NOMEM, "Wasserstein distance: out of memory (%zu and %zu points)", sa.n, sb.n);
    *out = powp(v, p) + ess;
  }
  split_free(&sa); split_free(&sb);
  return st;
}

static mgs_status check_args(const mgs_diagram *a, const mgs_diagram *b, int dim, double *out, mgs_error *err) {
  if (!a || !b || !out) return mgs_error_set(err, MGS_ERR_ARG, "diagram distance: null argument");
  if (dim != MGS_DIM_ALL && (dim < 0 || dim > 2))
    return mgs_error_set(err, MGS_ERR_ARG, "diagram distance: dimension %d is not 0, 1, 2 or all", dim);
  return MGS_OK;
}

mgs_status mgs_diagram_bottleneck(const mgs_diagram *a, const mgs_diagram *b, int dim,
                                  double *out, mgs_error *err) {
  mgs_status st = check_args(a, b, dim, out, err);
  if (st != MGS_OK) return st;
  double best = 0.0;
  for (int k = 0; k <= 2; k++) {
    if (dim != MGS_DIM_ALL && dim != k) continue;
    double v;
    st = dist_dim(a, b, k, INFINITY, INFINITY, &v, NULL, err);
    if (st != MGS_OK) return st;
    best = fmax(best, v);
  }
  *out = best;
  return MGS_OK;
}

mgs_status mgs_diagram_wasserstein(const mgs_diagram *a, const mgs_diagram *b, int dim,
                                   double p, double internal_p, double *out,
                                   double *error_bound, mgs_error *err) {
  mgs_status st = check_args(a, b, dim, out, err);
  if (st != MGS_OK) return st;
  if (!(p >= 1.0)) return mgs_error_set(err, MGS_ERR_ARG, "Wasserstein distance: order p = %g must be >= 1", p);
  if (!(internal_p >= 1.0)) return mgs_error_set(err, MGS_ERR_ARG, "Wasserstein distance: internal_p = %g must be >= 1", internal_p);
  if (isinf(p)) {
    if (error_bound) *error_bound = 0.0;
    return mgs_diagram_bottleneck(a, b, dim, out, err);
  }
  double sum = 0.0, bound_p = 0.0;
  for (int k = 0; k <= 2; k++) {
    if (dim != MGS_DIM_ALL && dim != k) continue;
    double v, bd;
    st = dist_dim(a, b, k, p, internal_p, &v, &bd, err);
    if (st != MGS_OK) return st;
    sum += v;
    bound_p += bd;
  }
  *out = isinf(sum) ? INFINITY : pow(sum, 1.0 / p);
  /* combining per-dimension bounds: (Σ (w_k + e_k)^p)^(1/p) ≤ W + Σ e_k (Minkowski) */
  if (error_bound) *error_bound = bound_p;
  return MGS_OK;
}
