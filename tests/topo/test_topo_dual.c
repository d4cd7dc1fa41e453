/* Dimension 2 by union-find on the dual (default) against the twist reduction of the 3-cell
 * columns (opts.d2_reduction = 1): the whole diagram must be identical, pair for pair and in
 * order (values, birth/death cells, voxels, positions, truncation flags, essential classes),
 * on random fields (unique values and clamped plateaus), noisy fields with cavities (some
 * closing at a maximum inside, some at the +w clamp: essential voids of the band), nested
 * sphere shells and narrow bands with interior (-w) tiles; dense and band, V and T, sub- and
 * superlevel, with the discrete gradient and with the full reduction. The cases must hold
 * finite and essential dimension-2 pairs, and the dual path must have run. */
#include "topo_test_util.h"

static int full = 0;
static size_t n_cases = 0, d2_finite = 0, d2_essential = 0, d2_dual_runs = 0;

enum { DT_CHEESE = 100 };

/* A noisy solid block with spherical cavities of radius 1.5-6 voxels: the small ones close at
 * a maximum inside, the large ones reach the +w clamp (a cavity of the band). */
static float *cheese(int N, uint32_t seed) {
  float *f = malloc((size_t)N * N * N * sizeof *f);
  double c[24][4];
  for (int b = 0; b < 24; b++) {
    for (int k = 0; k < 3; k++) c[b][k] = .25 + .5 * (tt_noise(seed + 11, (size_t)b * 4 + k) * .5 + .5);
    c[b][3] = (1.5 + 4.5 * (tt_noise(seed + 11, (size_t)b * 4 + 3) * .5 + .5)) / N;
  }
  for (int i = 0; i < N; i++)
    for (int j = 0; j < N; j++)
      for (int k = 0; k < N; k++) {
        size_t id = ((size_t)i * N + j) * N + k;
        double x = (i + .5) / N, y = (j + .5) / N, z = (k + .5) / N;
        double v = fmax(fabs(x - .5), fmax(fabs(y - .5), fabs(z - .5))) - .38;
        for (int b = 0; b < 24; b++) v = fmax(v, -tt_sphere(x, y, z, c[b][0], c[b][1], c[b][2], c[b][3]));
        f[id] = (float)(v + 0.4 / N * tt_noise(seed, id));
      }
  return f;
}

static mgs_diagram *run(const float *f, int N, double w, int cons, int sup, int full_red, int d2_red, int sparse,
                        mgs_topo_stats *st) {
  return tt_run(f, N, w, cons, sup, full_red, d2_red, sparse, st);
}

static int same_end(const mgs_pair_end *a, const mgs_pair_end *b) {
  return a->cell == b->cell && !memcmp(a->voxel, b->voxel, sizeof a->voxel) && !memcmp(a->pos, b->pos, sizeof a->pos);
}

/* Index-by-index equality of every field; prints the first difference. */
static int same_diagram(const char *what, const mgs_diagram *a, const mgs_diagram *b) {
  if (a->n != b->n) {
    fprintf(stderr, "  %s: %zu pairs (dual) vs %zu (reduction)\n", what, a->n, b->n);
    return 0;
  }
  for (size_t i = 0; i < a->n; i++) {
    const mgs_pair *p = &a->pairs[i], *q = &b->pairs[i];
    int fin = isfinite(p->death);
    if (p->dim != q->dim || p->birth != q->birth || p->death != q->death || p->truncated != q->truncated ||
        !same_end(&p->b, &q->b) || (fin && !same_end(&p->d, &q->d))) {
      fprintf(stderr, "  %s: pair %zu: dual (%d %.9g %.9g cells %llx %llx trunc %d) reduction (%d %.9g %.9g cells %llx %llx trunc %d)\n",
              what, i, p->dim, p->birth, p->death, (unsigned long long)p->b.cell, (unsigned long long)(fin ? p->d.cell : 0),
              p->truncated, q->dim, q->birth, q->death, (unsigned long long)q->b.cell,
              (unsigned long long)(isfinite(q->death) ? q->d.cell : 0), q->truncated);
      return 0;
    }
  }
  return 1;
}

static void compare(const char *name, const float *f, int N, double w, int cons, int sup, int sparse) {
  for (int full_red = 0; full_red < 2; full_red++) {
    mgs_topo_stats su, sr;
    memset(&su, 0, sizeof su);
    memset(&sr, 0, sizeof sr);
    mgs_diagram *du = run(f, N, w, cons, sup, full_red, 0, sparse, &su), *dr = run(f, N, w, cons, sup, full_red, 1, sparse, &sr);
    char what[192];
    snprintf(what, sizeof what, "%s N=%d w=%g %c %s %s %s", name, N, w, cons ? 'T' : 'V', sup ? "super" : "sub",
             sparse ? "band" : "dense", full_red ? "full reduction" : "gradient");
    if (du && dr) {
      n_cases++;
      CHECK_MSG(same_diagram(what, du, dr), "%s: dual union-find and reduction differ", what);
      CHECK_MSG(su.d2_union_find == 1, "%s: the dual union-find did not run", what);
      CHECK(sr.d2_union_find == 0);
      d2_dual_runs += (size_t)su.d2_union_find;
      CHECK(su.pairs_d[0] == sr.pairs_d[0] && su.pairs_d[1] == sr.pairs_d[1] && su.pairs_d[2] == sr.pairs_d[2]);
      CHECK(su.truncated == sr.truncated && su.persistent_cells == sr.persistent_cells);
      size_t fin = 0, ess = 0;
      for (size_t i = 0; i < du->n; i++)
        if (du->pairs[i].dim == 2) {
          if (du->pairs[i].truncated && du->pairs[i].death == (double)(float)w) ess++; /* died at the clamp: a void of the band */
          else fin++;
        }
      d2_finite += fin;
      d2_essential += ess;
      if (!full_red)
        fprintf(stderr, "  %s: %zu pairs, D2 %zu (%zu at a maximum, %zu at +w)\n", what, du->n, su.pairs_d[2], fin, ess);
    }
    mgs_diagram_destroy(du);
    mgs_diagram_destroy(dr);
  }
}

static void field_case(int kind, int N, double w, int cons, int sup, int sparse, uint32_t seed) {
  float *f = kind == DT_CHEESE ? cheese(N, seed) : tt_field(kind, N, seed);
  char name[64];
  snprintf(name, sizeof name, "%s seed %u", kind == DT_CHEESE ? "cheese" : tt_names[kind], seed);
  compare(name, f, N, w, cons, sup, sparse);
  free(f);
}

static void test_dual_equals_reduction(void) {
  for (int cons = 0; cons < 2; cons++) {
    /* random: many maxima, unique values (cells agree exactly) */
    for (uint32_t seed = 1; seed <= (full ? 10u : 3u); seed++) field_case(TT_RANDOM, 10 + (int)seed % 5, INFINITY, cons, 0, 0, seed);
    field_case(TT_RANDOM, 14, INFINITY, cons, 1, 0, 31);
    /* random clamped at +-0.4: plateaus at both ends, +w regions everywhere (many outsides) */
    field_case(TT_RANDOM, 16, 0.4, cons, 0, 0, 32);
    field_case(TT_RANDOM, 16, 0.4, cons, 0, 1, 33);
    field_case(TT_RANDOM, 16, 0.4, cons, 1, 0, 34); /* superlevel: dense (a band needs a fog volume) */
    /* noisy cavities: maxima inside small ones, +w inside large ones; band with -w tiles */
    field_case(DT_CHEESE, 40, INFINITY, cons, 0, 0, 5);
    field_case(DT_CHEESE, 40, 2.0 / 40, cons, 0, 1, 5);
    field_case(DT_CHEESE, 40, 2.0 / 40, cons, 1, 0, 6);
    /* nested sphere shells (noisy): voids inside each shell */
    field_case(TT_SHELLS, 32, INFINITY, cons, 0, 0, 5);
    field_case(TT_SHELLS, 32, 2.0 / 32, cons, 0, 1, 5);
    field_case(TT_SPHERE_SHELL, 32, 2.0 / 32, cons, 0, 1, 5);
    /* bands with interior tiles */
    field_case(TT_TUNNEL_BLOCK, 64, 2.0 / 64, cons, 0, 1, 5);
    field_case(TT_FLOATERS, 32, 3.0 / 32, cons, 0, 1, 5);
    if (!full) continue;
    field_case(DT_CHEESE, 64, 3.0 / 64, cons, 0, 1, 7);
    field_case(TT_TORUS_SHELL, 48, 3.0 / 48, cons, 0, 1, 7);
    field_case(TT_NOISY_TORUS, 48, INFINITY, cons, 0, 0, 7);
    field_case(TT_GENUS2, 40, 3.0 / 40, cons, 1, 0, 7);
  }
  fprintf(stderr, "  %zu comparisons (%zu with the dual union-find): %zu finite and %zu clamp-truncated D2 pairs\n", n_cases,
          d2_dual_runs, d2_finite, d2_essential);
  /* not vacuous: both kinds of dimension-2 pairs occurred */
  CHECK(n_cases > 0 && d2_finite > 100 && d2_essential > 10);
}

int main(int argc, char **argv) {
  full = argc > 1 && !strcmp(argv[1], "full");
  RUN(test_dual_equals_reduction);
  return mgs_test_finish();
}
