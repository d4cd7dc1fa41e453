/* train/mgs_morse_grad.h: the α-field at points against vdb/'s grid, the spatial index
 * against brute force, the closest point against a sphere, and finite differences of the
 * whole chain Gaussian parameters -> A at c -> SDF at the voxel -> loss (pairing fixed:
 * the voxels stay, their closest points are found again on the perturbed surface), on
 * scenes at tiny and huge scales, α near 0 and 1, near-singular covariances and a 1e5
 * offset. FD errors are printed (docs/notes/morse-grad.md quotes them). Also the grid
 * closest point from critical cells where ∇A vanishes (a blob's core, a gap's middle). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "core/mgs_core.h"
#include "mgs_test.h"
#include "train/mgs_morse.h"
#include "train/mgs_morse_grad.h"
#include "vdb/mgs_vdb.h"

static mgs_gaussians *model(size_t n) {
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, NULL)) exit(2);
  return g;
}

/* A cluster of n anisotropic, rotated, overlapping Gaussians around `offset`, all lengths
 * times `scale`. */
static mgs_gaussians *cluster(size_t n, double scale, const double offset[3], uint64_t seed) {
  mgs_rng r;
  mgs_rng_init(&r, seed, 3);
  mgs_gaussians *g = model(n);
  for (size_t i = 0; i < n; i++) {
    for (int k = 0; k < 3; k++) {
      g->mean[3 * i + k] = (float)(offset[k] + scale * 0.5 * (2 * mgs_rng_uniform(&r) - 1));
      g->log_scale[3 * i + k] = (float)log(scale * (0.25 + 0.2 * mgs_rng_uniform(&r)));
    }
    for (int k = 0; k < 4; k++) g->rot[4 * i + k] = (float)(mgs_rng_normal(&r) * 1.7); /* not normalized */
    g->opacity[i] = (float)(0.5 + 2 * mgs_rng_uniform(&r));
  }
  return g;
}

/* ---------------------------------------------------------------- field vs vdb */
static void test_field_matches_vdb(void) {
  const double off[3] = {0.3, -0.2, 0.1};
  mgs_gaussians *g = cluster(12, 1.0, off, 7);
  g->log_scale[0] = logf(1e-3f); /* one thinner than a voxel: the filter matters */
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = 0.05;
  mgs_vdb_grid *grid = NULL;
  mgs_error err;
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &grid, NULL, &err), &err);
  if (!grid) { mgs_gaussians_destroy(g); return; }
  mgs_morse_field_params p = {ap.k_sigma, mgs_morse_filter_var(ap.voxel_size, MGS_VDB_SMALL_PEAK)};
  mgs_morse_index *ix = NULL;
  CHECK_OK(mgs_morse_index_create(g, &p, &ix, &err), &err);
  size_t nl = mgs_vdb_leaf_count(grid);
  mgs_vdb_leaf_view *lv = malloc(nl * sizeof *lv);
  mgs_vdb_leaf_views(grid, lv, nl);
  double maxdiff = 0, maxval = 0;
  size_t checked = 0, mismatch = 0;
  for (size_t l = 0; l < nl; l++)
    for (int o = 0; o < 512; o += 7) {
      if (!mgs_vdb_leaf_is_active(&lv[l], o)) continue;
      double ijk[3] = {lv[l].origin[0] + (o >> 6), lv[l].origin[1] + ((o >> 3) & 7), lv[l].origin[2] + (o & 7)}, x[3];
      mgs_vdb_index_to_world(grid, ijk, x);
      double A, Ab;
      CHECK_OK(mgs_morse_alpha_at(g, ix, NULL, x, &A, NULL, &err), &err);
      CHECK_OK(mgs_morse_alpha_at(g, NULL, &p, x, &Ab, NULL, &err), &err);
      const double diff = fabs(A - lv[l].values[o]);
      if (diff > 2e-5 * (1 + A)) {
        /* vdb/ tests q <= k² in float: a Gaussian whose kσ boundary passes within rounding
           of this voxel centre may be in one sum and not the other (a jump of α e^{-k²/2}) */
        mismatch++;
        CHECK(diff < 0.0112);
      } else {
        maxdiff = fmax(maxdiff, diff);
      }
      maxval = fmax(maxval, A);
      CHECK_NEAR(A, Ab, 1e-12 * (1 + A)); /* index = brute force */
      checked++;
    }
  fprintf(stderr, "  field vs vdb grid: %zu voxels, max |A - grid| = %.3g (max A %.3g), %zu on a cutoff boundary\n",
          checked, maxdiff, maxval, mismatch);
  CHECK(checked > 1000);
  CHECK(mismatch <= checked / 1000);
  free(lv);
  mgs_morse_index_destroy(ix);
  mgs_vdb_grid_destroy(grid);
  mgs_gaussians_destroy(g);
}

/* ∇A against central differences of A, and the index against brute force away from the
 * cluster (empty cells, points outside the index's range). */
static void test_spatial_gradient_and_index(void) {
  const double off[3] = {0, 0, 0};
  mgs_gaussians *g = cluster(40, 1.0, off, 11);
  g->log_scale[3 * 5] = 3.0f; /* one huge Gaussian: the index's global list */
  g->opacity[5] = -4.0f;
  mgs_morse_field_params p = {3.0, 0.0};
  mgs_morse_index *ix = NULL;
  mgs_error err;
  CHECK_OK(mgs_morse_index_create(g, &p, &ix, &err), &err);
  mgs_rng r;
  mgs_rng_init(&r, 5, 5);
  double worst = 0;
  for (int t = 0; t < 300; t++) {
    double x[3];
    for (int k = 0; k < 3; k++) x[k] = 6 * (2 * mgs_rng_uniform(&r) - 1);
    double A, Ab, gr[3], gb[3];
    CHECK_OK(mgs_morse_alpha_at(g, ix, NULL, x, &A, gr, &err), &err);
    CHECK_OK(mgs_morse_alpha_at(g, NULL, &p, x, &Ab, gb, &err), &err);
    CHECK_NEAR(A, Ab, 1e-12 * (1 + A));
    for (int k = 0; k < 3; k++) CHECK_NEAR(gr[k], gb[k], 1e-12 * (1 + fabs(gb[k])));
    for (int k = 0; k < 3; k++) {
      double h = 1e-6, xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]}, Ap, Am;
      xp[k] += h; xm[k] -= h;
      mgs_morse_alpha_at(g, ix, NULL, xp, &Ap, NULL, &err);
      mgs_morse_alpha_at(g, ix, NULL, xm, &Am, NULL, &err);
      double fd = (Ap - Am) / (2 * h);
      /* a kσ boundary between xm and xp makes a jump: skip those (rare) */
      if (fabs(fd - gr[k]) > 1e-3 && fabs(Ap - Am) > 1e-4) continue;
      worst = fmax(worst, fabs(fd - gr[k]) / (1 + fabs(gr[k])));
    }
  }
  fprintf(stderr, "  grad A vs FD: max rel error %.3g\n", worst);
  CHECK(worst < 1e-6);
  mgs_morse_index_destroy(ix);
  mgs_gaussians_destroy(g);
}

/* The index after parameter changes: small moves keep it (exact through the padding),
 * large ones or a new count rebuild it; A through the index = brute force throughout. */
static double index_vs_brute(const mgs_gaussians *g, const mgs_morse_index *ix, uint64_t seed) {
  mgs_rng r;
  mgs_rng_init(&r, seed, 2);
  mgs_error err;
  double worst = 0;
  for (int t = 0; t < 400; t++) {
    double x[3], A, Ab, gr[3], gb[3];
    for (int k = 0; k < 3; k++) x[k] = 2.5 * (2 * mgs_rng_uniform(&r) - 1);
    mgs_morse_alpha_at(g, ix, NULL, x, &A, gr, &err);
    mgs_morse_alpha_at(g, NULL, &(mgs_morse_field_params){3.0, 0.0}, x, &Ab, gb, &err);
    worst = fmax(worst, fabs(A - Ab));
  }
  return worst;
}

static void test_index_update(void) {
  const double off[3] = {0, 0, 0};
  mgs_gaussians *g = cluster(60, 1.0, off, 13);
  for (size_t i = 0; i < g->n; i++)
    for (int k = 0; k < 3; k++) { g->mean[3 * i + k] *= 3.0f; g->log_scale[3 * i + k] -= 0.7f; }
  mgs_morse_field_params p = {3.0, 0.0};
  mgs_morse_index *ix = NULL;
  mgs_error err;
  CHECK_OK(mgs_morse_index_create(g, &p, &ix, &err), &err);
  int rebuilt = -1;
  /* small drift: 5 % of a std-dev, scales +5 % */
  for (size_t i = 0; i < g->n; i++) {
    g->mean[3 * i] += 0.05f * expf(g->log_scale[3 * i]);
    g->log_scale[3 * i + 1] += 0.05f;
  }
  CHECK_OK(mgs_morse_index_update(&ix, g, &rebuilt, &err), &err);
  CHECK(rebuilt == 0);
  CHECK(index_vs_brute(g, ix, 1) < 1e-12);
  /* a large jump of one Gaussian: rebuilt, still exact */
  g->mean[3 * 7] += 2.0f;
  CHECK_OK(mgs_morse_index_update(&ix, g, &rebuilt, &err), &err);
  CHECK(rebuilt == 1);
  CHECK(index_vs_brute(g, ix, 3) < 1e-12);
  /* a new count: rebuilt */
  size_t first;
  CHECK_OK(mgs_gaussians_append(g, 1, &first, &err), &err);
  g->log_scale[3 * first] = g->log_scale[3 * first + 1] = g->log_scale[3 * first + 2] = -1.0f;
  g->opacity[first] = 2.0f;
  CHECK_OK(mgs_morse_index_update(&ix, g, &rebuilt, &err), &err);
  CHECK(rebuilt == 1 && mgs_morse_index_count(ix) == g->n);
  CHECK(index_vs_brute(g, ix, 4) < 1e-12);
  mgs_morse_index_destroy(ix);
  mgs_gaussians_destroy(g);
}

/* ---------------------------------------------------------------- closest point */
static void test_sphere(void) {
  /* one isotropic Gaussian: {A = τ} is the sphere r = σ sqrt(2 ln(α/τ)) */
  mgs_gaussians *g = model(1);
  const double sigma = 0.3, alpha = 0.9, tau = 0.25, mu[3] = {1, 2, -1};
  for (int k = 0; k < 3; k++) { g->mean[k] = (float)mu[k]; g->log_scale[k] = (float)log(sigma); }
  g->rot[0] = 2.0f; g->rot[1] = 0.3f; /* un-normalized, irrelevant for a sphere */
  g->opacity[0] = (float)log(alpha / (1 - alpha));
  const double a = 1 / (1 + exp(-(double)g->opacity[0])), s = exp((double)g->log_scale[0]);
  const double rad = s * sqrt(2 * log(a / (double)(float)tau));
  mgs_morse_field_params p = {10.0, 0.0};
  mgs_error err;
  const double dirs[3][3] = {{1, 0, 0}, {0.6, 0.8, 0}, {-0.48, 0.6, 0.64}};
  const double dist[3] = {0.12, -0.1, 0.03};
  for (int t = 0; t < 3; t++) {
    double x[3], c[3], d;
    for (int k = 0; k < 3; k++) x[k] = g->mean[k] + (rad + dist[t]) * dirs[t][k];
    CHECK_OK(mgs_morse_closest_point(g, NULL, &p, x, (float)tau, c, &d, &err), &err);
    CHECK_NEAR(d, dist[t], 1e-9);
    for (int k = 0; k < 3; k++) CHECK_NEAR(c[k], g->mean[k] + rad * dirs[t][k], 1e-9);
    /* analytic ∂d/∂θ for d = |x−μ| − r(θ): ∂/∂μ = −dir, ∂/∂log σ_k sums to −r, ∂/∂logit = −σ²(1−α)/r */
    mgs_gaussians *gr = model(1);
    memset(gr->rot, 0, 4 * sizeof(float));
    double A;
    CHECK_OK(mgs_morse_sdf_point_grad(g, c, (float)tau, 1.0, gr, &A, &err), &err);
    CHECK_NEAR(A, tau, 1e-9);
    for (int k = 0; k < 3; k++) CHECK_NEAR(gr->mean[k], -dirs[t][k], 1e-6);
    CHECK_NEAR(gr->log_scale[0] + gr->log_scale[1] + gr->log_scale[2], -rad, 1e-6);
    CHECK_NEAR(gr->opacity[0], -s * s * (1 - a) / rad, 1e-6);
    for (int k = 0; k < 4; k++) CHECK_NEAR(gr->rot[k], 0, 1e-6);
    mgs_gaussians_destroy(gr);
  }
  /* a point where no Gaussian reaches: a clear error, not a NaN */
  double far[3] = {100, 0, 0}, c[3];
  CHECK(mgs_morse_closest_point(g, NULL, &p, far, (float)tau, c, NULL, &err) == MGS_ERR_NUMERIC);
  mgs_gaussians_destroy(g);
}

/* ------------------------------------------------------ grid closest point, flat ∇A */
/* A bar's end sits on a critical cell of d; deep inside a blob or midway across a gap ∇A
   is zero there and Newton along ∇A cannot start. The analysis must still find the surface
   point the end moves with (before the search fallback: none, so those bars got no
   gradient — two thirds of the thin scene's H0 ends). */
static void test_grid_closest_flat(void) {
  const double sigma = 0.1, alpha = 0.9, tau = 0.5, h = 0.02;
  const double rad = sigma * sqrt(2 * log(alpha / tau));
  for (int two = 0; two < 2; two++) {
    const double cx = two ? 0.2 : 0.0; /* one blob at 0, or two at ±0.2 */
    mgs_gaussians *g = model(two ? 2 : 1);
    for (int b = 0; b <= two; b++) {
      g->mean[3 * b] = (float)(b ? -cx : cx);
      for (int k = 0; k < 3; k++) g->log_scale[3 * b + k] = (float)log(sigma);
      g->rot[4 * b] = 1.0f;
      g->opacity[b] = (float)log(alpha / (1 - alpha));
    }
    mgs_vdb_alpha_params ap;
    mgs_vdb_alpha_params_default(&ap);
    ap.voxel_size = h;
    mgs_vdb_grid *grid = NULL;
    mgs_error err;
    CHECK_OK(mgs_vdb_alpha_field(g, &ap, &grid, NULL, &err), &err);
    if (!grid) { mgs_gaussians_destroy(g); return; }
    /* the critical point exactly on a voxel centre: the grid's gradient there is zero */
    double ijk[3] = {0, 0, 0}, x[3], c[3], gn = 0;
    mgs_vdb_index_to_world(grid, ijk, x);
    CHECK_NEAR(x[0], 0, 1e-12);
    float xf[3] = {0, 0, 0}, gr[3], a0;
    mgs_vdb_sample_gradient(grid, 1, xf, gr, &a0);
    CHECK(gr[0] == 0 && gr[1] == 0 && gr[2] == 0);
    CHECK(two ? a0 < tau : a0 > tau);
    double expect = two ? cx - rad : rad; /* distance from x to {A = τ} */
    CHECK(mgs_morse_grid_closest_point(grid, tau, x, expect + 2 * h, c, &gn) == 1);
    double r0 = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    fprintf(stderr, "  %s: closest point at %.4f (surface at %.4f), |grad A| %.3f\n", two ? "gap middle" : "blob core",
            r0, expect, gn);
    CHECK(fabs(r0 - expect) < 0.5 * h); /* the filtered, trilinear field: within half a voxel */
    CHECK(gn > 0);
    float cf[3] = {(float)c[0], (float)c[1], (float)c[2]}, ac;
    mgs_vdb_sample(grid, 1, cf, &ac);
    CHECK_NEAR(ac, tau, 1e-3 * tau);
    /* not beyond max_travel */
    CHECK(mgs_morse_grid_closest_point(grid, tau, x, 0.5 * expect, c, &gn) == 0);
    mgs_vdb_grid_destroy(grid);
    mgs_gaussians_destroy(g);
  }
}

/* The SDF the derivative is of: closest-point distances on the filtered k=3 field equal
 * vdb/'s SDF grid (the analysis's) at band voxels, to its stated accuracy; the projection
 * lands on the surface. */
static void test_sdf_matches_vdb(void) {
  const double off[3] = {0.1, 0.2, -0.3};
  mgs_gaussians *g = cluster(10, 1.0, off, 17);
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = 0.04;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.tau = 0.4;
  mgs_vdb_grid *al = NULL, *sdf = NULL;
  mgs_error err;
  CHECK_OK(mgs_vdb_alpha_field(g, &ap, &al, NULL, &err), &err);
  if (al) CHECK_OK(mgs_vdb_sdf_from_alpha(al, &sp, &sdf, &err), &err);
  if (!sdf) { mgs_vdb_grid_destroy(al); mgs_gaussians_destroy(g); return; }
  mgs_morse_field_params p = {ap.k_sigma, mgs_morse_filter_var(ap.voxel_size, MGS_VDB_SMALL_PEAK)};
  mgs_morse_index *ix = NULL;
  CHECK_OK(mgs_morse_index_create(g, &p, &ix, &err), &err);
  size_t nl = mgs_vdb_leaf_count(sdf);
  mgs_vdb_leaf_view *lv = malloc(nl * sizeof *lv);
  mgs_vdb_leaf_views(sdf, lv, nl);
  double worst = 0, sum = 0, worst_proj = 0;
  size_t cnt = 0, failed = 0;
  for (size_t l = 0; l < nl; l++)
    for (int o = 0; o < 512; o += 3) {
      if (!mgs_vdb_leaf_is_active(&lv[l], o)) continue;
      const float v = lv[l].values[o];
      if (fabs(v) > 1.5 * ap.voxel_size) continue; /* the first rings, where the grid is exact */
      double ijk[3] = {lv[l].origin[0] + (o >> 6), lv[l].origin[1] + ((o >> 3) & 7), lv[l].origin[2] + (o & 7)}, x[3], c[3], d;
      mgs_vdb_index_to_world(sdf, ijk, x);
      if (mgs_morse_closest_point(g, ix, NULL, x, (float)sp.tau, c, &d, &err)) { failed++; continue; }
      worst = fmax(worst, fabs(d - v) / ap.voxel_size);
      sum += fabs(d - v) / ap.voxel_size;
      cnt++;
      double pc[3], A;
      if (mgs_morse_project(g, ix, NULL, x, (float)sp.tau, pc, &err) == MGS_OK) {
        mgs_morse_alpha_at(g, ix, NULL, pc, &A, NULL, &err);
        worst_proj = fmax(worst_proj, fabs(A - sp.tau));
      }
    }
  fprintf(stderr, "  SDF vs vdb grid: %zu band voxels (%zu without a closest point), |d - grid| mean %.4f max %.4f voxel; projection |A - tau| max %.2g\n",
          cnt, failed, sum / (double)(cnt ? cnt : 1), worst, worst_proj);
  /* where {A = τ} runs along a kσ cutoff the field jumps across τ: no point has A = τ
     there, and the closest point is refused (documented); a few percent at k = 3 */
  CHECK(cnt > 500);
  CHECK(failed <= cnt / 15);
  CHECK(sum / (double)cnt < 0.05);
  CHECK(worst < 0.5);
  CHECK(worst_proj < 1e-7);
  free(lv);
  mgs_morse_index_destroy(ix);
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(al);
  mgs_gaussians_destroy(g);
}

/* ---------------------------------------------------------------- the whole chain */
typedef struct chain {
  mgs_gaussians *g;
  mgs_morse_field_params p;
  float tau;
  int nv;
  double x[8][3];   /* the critical voxels (fixed) */
  double w[8];      /* loss = Σ w_v d_v + ½ (d_0 − d_1)² */
} chain;

static int chain_d(const chain *ch, double d[8]) {
  mgs_error err;
  for (int v = 0; v < ch->nv; v++) {
    double c[3];
    if (mgs_morse_closest_point(ch->g, NULL, &ch->p, ch->x[v], ch->tau, c, &d[v], &err)) {
      fprintf(stderr, "  voxel %d: %s\n", v, err.msg);
      return -1;
    }
  }
  return 0;
}
static double chain_loss(const double d[8], const chain *ch) {
  double L = 0;
  for (int v = 0; v < ch->nv; v++) L += ch->w[v] * d[v];
  return L + 0.5 * (d[0] - d[1]) * (d[0] - d[1]);
}

/* Picks voxels around the surface: points at ±(0.1 .. 0.4)·scale from it, inside and out. */
static int pick_voxels(chain *ch, double scale, uint64_t seed) {
  mgs_rng r;
  mgs_rng_init(&r, seed, 9);
  mgs_error err;
  double ctr[3] = {0, 0, 0};
  for (size_t i = 0; i < ch->g->n; i++)
    for (int k = 0; k < 3; k++) ctr[k] += ch->g->mean[3 * i + k] / (double)ch->g->n;
  int tries = 0;
  ch->nv = 0;
  while (ch->nv < 6 && tries++ < 400) {
    /* march from the centre outward along a random direction to the last crossing */
    double dir[3], l = 0;
    for (int k = 0; k < 3; k++) { dir[k] = mgs_rng_normal(&r); l += dir[k] * dir[k]; }
    l = sqrt(l);
    double y[3], A = 0, prev = 1e9, tcross = -1;
    for (double t = 0; t < 3 * scale; t += 0.01 * scale) {
      for (int k = 0; k < 3; k++) y[k] = ctr[k] + t * dir[k] / l;
      mgs_morse_alpha_at(ch->g, NULL, &ch->p, y, &A, NULL, &err);
      if (prev > ch->tau && A <= ch->tau) tcross = t;
      prev = A;
    }
    if (tcross < 0) continue;
    double off = (0.1 + 0.3 * mgs_rng_uniform(&r)) * scale * (ch->nv % 2 ? -0.5 : 1.0);
    double x[3], c[3], d;
    for (int k = 0; k < 3; k++) x[k] = ctr[k] + (tcross + off) * dir[k] / l;
    if (mgs_morse_closest_point(ch->g, NULL, &ch->p, x, ch->tau, c, &d, &err)) continue;
    mgs_morse_point pt;
    mgs_gaussians *tmp = mgs_gaussians_clone(ch->g);
    mgs_morse_index *ix = NULL;
    mgs_morse_index_create(ch->g, &ch->p, &ix, &err);
    mgs_morse_sdf_point_grad_ix(ch->g, ix, c, ch->tau, 0.0, tmp, &pt, &err);
    mgs_morse_index_destroy(ix);
    mgs_gaussians_destroy(tmp);
    /* a regular surface point with a unique closest point (well-conditioned FD) */
    if (pt.grad_norm * scale < 0.05 || fabs(d) < 0.05 * scale) continue;
    memcpy(ch->x[ch->nv], x, sizeof x);
    ch->w[ch->nv] = ch->nv % 2 ? -0.7 : 1.3;
    ch->nv++;
  }
  return ch->nv >= 4 ? 0 : -1;
}

/* Compares the analytic gradient of the loss with central differences over every
 * parameter of every Gaussian. Returns the max relative error. */
static double chain_fd(chain *ch, double scale, const char *name) {
  mgs_error err;
  mgs_gaussians *g = ch->g;
  double d[8];
  if (chain_d(ch, d)) { CHECK_MSG(0, "%s: closest point failed", name); return 1; }
  mgs_gaussians *gr = model(g->n);
  memset(gr->rot, 0, g->n * 4 * sizeof(float));
  mgs_morse_index *ix = NULL;
  CHECK_OK(mgs_morse_index_create(g, &ch->p, &ix, &err), &err);
  for (int v = 0; v < ch->nv; v++) {
    double c[3], dv;
    mgs_morse_closest_point(g, ix, NULL, ch->x[v], ch->tau, c, &dv, &err);
    CHECK_NEAR(dv, d[v], 1e-9 * scale); /* index and brute force agree */
    double dL = ch->w[v] + (v == 0 ? d[0] - d[1] : v == 1 ? d[1] - d[0] : 0);
    mgs_morse_point pt;
    CHECK_OK(mgs_morse_sdf_point_grad_ix(g, ix, c, ch->tau, dL, gr, &pt, &err), &err);
    CHECK(!pt.floored);
  }
  mgs_morse_index_destroy(ix);
  /* parameter groups and their FD steps (means relative to the scene, at least 4 ulp) */
  const mgs_param_group groups[4] = {MGS_PARAM_MEAN, MGS_PARAM_LOG_SCALE, MGS_PARAM_ROT, MGS_PARAM_OPACITY};
  double worst = 0, gmax = 0;
  int checked = 0;
  for (int gi = 0; gi < 4; gi++) {
    int dim = mgs_param_dim(groups[gi]);
    float *P = mgs_gaussians_group(g, groups[gi]), *D = mgs_gaussians_group(gr, groups[gi]);
    for (size_t i = 0; i < g->n; i++)
      for (int k = 0; k < dim; k++) {
        float *pp = &P[(size_t)dim * i + k];
        const float p0 = *pp;
        double h = groups[gi] == MGS_PARAM_MEAN ? 1e-4 * scale : 1e-4;
        h = fmax(h, 4 * fabs(nextafterf(p0, INFINITY) - p0));
        double dp[8], dm[8];
        *pp = (float)(p0 + h);
        const double hp = (double)*pp - p0;
        int bad = chain_d(ch, dp);
        *pp = (float)(p0 - h);
        const double hm = (double)*pp - p0;
        bad |= chain_d(ch, dm);
        *pp = p0;
        if (bad) { CHECK_MSG(0, "%s: closest point failed after perturbing", name); continue; }
        double fd = (chain_loss(dp, ch) - chain_loss(dm, ch)) / (hp - hm);
        double an = D[(size_t)dim * i + k];
        /* relative to the gradient's overall size (units: d per parameter unit) */
        double ref = groups[gi] == MGS_PARAM_MEAN ? 1.0 : scale;
        double e = fabs(fd - an) / (ref + fabs(an));
        gmax = fmax(gmax, fabs(an));
        if (e > worst) worst = e;
        if (e > 2e-3) fprintf(stderr, "  %s: %s[%zu][%d] analytic %.8g fd %.8g\n", name, mgs_param_name(groups[gi]), i, k, an, fd);
        checked++;
      }
  }
  fprintf(stderr, "  chain %-22s %d params, %d voxels, max rel error %.3g (max |grad| %.3g)\n", name, checked, ch->nv,
          worst, gmax);
  CHECK(checked == (int)g->n * 11);
  CHECK(gmax > 0);
  mgs_gaussians_destroy(gr);
  return worst;
}

static void run_chain(const char *name, double scale, const double off[3], uint64_t seed, void (*edit)(mgs_gaussians *),
                      double filter_var) {
  chain ch;
  memset(&ch, 0, sizeof ch);
  ch.g = cluster(5, scale, off, seed);
  if (edit) edit(ch.g);
  ch.p.k_sigma = 10.0; /* supports wide enough that no cutoff jump falls between FD samples */
  ch.p.filter_var = filter_var * scale * scale;
  ch.tau = 0.3f;
  if (pick_voxels(&ch, scale, seed)) {
    CHECK_MSG(0, "%s: could not place voxels", name);
  } else {
    double e = chain_fd(&ch, scale, name);
    CHECK_MSG(e < 2e-3, "%s: FD error %.3g", name, e);
  }
  mgs_gaussians_destroy(ch.g);
}

static void edit_alpha_extremes(mgs_gaussians *g) {
  g->opacity[0] = 12.0f;  /* α = 1 − 6e-6 */
  g->opacity[1] = -9.0f;  /* α = 1.2e-4: too faint to reach τ alone */
  g->opacity[2] = 7.0f;
}
static void edit_near_singular(mgs_gaussians *g) {
  g->log_scale[0 * 3 + 2] = g->log_scale[0] - logf(1e4f); /* a disc 1e4 thinner than wide */
  g->log_scale[1 * 3 + 1] = g->log_scale[3] - logf(300.0f);
  g->opacity[0] = 3.0f;
}

static void test_chain(void) {
  const double zero[3] = {0, 0, 0}, far[3] = {1e5, -1e5, 5e4}, mid[3] = {3e-4, 0, -2e-4};
  run_chain("unit", 1.0, zero, 21, NULL, 0);
  run_chain("unit, filtered", 1.0, zero, 22, NULL, 0.01);
  run_chain("tiny (1e-4)", 1e-4, mid, 23, NULL, 0);
  run_chain("huge (1e3)", 1e3, zero, 24, NULL, 0);
  run_chain("alpha near 0 and 1", 1.0, zero, 25, edit_alpha_extremes, 0);
  run_chain("near-singular", 1.0, zero, 26, edit_near_singular, 0);
  run_chain("1e5 offset", 10.0, far, 27, NULL, 0);
}

/* ---------------------------------------------------------------- guards */
static void test_flat_gradient_guard(void) {
  /* two equal Gaussians: at the midpoint ∇A = 0; with τ = A(mid) the surface pinches */
  mgs_gaussians *g = model(2);
  for (int i = 0; i < 2; i++) {
    g->mean[3 * i] = i ? 0.5f : -0.5f;
    for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = logf(0.4f);
    g->opacity[i] = 2.0f;
  }
  double mid[3] = {0, 0, 0}, A, gA[3];
  mgs_error err;
  CHECK_OK(mgs_morse_alpha_at(g, NULL, NULL, mid, &A, gA, &err), &err);
  CHECK(fabs(gA[0]) < 1e-12);
  mgs_gaussians *gr = model(2);
  memset(gr->rot, 0, 8 * sizeof(float));
  mgs_morse_index *ix = NULL;
  mgs_morse_field_params p;
  mgs_morse_field_params_default(&p);
  CHECK_OK(mgs_morse_index_create(g, &p, &ix, &err), &err);
  mgs_morse_point pt;
  CHECK_OK(mgs_morse_sdf_point_grad_ix(g, ix, mid, (float)A, 1.0, gr, &pt, &err), &err);
  CHECK(pt.floored == 1);
  CHECK(pt.contributors == 2);
  /* bounded as documented: |∂d/∂θ| <= 1000 σ |∂A/∂θ| / τ, and finite */
  double a = 1 / (1 + exp(-2.0)), G = a * exp(-0.5 * 0.25 / (0.4 * 0.4));
  CHECK(isfinite(gr->opacity[0]) && fabs(gr->opacity[0]) <= 1000 * 0.4 * G * (1 - a) / A * 1.0001);
  for (int k = 0; k < 3; k++) CHECK(isfinite(gr->mean[k]) && isfinite(gr->log_scale[k]));
  /* a point reached by no Gaussian adds nothing */
  double far[3] = {50, 0, 0};
  mgs_gaussians *gr2 = mgs_gaussians_clone(gr);
  CHECK_OK(mgs_morse_sdf_point_grad_ix(g, ix, far, 0.3f, 1.0, gr2, &pt, &err), &err);
  CHECK(pt.contributors == 0 && gr2->opacity[0] == gr->opacity[0]);
  /* bad input */
  mgs_gaussians *small = model(1);
  CHECK(mgs_morse_sdf_point_grad(g, mid, 0.3f, 1.0, small, NULL, &err) == MGS_ERR_ARG);
  CHECK(mgs_morse_sdf_point_grad(g, mid, 0.0f, 1.0, gr, NULL, &err) == MGS_ERR_ARG);
  mgs_morse_field_params bad = {3.0, -1.0};
  mgs_morse_index *ix2 = NULL;
  CHECK(mgs_morse_index_create(g, &bad, &ix2, &err) == MGS_ERR_UNSUPPORTED);
  CHECK(mgs_morse_sdf_point_grad_ix(small, ix, mid, 0.3f, 1.0, small, NULL, &err) == MGS_ERR_ARG);
  mgs_gaussians_destroy(small);
  mgs_gaussians_destroy(gr2);
  mgs_gaussians_destroy(gr);
  mgs_morse_index_destroy(ix);
  mgs_gaussians_destroy(g);
}

/* Cost per call on a model of 50k Gaussians (printed; the notes quote it). Process CPU
 * time, so the figure does not depend on how loaded the machine is (the calls are serial). */
static double cpu_now(void) { return (double)clock() / CLOCKS_PER_SEC; }
static void test_cost(void) {
  const double zero[3] = {0, 0, 0};
  mgs_gaussians *g = cluster(50000, 1.0, zero, 31);
  for (size_t i = 0; i < g->n; i++)
    for (int k = 0; k < 3; k++) { g->mean[3 * i + k] *= 20.0f; g->log_scale[3 * i + k] -= 1.0f; }
  mgs_morse_field_params p = {3.0, 0.0};
  mgs_error err;
  mgs_morse_index *ix = NULL;
  double t0 = cpu_now();
  CHECK_OK(mgs_morse_index_create(g, &p, &ix, &err), &err);
  double t1 = cpu_now();
  mgs_gaussians *gr = model(g->n);
  mgs_rng r;
  mgs_rng_init(&r, 1, 1);
  const int calls = 2000;
  int contrib = 0;
  for (int t = 0; t < calls; t++) {
    double c[3];
    for (int k = 0; k < 3; k++) c[k] = 10 * (2 * mgs_rng_uniform(&r) - 1);
    mgs_morse_point pt;
    mgs_morse_sdf_point_grad_ix(g, ix, c, 0.3f, 1.0, gr, &pt, &err);
    contrib += pt.contributors;
  }
  double t2 = cpu_now();
  for (int t = 0; t < 20; t++) {
    double c[3] = {0.1 * t, 0.2, 0.3};
    mgs_morse_sdf_point_grad(g, c, 0.3f, 1.0, gr, NULL, &err);
  }
  double t3 = cpu_now();
  int rebuilt = -1;
  CHECK_OK(mgs_morse_index_update(&ix, g, &rebuilt, &err), &err);
  double t4 = cpu_now();
  CHECK(rebuilt == 0);
  /* closest points of voxels near the surface {A = 0.3} (found by marching along x) */
  int found = 0, tried = 0;
  double tcp = 0;
  for (int t = 0; t < 400 && found < 200; t++) {
    double x[3] = {-9.5, 10 * (2 * mgs_rng_uniform(&r) - 1), 10 * (2 * mgs_rng_uniform(&r) - 1)}, A = 0, prev = 0;
    for (; x[0] < 9.5; x[0] += 0.02) {
      mgs_morse_alpha_at(g, ix, NULL, x, &A, NULL, &err);
      if (prev < 0.3 && A >= 0.3) break;
      prev = A;
    }
    if (x[0] >= 9.5) continue;
    x[0] -= 0.05; /* a voxel outside, near the surface */
    double c[3], d;
    tried++;
    double c0 = cpu_now();
    if (mgs_morse_closest_point(g, ix, NULL, x, 0.3f, c, &d, &err) == MGS_OK) found++;
    tcp += cpu_now() - c0;
  }
  fprintf(stderr, "  closest point: %d of %d voxels, %.1f us each (CPU)\n", found, tried, 1e6 * tcp / (tried ? tried : 1));
  fprintf(stderr, "  cost (CPU), 50k Gaussians: index build %.1f ms, update check %.1f ms, %.2f us per indexed call (%.1f contributors), brute force %.2f ms per call\n",
          1e3 * (t1 - t0), 1e3 * (t4 - t3), 1e6 * (t2 - t1) / calls, (double)contrib / calls, 1e3 * (t3 - t2) / 20);
  CHECK(t2 - t1 < t3 - t2 + 1.0); /* sanity only; timings are reported, not asserted */
  mgs_gaussians_destroy(gr);
  mgs_morse_index_destroy(ix);
  mgs_gaussians_destroy(g);
}

/* ---------------------------------------------------------------- one pass vs two */
/* The topological loss' one-pass form (unit derivative, scaled once the weight is known)
 * against mgs_morse_sdf_point_grad(weight): the same A, and every gradient entry within
 * float rounding (1e-6 of the largest entry), at tiny and huge scales, a 1e5 offset, the
 * floored flat point and a point no Gaussian reaches. It fails if the scale, the sign,
 * the floor or a row's reset is wrong. */
static void one_vs_two(const mgs_gaussians *g, const double c[3], float tau, double w, int expect_floor) {
  mgs_error err;
  mgs_gaussians *two = mgs_gaussians_clone(g), *one = mgs_gaussians_clone(g);
  for (int gr = 0; gr < MGS_PARAM_SH_DC; gr++) {
    memset(mgs_gaussians_group(two, (mgs_param_group)gr), 0, g->n * (size_t)mgs_param_dim((mgs_param_group)gr) * sizeof(float));
    /* garbage in the unit model: every row must be overwritten */
    float *u = mgs_gaussians_group(one, (mgs_param_group)gr);
    for (size_t k = 0; k < g->n * (size_t)mgs_param_dim((mgs_param_group)gr); k++) u[k] = 123.0f;
  }
  double A2 = -1, den = -1;
  CHECK_OK(mgs_morse_sdf_point_grad(g, c, tau, w, two, &A2, &err), &err);
  mgs_morse_point pt;
  CHECK_OK(mgs_morse_sdf_point_unit_grad(g, c, tau, one, &pt, &den, &err), &err);
  CHECK(pt.alpha == A2);
  CHECK(pt.floored == expect_floor);
  double f = pt.contributors > 0 && den > 0 ? -w / den : 0, mx = 0, worst = 0;
  for (int gr = 0; gr < MGS_PARAM_SH_DC; gr++) {
    const float *a = mgs_gaussians_group(two, (mgs_param_group)gr), *b = mgs_gaussians_group(one, (mgs_param_group)gr);
    for (size_t k = 0; k < g->n * (size_t)mgs_param_dim((mgs_param_group)gr); k++) mx = fmax(mx, fabs(a[k]));
    for (size_t k = 0; k < g->n * (size_t)mgs_param_dim((mgs_param_group)gr); k++) worst = fmax(worst, fabs(a[k] - (float)(f * b[k])));
  }
  CHECK(isfinite(worst) && worst <= 1e-6 * mx + 1e-30);
  if (pt.contributors > 0 && w != 0) CHECK(mx > 0);
  mgs_gaussians_destroy(one);
  mgs_gaussians_destroy(two);
}

static void test_unit_grad_one_pass(void) {
  const double scales[3] = {1e-4, 1.0, 1e3};
  for (int si = 0; si < 3; si++)
    for (int off = 0; off < 2; off++) {
      double o[3] = {off ? 1e5 : 0, off ? -1e5 : 0, 0.5};
      mgs_gaussians *g = cluster(40, scales[si], o, 7 + (uint64_t)si);
      double c[3] = {o[0] + 0.1 * scales[si], o[1] - 0.05 * scales[si], o[2] + 0.02 * scales[si]};
      double A;
      mgs_error err;
      CHECK_OK(mgs_morse_alpha_at(g, NULL, NULL, c, &A, NULL, &err), &err);
      one_vs_two(g, c, (float)(0.9 * A), 0.37, 0);
      one_vs_two(g, c, (float)(0.9 * A), 0.0, 0);
      mgs_gaussians_destroy(g);
    }
  /* the flat midpoint of two equal Gaussians (floored normal) and a point out of reach */
  mgs_gaussians *g = model(2);
  for (int i = 0; i < 2; i++) {
    g->mean[3 * i] = i ? 0.5f : -0.5f;
    for (int k = 0; k < 3; k++) g->log_scale[3 * i + k] = logf(0.4f);
    g->opacity[i] = 2.0f;
  }
  double mid[3] = {0, 0, 0}, far[3] = {50, 0, 0}, A;
  mgs_error err;
  CHECK_OK(mgs_morse_alpha_at(g, NULL, NULL, mid, &A, NULL, &err), &err);
  one_vs_two(g, mid, (float)A, -2.5, 1);
  one_vs_two(g, far, 0.3f, 1.0, 0);
  mgs_gaussians *small = model(1);
  mgs_morse_point pt;
  CHECK(mgs_morse_sdf_point_unit_grad(g, mid, 0.3f, small, &pt, NULL, &err) == MGS_ERR_ARG);
  CHECK(mgs_morse_sdf_point_unit_grad(g, mid, 0.0f, g, &pt, NULL, &err) == MGS_ERR_ARG);
  mgs_gaussians_destroy(small);
  mgs_gaussians_destroy(g);
}

int main(void) {
  RUN(test_field_matches_vdb);
  RUN(test_spatial_gradient_and_index);
  RUN(test_index_update);
  RUN(test_sphere);
  RUN(test_sdf_matches_vdb);
  RUN(test_grid_closest_flat);
  RUN(test_chain);
  RUN(test_flat_gradient_guard);
  RUN(test_unit_grad_one_pass);
  RUN(test_cost);
  return mgs_test_finish();
}
