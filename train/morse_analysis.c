/* The Morse analysis inside training (see train/mgs_morse.h): every K iterations after
 * the warm-up, model -> α-field -> SDF -> narrow-band persistence with critical cells,
 * and only what an enabled component reads after that (closest points for L_topo, solid
 * components and camera counts for floater pruning). Every stage is timed; its rows go
 * to RUN/morse_analysis.csv. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "train/morse_internal.h"
#include "topo/mgs_diagram_tools.h"
#include "train/mgs_morse_grad.h"
#include "topo/mgs_persistence.h"
#include "core/mgs_core.h"
#include "core/mgs_log.h"
#include "core/mgs_math.h"

void mgs_morse_options_default(mgs_morse_options *o) {
  memset(o, 0, sizeof *o);
  o->every = 500;
  o->warmup = 3000;
  o->until = 15000;
  o->resolution = 256;
  o->tau = 0.5;
  o->eps_p = 0.01;
  o->eps_sig = 0.02;
  o->min_alpha = 1.0 / 255.0;
  o->sdf_method = MGS_VDB_SDF_CLOSEST;
  o->spawn = MGS_MORSE_SPAWN_NONE;
  o->prune = MGS_MORSE_PRUNE_NONE;
  o->max_spawn = 1000;
  o->gap_max = 0.05;
  o->floater_volume = 0.01;
  o->floater_mass = 0.01;
  o->min_cameras = 3;
  o->topo = MGS_MORSE_TOPO_NONE;
  o->beta = 0.003;
  o->dims = 0x7;
  o->min_bar = 0.5;
}

mgs_status mgs_morse_grid_budget_check(const mgs_morse_options *o, mgs_error *err) {
  int hw = mgs_topo_band_for_threshold(mgs_morse_eps_in_use(o, 1.0), o->spawn == MGS_MORSE_SPAWN_GAPS ? o->gap_max : 0,
                                       1.0 / o->resolution);
  double bytes = 4.0 * 6.0 * (double)o->resolution * o->resolution * (2.0 * hw + 1) * 40.0;
  long pages = sysconf(_SC_PHYS_PAGES), psize = sysconf(_SC_PAGE_SIZE);
  double phys = pages > 0 && psize > 0 ? (double)pages * (double)psize : 8e9;
  if (bytes > 0.6 * phys)
    return mgs_error_set(err, MGS_ERR_ARG,
                         "--morse-resolution %d needs about %.1f GB for the analysis grids (band %d voxels), more than "
                         "60%% of this machine's %.1f GB; lower it",
                         o->resolution, bytes / 1e9, hw, phys / 1e9);
  return MGS_OK;
}

mgs_status mgs_morse_options_check(const mgs_morse_options *o, int iterations, mgs_error *err) {
#define RANGE(cond, ...) if (!(cond)) return mgs_error_set(err, MGS_ERR_ARG, __VA_ARGS__)
  RANGE(o->every >= 1 && o->every <= 1000000, "--morse-every must be in 1..1000000 (got %d)", o->every);
  RANGE(o->warmup >= 1, "--morse-warmup must be >= 1 (got %d)", o->warmup);
  RANGE(iterations <= 0 || o->warmup < iterations, "--morse-warmup (%d) must be below --iters (%d): no analysis would run", o->warmup, iterations);
  RANGE(o->until >= o->warmup, "--morse-until must be >= --morse-warmup (%d; got %d)", o->warmup, o->until);
  RANGE(o->resolution >= 16 && o->resolution <= 2048, "--morse-resolution must be in 16..2048 (got %d)", o->resolution);
  RANGE(o->tau > 0 && o->tau < 1, "--morse-tau must be in (0, 1) (got %g)", o->tau);
  RANGE(o->eps_p > 0 && o->eps_p <= 0.5, "--eps-p must be in (0, 0.5] of the diagonal (got %g)", o->eps_p);
  RANGE(o->eps_sig > 0 && o->eps_sig <= 0.5, "--eps-sig must be in (0, 0.5] of the diagonal (got %g)", o->eps_sig);
  RANGE(o->gap_max > 0 && o->gap_max <= 0.5, "--gap-max must be in (0, 0.5] of the diagonal (got %g)", o->gap_max);
  RANGE(o->beta >= 0 && o->beta <= 100, "--beta must be in [0, 100] (got %g)", o->beta);
  RANGE(o->min_bar >= 0 && o->min_bar <= 16, "--min-bar must be in [0, 16] voxels (got %g)", o->min_bar);
  RANGE(o->dims >= 1 && o->dims <= 7, "--topo-dims must name dimensions among 0,1,2");
  RANGE(o->max_spawn >= 0, "--max-spawn must be >= 0 (got %d)", o->max_spawn);
  RANGE(o->min_cameras >= 0, "--min-cameras must be >= 0 (got %d)", o->min_cameras);
  RANGE(o->floater_volume >= 0 && o->floater_volume < 1, "--floater-volume must be in [0, 1) (got %g)", o->floater_volume);
  RANGE(o->floater_mass >= 0 && o->floater_mass < 1, "--floater-mass must be in [0, 1) (got %g)", o->floater_mass);
  /* the grid: half-width for the largest threshold, as the analysis will use it */
  double hw = mgs_topo_band_for_threshold(morse_eps_in_use(o, 1.0), o->spawn == MGS_MORSE_SPAWN_GAPS ? o->gap_max : 0,
                                          1.0 / o->resolution);
  RANGE(hw >= 1 && hw <= 64, "--morse-resolution %d with thresholds up to %g of the diagonal needs a band of %g voxels (at most 64): lower the resolution or the thresholds",
        o->resolution, morse_eps_in_use(o, 1.0), hw);
#undef RANGE
  return MGS_OK;
}

double morse_eps_in_use(const mgs_morse_options *o, double diagonal) {
  double e = 0;
  if (o->spawn != MGS_MORSE_SPAWN_NONE || o->prune == MGS_MORSE_PRUNE_LITERAL) e = fmax(e, o->eps_p);
  if (o->topo != MGS_MORSE_TOPO_NONE) e = fmax(e, o->eps_sig);
  if (e == 0) e = o->eps_p;
  return e * diagonal;
}

mgs_status mgs_morse_ctx_create(const mgs_morse_options *o, const mgs_dataset *ds, mgs_morse_ctx **out,
                                mgs_error *err) {
  *out = NULL;
  mgs_morse_ctx *c = calloc(1, sizeof *c);
  if (!c) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  c->refs = 1;
  if (o) c->o = *o; else mgs_morse_options_default(&c->o);
  c->ds = ds;
  *out = c;
  return MGS_OK;
}

mgs_morse_ctx *mgs_morse_ctx_ref(mgs_morse_ctx *c) { if (c) c->refs++; return c; }

static void drop_transient(mgs_morse_ctx *c) {
  mgs_vdb_grid_destroy(c->alpha); c->alpha = NULL;
  mgs_vdb_grid_destroy(c->sdf); c->sdf = NULL;
  mgs_gaussians_destroy(c->sub); c->sub = NULL;
  free(c->sub_map); c->sub_map = NULL;
  mgs_topo_components_destroy(c->comp); c->comp = NULL;
  free(c->cam_count); c->cam_count = NULL; c->cam_n = 0;
}

void mgs_morse_ctx_unref(mgs_morse_ctx *c) {
  if (!c || --c->refs > 0) return;
  drop_transient(c);
  mgs_vdb_alpha_cache_destroy(c->acache);
  mgs_vdb_sdf_cache_destroy(c->scache);
  mgs_topo_cache_destroy(c->tcache);
  free(c->r.pairs);
  free(c->rows);
  free(c->csv_path);
  free(c);
}

const mgs_morse_options *mgs_morse_ctx_options(const mgs_morse_ctx *c) { return &c->o; }
const mgs_morse_result *mgs_morse_ctx_result(const mgs_morse_ctx *c) { return &c->r; }
const mgs_vdb_grid *mgs_morse_ctx_sdf(const mgs_morse_ctx *c) { return c->sdf; }
const mgs_vdb_grid *mgs_morse_ctx_alpha(const mgs_morse_ctx *c) { return c->alpha; }
const int *mgs_morse_ctx_camera_counts(const mgs_morse_ctx *c, size_t *n) { if (n) *n = c->cam_n; return c->cam_count; }
double mgs_morse_ctx_seconds(const mgs_morse_ctx *c) { return c->seconds_total; }
size_t mgs_morse_ctx_analyses(const mgs_morse_ctx *c) { return c->analyses; }

int mgs_morse_is_analysis_iteration(const mgs_morse_ctx *c, int it) {
  const mgs_morse_options *o = &c->o;
  return it >= o->warmup && it <= o->until && (it - o->warmup) % o->every == 0;
}

mgs_status mgs_morse_ctx_update(mgs_morse_ctx *c, const mgs_gaussians *g, int it, int *ran, mgs_error *err) {
  if (ran) *ran = 0;
  if (!mgs_morse_is_analysis_iteration(c, it) || c->r.iteration == it) return MGS_OK;
  if (ran) *ran = 1;
  mgs_error e2;
  mgs_error_clear(&e2);
  mgs_status st = mgs_morse_analyze(c, g, it, &e2);
  if (st == MGS_OK) return MGS_OK;
  /* one failed analysis (a grid over budget, a broken band) must not end a long run:
     nothing acts on it (no pairs) until the next one */
  mgs_warn("Morse analysis at iteration %d skipped: %s", it, e2.msg);
  drop_transient(c);
  free(c->r.pairs);
  memset(&c->r, 0, sizeof c->r);
  c->r.iteration = it;
  (void)err;
  return MGS_OK;
}

/* ---- closest points ------------------------------------------------------------- */

/* Newton on A - τ from p0; c must end within max_travel of x. */
static int closest_newton(const mgs_vdb_grid *alpha, double tau, const double x[3], const double p0[3],
                          double max_travel, double c[3], double *grad_norm) {
  double h = mgs_vdb_grid_voxel_size(alpha), p[3] = {p0[0], p0[1], p0[2]};
  for (int it = 0; it < 30; it++) {
    float xf[3] = {(float)p[0], (float)p[1], (float)p[2]}, gr[3], v;
    mgs_vdb_sample_gradient(alpha, 1, xf, gr, &v);
    double g2 = (double)gr[0] * gr[0] + (double)gr[1] * gr[1] + (double)gr[2] * gr[2];
    double f = v - tau;
    if (fabs(f) < 1e-4 * tau && g2 > 0) {
      double dx = p[0] - x[0], dy = p[1] - x[1], dz = p[2] - x[2];
      if (sqrt(dx * dx + dy * dy + dz * dz) > max_travel) return 0;
      memcpy(c, p, sizeof p);
      *grad_norm = sqrt(g2);
      return 1;
    }
    if (!(g2 > 1e-20)) return 0;
    double s = -f / g2, len = fabs(s) * sqrt(g2);
    if (len > h) s *= h / len; /* at most a voxel per step: the interpolant is only local */
    for (int k = 0; k < 3; k++) p[k] += s * gr[k];
  }
  return 0;
}

/* Critical cells of d far from the surface sit where ∇A vanishes (the middle of a gap
   between two pieces, the core of a thick part), so Newton from x stalls there. Then the
   nearest sample on the other side of τ within max_travel (voxel steps) is found, the
   crossing located by bisection on the segment to it, and Newton finishes from there. */
static int closest_by_search(const mgs_vdb_grid *alpha, double tau, const double x[3], double max_travel,
                             double c[3], double *grad_norm) {
  double h = mgs_vdb_grid_voxel_size(alpha);
  int r = (int)ceil(max_travel / h);
  if (r < 1) r = 1;
  if (r > 16) r = 16;
  float xf[3] = {(float)x[0], (float)x[1], (float)x[2]}, a0;
  mgs_vdb_sample(alpha, 1, xf, &a0);
  int inside = a0 >= tau;
  double best = INFINITY, q[3] = {0, 0, 0};
  for (int i = -r; i <= r; i++)
    for (int j = -r; j <= r; j++)
      for (int k = -r; k <= r; k++) {
        double dd = h * sqrt((double)(i * i + j * j + k * k));
        if (dd >= best || dd > max_travel || (i | j | k) == 0) continue;
        float y[3] = {(float)(x[0] + i * h), (float)(x[1] + j * h), (float)(x[2] + k * h)}, a;
        mgs_vdb_sample(alpha, 1, y, &a);
        if ((a >= tau) != inside) { best = dd; q[0] = y[0]; q[1] = y[1]; q[2] = y[2]; }
      }
  if (!isfinite(best)) return 0;
  double lo[3] = {x[0], x[1], x[2]}, hi[3] = {q[0], q[1], q[2]}, m[3];
  for (int it = 0; it < 20; it++) {
    for (int k = 0; k < 3; k++) m[k] = 0.5 * (lo[k] + hi[k]);
    float mf[3] = {(float)m[0], (float)m[1], (float)m[2]}, a;
    mgs_vdb_sample(alpha, 1, mf, &a);
    if ((a >= tau) == inside) memcpy(lo, m, sizeof m);
    else memcpy(hi, m, sizeof m);
  }
  return closest_newton(alpha, tau, x, hi, max_travel, c, grad_norm);
}

int mgs_morse_grid_closest_point(const mgs_vdb_grid *alpha, double tau, const double x[3], double max_travel,
                            double c[3], double *grad_norm) {
  return closest_newton(alpha, tau, x, x, max_travel, c, grad_norm) ||
         closest_by_search(alpha, tau, x, max_travel, c, grad_norm);
}

/* ---- camera counts ---------------------------------------------------------------- */

typedef struct { const mgs_gaussians *g; const mgs_dataset *ds; int *count; } cam_ctx;
static void cam_range(void *vp, size_t b, size_t e) {
  cam_ctx *cc = vp;
  size_t nv = cc->ds->n_views[MGS_SPLIT_TRAIN];
  for (size_t i = b; i < e; i++) {
    double p[3] = {cc->g->mean[3 * i], cc->g->mean[3 * i + 1], cc->g->mean[3 * i + 2]};
    int n = 0;
    for (size_t v = 0; v < nv; v++) {
      const mgs_camera *cam = &cc->ds->views[MGS_SPLIT_TRAIN][v].cam;
      double u, w, z;
      if (mgs_camera_project(cam, p, &u, &w, &z) && u >= 0 && w >= 0 && u < cam->width && w < cam->height) n++;
    }
    cc->count[i] = n;
  }
}

/* ---- the analysis ----------------------------------------------------------------- */

static mgs_status push_row(mgs_morse_ctx *c, mgs_error *err) {
  /* the rows before this one are complete (spawn counts and the loss come in their own
     iteration): written now, so a long run's file grows as it goes */
  if (c->csv_path) {
    mgs_status st = mgs_morse_ctx_flush_csv(c, err);
    if (st) return st;
  }
  const mgs_morse_result *res = &c->r;
  mgs_info("morse analysis @%d: %zu Gaussians, voxel %.4g, band %.4g; betti(0) %d %d %d, above eps %d %d %d; %zu pairs; "
           "%.2f s (alpha %.2f, sdf %.2f, persistence %.2f, closest %.2f, components %.2f)",
           res->iteration, res->gaussians_used, res->voxel_size, res->half_width, res->betti0[0], res->betti0[1], res->betti0[2],
           res->betti_eps[0], res->betti_eps[1], res->betti_eps[2], res->n, res->seconds[5], res->seconds[0], res->seconds[1],
           res->seconds[2], res->seconds[3], res->seconds[4]);
  morse_row *r = realloc(c->rows, (c->n_rows + 1) * sizeof *r);
  if (!r) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  c->rows = r;
  morse_row *w = &r[c->n_rows++];
  memset(w, 0, sizeof *w);
  w->iteration = c->r.iteration;
  memcpy(w->seconds, c->r.seconds, sizeof w->seconds);
  memcpy(w->betti0, c->r.betti0, sizeof w->betti0);
  memcpy(w->betti_eps, c->r.betti_eps, sizeof w->betti_eps);
  w->pairs = c->r.n;
  w->topo = NAN;
  w->leaves = c->r.leaves;
  w->leaves_reused = c->r.leaves_reused;
  return MGS_OK;
}

void mgs_morse_ctx_note_spawn(mgs_morse_ctx *c, size_t spawned, size_t pruned) {
  if (c->n_rows && c->rows[c->n_rows - 1].iteration == c->r.iteration) {
    c->rows[c->n_rows - 1].spawned += spawned;
    c->rows[c->n_rows - 1].pruned += pruned;
  }
}
void mgs_morse_ctx_note_topo(mgs_morse_ctx *c, double v) {
  if (c->n_rows && c->rows[c->n_rows - 1].iteration == c->r.iteration && isnan(c->rows[c->n_rows - 1].topo))
    c->rows[c->n_rows - 1].topo = v;
}

mgs_status mgs_morse_analyze(mgs_morse_ctx *c, const mgs_gaussians *g, int it, mgs_error *err) {
  const mgs_morse_options *o = &c->o;
  double t0 = mgs_now(), ts[6] = {0};
  drop_transient(c);
  free(c->r.pairs);
  memset(&c->r, 0, sizeof c->r);
  c->r.iteration = it;
  mgs_status st = MGS_OK;
  /* Gaussians the rasterizer never draws do not make the surface either */
  size_t *map = malloc((g->n ? g->n : 1) * sizeof(size_t)), m = 0;
  if (!map) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  for (size_t i = 0; i < g->n; i++)
    if (mgs_sigmoidf(g->opacity[i]) >= o->min_alpha) map[m++] = i;
  c->sub_map = map;
  c->r.gaussians_used = m;
  if (m == 0) { /* nothing opaque enough: an empty analysis, nothing to act on */
    c->analyses++;
    return push_row(c, err);
  }
  c->sub = mgs_gaussians_select(g, map, m);
  if (!c->sub) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  /* the grid's scale from a box far outliers do not stretch (real SfM: a few two-view
     points 10x away made the voxel 9x too coarse, the hinge a blob); what lies outside
     is left out of the analysis (ADC still sees it) */
  double lo[3], hi[3];
  mgs_points_bounds_robust(c->sub->mean, c->sub->n, lo, hi);
  size_t kept = 0;
  for (size_t j = 0; j < m; j++)
    if (mgs_point_in_box(c->sub->mean + 3 * j, lo, hi)) map[kept++] = map[j];
  if (kept < m) {
    mgs_gaussians_destroy(c->sub);
    m = kept;
    c->r.gaussians_used = m;
    c->sub = mgs_gaussians_select(g, map, m);
    if (!c->sub) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  }
  double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  if (!(diag > 0)) diag = 1e-3;
  double h = diag / o->resolution;
  if (o->incremental) {
    /* the same lattice as the last analysis while the box has not changed much, so the
       α leaves of regions whose Gaussians did not change can be reused */
    if (c->h_fixed > 0 && fabs(diag - c->diag_fixed) <= 0.1 * c->diag_fixed) h = c->h_fixed;
    else { c->h_fixed = h; c->diag_fixed = diag; }
  }
  int hw = mgs_topo_band_for_threshold(morse_eps_in_use(o, diag), o->spawn == MGS_MORSE_SPAWN_GAPS ? o->gap_max * diag : 0, h);
  if (hw < 1) hw = 1;
  c->r.diagonal = diag; c->r.voxel_size = h; c->r.half_width = hw * h;

  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = h;
  ap.half_width = hw;
  if (o->memory_budget > 0) ap.memory_budget = o->memory_budget;
  mgs_vdb_build_info bi;
  if (o->incremental) {
    if (!c->acache && !(c->acache = mgs_vdb_alpha_cache_create())) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
    st = mgs_vdb_alpha_field_cached(c->sub, &ap, c->acache, &c->alpha, &bi, err);
  } else {
    st = mgs_vdb_alpha_field(c->sub, &ap, &c->alpha, &bi, err);
  }
  if (st) return st;
  c->r.leaves = bi.leaves;
  c->r.leaves_reused = o->incremental ? bi.leaves_reused : 0;
  ts[0] = mgs_now() - t0;
  double t1 = mgs_now();
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.tau = o->tau; sp.half_width = hw; sp.method = o->sdf_method;
  if (o->incremental) {
    /* the band is computed again only around the α leaves that changed (bit-identical) */
    mgs_vdb_sdf_update_info si;
    if (!c->scache && !(c->scache = mgs_vdb_sdf_cache_create())) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
    if ((st = mgs_vdb_sdf_from_alpha_cached(c->alpha, &sp, c->scache, &c->sdf, &si, err))) return st;
    c->r.sdf_leaves = si.leaves_total;
    c->r.sdf_leaves_reused = si.whole ? 0 : si.leaves_total - si.leaves_recomputed;
  } else if ((st = mgs_vdb_sdf_from_alpha(c->alpha, &sp, &c->sdf, err))) {
    return st;
  }
  c->r.active_voxels = mgs_vdb_grid_active_voxel_count(c->sdf);
  ts[1] = mgs_now() - t1;

  /* persistence: read by spawning, literal pruning and L_topo */
  int need_pers = o->spawn != MGS_MORSE_SPAWN_NONE || o->prune == MGS_MORSE_PRUNE_LITERAL || o->topo != MGS_MORSE_TOPO_NONE;
  if (need_pers) {
    double t2 = mgs_now();
    mgs_topo_opts to;
    mgs_topo_opts_default(&to);
    to.half_width = hw * h;
    if (o->incremental) { /* the leaves whose band did not change keep their critical cells */
      if (!c->tcache && !(c->tcache = mgs_topo_cache_create())) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
      to.cache = c->tcache;
    }
    mgs_diagram *d = NULL;
    mgs_topo_stats tst;
    if ((st = mgs_topo_persistence_vdb_stats(c->sdf, &to, &d, &tst, err))) return st;
    c->r.pers_leaves = tst.leaves;
    c->r.pers_leaves_reused = tst.leaves_reused;
    c->r.pairs = calloc(d->n ? d->n : 1, sizeof(mgs_morse_pair));
    if (!c->r.pairs) { mgs_diagram_destroy(d); return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory"); }
    c->r.n = d->n;
    double eps = morse_eps_in_use(o, diag);
    for (size_t k = 0; k < d->n; k++) c->r.pairs[k].p = d->pairs[k];
    mgs_diagram_betti(d, 0.0, c->r.betti0);
    mgs_diagram_betti_persistent(d, 0.0, eps, c->r.betti_eps);
    mgs_diagram_destroy(d);
    ts[2] = mgs_now() - t2;
  }

  /* closest points of the bar ends L_topo will move */
  if (o->topo != MGS_MORSE_TOPO_NONE && c->r.n) {
    double t3 = mgs_now(), w = hw * h, eps_sig = o->eps_sig * diag;
    size_t np = 0;
    double *pts = malloc(2 * c->r.n * 3 * sizeof(double));
    size_t *who = malloc(2 * c->r.n * sizeof(size_t));
    if (!pts || !who) { free(pts); free(who); return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory"); }
    for (size_t k = 0; k < c->r.n; k++) {
      mgs_morse_pair *mp = &c->r.pairs[k];
      const mgs_pair *p = &mp->p;
      if (!morse_in_loss(o, p, eps_sig, h)) continue;
      for (int end = 0; end < 2; end++) {
        double v = end ? p->death : p->birth;
        if (fabs(v) >= w * (1 - 1e-6)) continue; /* set by the clamp: no gradient */
        const int32_t *vx = end ? p->d.voxel : p->b.voxel;
        double ijk[3] = {vx[0], vx[1], vx[2]}, x[3], cpt[3], gn;
        mgs_vdb_index_to_world(c->sdf, ijk, x);
        if (!mgs_morse_grid_closest_point(c->alpha, o->tau, x, fabs(v) + 2 * h, cpt, &gn)) continue;
        if (end) { memcpy(mp->cd, cpt, sizeof cpt); mp->gd = gn; mp->has_cd = 1; }
        else { memcpy(mp->cb, cpt, sizeof cpt); mp->gb = gn; mp->has_cb = 1; }
        memcpy(pts + 3 * np, cpt, sizeof cpt);
        who[np++] = 2 * k + (size_t)end;
      }
    }
    /* A at the closest points on the exact Gaussian sum (what the term re-evaluates) */
    morse_gather gt;
    st = morse_gather_build(g, pts, np, 3.0, &gt, err);
    mgs_gaussians *loc = st == MGS_OK ? mgs_gaussians_create(16, g->sh_degree) : NULL;
    if (st == MGS_OK && !loc) st = mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
    for (size_t q = 0; q < np && st == MGS_OK; q++) {
      double a = 0;
      st = morse_gather_rows(g, gt.idx + gt.start[q], gt.start[q + 1] - gt.start[q], loc, err);
      if (st == MGS_OK) st = mgs_morse_sdf_point_grad(loc, pts + 3 * q, (float)o->tau, 0, NULL, &a, err);
      /* |∇A(c)| of the same exact sum (central differences at a hundredth of a voxel), so
         the term's re-evaluated value and its gradient use one normal length */
      double gn2 = 0;
      for (int k = 0; k < 3 && st == MGS_OK; k++) {
        double xp[3], xm[3], a_p = 0, a_m = 0;
        memcpy(xp, pts + 3 * q, sizeof xp); memcpy(xm, pts + 3 * q, sizeof xm);
        xp[k] += 0.01 * h; xm[k] -= 0.01 * h;
        st = mgs_morse_sdf_point_grad(loc, xp, (float)o->tau, 0, NULL, &a_p, err);
        if (st == MGS_OK) st = mgs_morse_sdf_point_grad(loc, xm, (float)o->tau, 0, NULL, &a_m, err);
        gn2 += (a_p - a_m) * (a_p - a_m) / (0.02 * h * 0.02 * h);
      }
      mgs_morse_pair *mp = &c->r.pairs[who[q] / 2];
      int *has = (who[q] & 1) ? &mp->has_cd : &mp->has_cb;
      if (!(gn2 > 1e-12)) *has = 0; /* flat exact field there: no normal, no gradient */
      if (who[q] & 1) { mp->ad = a; if (*has) mp->gd = sqrt(gn2); }
      else { mp->ab = a; if (*has) mp->gb = sqrt(gn2); }
    }
    mgs_gaussians_destroy(loc);
    if (np) morse_gather_free(&gt); else free(gt.start);
    free(pts); free(who);
    if (st) return st;
    ts[3] = mgs_now() - t3;
  }

  /* floaters: components of the solid and camera counts */
  if (o->prune == MGS_MORSE_PRUNE_FLOATERS) {
    double t4 = mgs_now();
    mgs_vdb_grid *dens = NULL;
    if ((st = mgs_vdb_density_from_alpha(c->alpha, &dens, err))) return st;
    st = mgs_topo_components_vdb(c->sdf, dens, 0.0, 6, (size_t)1 << 28, &c->comp, err);
    mgs_vdb_grid_destroy(dens);
    if (st) return st;
    if (o->min_cameras > 0 && c->ds && c->ds->n_views[MGS_SPLIT_TRAIN]) {
      c->cam_count = malloc((g->n ? g->n : 1) * sizeof(int));
      if (!c->cam_count) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
      c->cam_n = g->n;
      cam_ctx cc = {g, c->ds, c->cam_count};
      mgs_parallel_for(0, g->n, 1024, cam_range, &cc);
    }
    ts[4] = mgs_now() - t4;
  }
  ts[5] = mgs_now() - t0;
  memcpy(c->r.seconds, ts, sizeof ts);
  c->seconds_total += ts[5];
  c->analyses++;
  return push_row(c, err);
}

/* ---- CSV ---------------------------------------------------------------------------- */

void mgs_morse_ctx_set_csv(mgs_morse_ctx *c, const char *path) {
  free(c->csv_path);
  c->csv_path = path ? mgs_strdup(path) : NULL;
}

mgs_status mgs_morse_ctx_flush_csv(mgs_morse_ctx *c, mgs_error *err) {
  if (!c->csv_path || c->rows_flushed >= c->n_rows) return MGS_OK;
  int fresh = !mgs_path_exists(c->csv_path);
  FILE *f = fopen(c->csv_path, "a");
  if (!f) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open for appending", c->csv_path);
  if (fresh)
    fprintf(f, "iteration,s_alpha,s_sdf,s_persistence,s_closest,s_components,s_total,"
               "betti0_0,betti0_1,betti0_2,betti_eps_0,betti_eps_1,betti_eps_2,pairs,spawned,pruned,topo_loss,leaves,leaves_reused\n");
  for (size_t k = c->rows_flushed; k < c->n_rows; k++) {
    const morse_row *r = &c->rows[k];
    fprintf(f, "%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%d,%d,%d,%d,%d,%d,%zu,%zu,%zu,%.6g,%zu,%zu\n", r->iteration, r->seconds[0],
            r->seconds[1], r->seconds[2], r->seconds[3], r->seconds[4], r->seconds[5], r->betti0[0], r->betti0[1],
            r->betti0[2], r->betti_eps[0], r->betti_eps[1], r->betti_eps[2], r->pairs, r->spawned, r->pruned,
            isnan(r->topo) ? 0.0 : r->topo, r->leaves, r->leaves_reused);
  }
  int ok = fclose(f) == 0;
  c->rows_flushed = c->n_rows;
  return ok ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "%s: write failed", c->csv_path);
}

/* ---- checkpoint --------------------------------------------------------------------- */

#define CTX_MAGIC 0x3252534fu    /* "OSR2": v2 adds the incremental lattice */
#define CTX_MAGIC_V1 0x4d4f5253u /* "MORS" */

/* The last SDF grid goes into checkpoints too: terms that read it between analyses (the
 * normal loss's ∇d) must see the same grid after --resume (u64 size + bytes; 0 = no grid). */
static mgs_status save_sdf(const mgs_morse_ctx *c, FILE *f, mgs_error *err) {
  uint64_t size = 0;
  if (!c->sdf) return fwrite(&size, 8, 1, f) == 1 ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "morse: cannot write the checkpoint");
  char *bytes = NULL;
  size_t len = 0;
  mgs_status st = mgs_vdb_grid_to_bytes(c->sdf, &bytes, &len, err);
  if (st) return st;
  size = len;
  int ok = fwrite(&size, 8, 1, f) == 1 && fwrite(bytes, 1, len, f) == len;
  free(bytes);
  return ok ? MGS_OK : mgs_error_set(err, MGS_ERR_IO, "morse: cannot write the SDF grid to the checkpoint");
}

static mgs_status load_sdf(mgs_morse_ctx *c, FILE *f, mgs_error *err) {
  uint64_t size = 0;
  if (fread(&size, 8, 1, f) != 1 || size > ((uint64_t)1 << 40))
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the Morse analysis state (SDF grid)");
  if (size == 0) return MGS_OK;
  char *bytes = malloc(size);
  if (!bytes) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (SDF grid)");
  mgs_status st = fread(bytes, 1, size, f) == size ? mgs_vdb_grid_from_bytes(bytes, size, "sdf", &c->sdf, err)
                                                   : mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the Morse SDF grid");
  free(bytes);
  return st;
}
mgs_status mgs_morse_ctx_save(const mgs_morse_ctx *c, FILE *f, mgs_error *err) {
  uint32_t magic = CTX_MAGIC;
  uint64_t n = c->r.n, analyses = c->analyses;
  int ok = fwrite(&magic, 4, 1, f) == 1 && fwrite(&analyses, 8, 1, f) == 1 &&
           fwrite(&c->seconds_total, sizeof(double), 1, f) == 1 && fwrite(&c->h_fixed, sizeof(double), 1, f) == 1 &&
           fwrite(&c->diag_fixed, sizeof(double), 1, f) == 1;
  mgs_morse_result r = c->r;
  r.pairs = NULL;
  ok = ok && fwrite(&r, sizeof r, 1, f) == 1 && fwrite(&n, 8, 1, f) == 1;
  if (n) ok = ok && fwrite(c->r.pairs, sizeof(mgs_morse_pair), n, f) == n;
  if (!ok) return mgs_error_set(err, MGS_ERR_IO, "morse: cannot write the analysis state to the checkpoint");
  return save_sdf(c, f, err);
}

mgs_status mgs_morse_ctx_load(mgs_morse_ctx *c, FILE *f, mgs_error *err) {
  uint32_t magic = 0;
  uint64_t n = 0, analyses = 0;
  mgs_morse_result r;
  double secs = 0, hf = 0, df = 0;
  if (fread(&magic, 4, 1, f) == 1 && magic == CTX_MAGIC_V1)
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the Morse analysis state was written by an older morsegs (v1); "
                         "resume with that version or train again");
  if (magic != CTX_MAGIC || fread(&analyses, 8, 1, f) != 1 || fread(&secs, sizeof(double), 1, f) != 1 ||
      fread(&hf, sizeof(double), 1, f) != 1 || fread(&df, sizeof(double), 1, f) != 1 || fread(&r, sizeof r, 1, f) != 1 ||
      fread(&n, 8, 1, f) != 1 || n > ((uint64_t)1 << 32))
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the Morse analysis state is missing or damaged");
  mgs_morse_pair *p = calloc(n ? n : 1, sizeof *p);
  if (!p) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  if (n && fread(p, sizeof *p, n, f) != n) { free(p); return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the Morse analysis state"); }
  drop_transient(c);
  free(c->r.pairs);
  c->r = r;
  c->r.pairs = p;
  c->r.n = n;
  c->analyses = analyses;
  c->seconds_total = secs;
  c->h_fixed = hf;
  c->diag_fixed = df;
  return load_sdf(c, f, err);
}
