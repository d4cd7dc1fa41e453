/* MorseGS-D (seed 000 Alg. 1; SPEC §5.2 item 4, §6) as a density-control strategy.
 *
 * Before the warm-up W and after `until`, and at every iteration that is not an analysis
 * iteration, this is the reference ADC (train/strategy_adc.c, owned). At an analysis
 * iteration the Morse rules run first on the model the analysis saw (prune, then spawn),
 * the ADC accumulators and this iteration's per-Gaussian screen statistics are carried
 * through that change, and then ADC runs as the fallback "for remaining under-reconstructed
 * regions" (Alg. 1 step 7).
 *
 * Spawn rules (--spawn):
 *   literal  Alg. 1 as printed: dimension-0 pairs with persistence > ε_p get a Gaussian at
 *            the birth cell (the "index-0 critical point") with Σ = p²·I; dimension-1 pairs
 *            with persistence > ε_p clone the Gaussian nearest to the birth cell (the
 *            index-1 cell) onto it, elongated along the ridge: the eigenvector of the SDF's
 *            Hessian there with the most negative eigenvalue (the direction in which the
 *            sublevel set joins the two components it merges).
 *   gaps     the corrected rule, from measurements on controlled fields (tests/train/
 *            test_morse_gaps.c): a hole of radius ρ in a surface shows as a dimension-1 pair
 *            born at or below 0 and dying at ≈ ρ (a through-hole: its death cell is on the
 *            hole's axis) or, in a closed shell, as a dimension-2 pair born at ≈ ρ (the
 *            cavity closes when the hole does; the birth cell is in the hole). Each such pair
 *            with ρ ≤ gap_max gets one flat Gaussian: in the plane of the surrounding
 *            Gaussians (normal = principal direction of their shortest axes), centred on the
 *            hole projected into that plane, tangent std ρ, colour and opacity of the
 *            neighbours. Pairs whose neighbours' normals do not agree (w_max < 0.7 of the
 *            normal tensor's trace) are not gaps in a surface: an open thin tube shows the
 *            same dimension-1 pair, with the wall's normals all around the axis.
 * Prune rules (--prune):
 *   literal  Gaussians whose 3σ ellipsoid holds a critical cell of a bar shorter than ε_p
 *            and none of a longer bar ("contributing only to low-persistence features");
 *            bars below min_bar voxels (the SDF's accuracy) count as neither.
 *   floaters components of {d ≤ 0} other than the largest whose volume or opacity mass is
 *            below a fraction of the largest's (their Gaussians, unless they also touch the
 *            largest), and Gaussians whose mean fewer than m training cameras see. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/morse_internal.h"
#include "train/mgs_strategy.h"
#include "core/mgs_math.h"
#include "core/mgs_log.h"

typedef struct morse_strat {
  mgs_strategy *adc;
  mgs_adc_options ao;
  mgs_morse_ctx *ctx;
  size_t total_spawned, total_pruned;
} morse_strat;

/* ---- helpers ---------------------------------------------------------------------- */

static void shortest_axis(const mgs_gaussians *g, size_t i, double n[3], double *smin) {
  double R[9], q[4] = {g->rot[4 * i], g->rot[4 * i + 1], g->rot[4 * i + 2], g->rot[4 * i + 3]};
  mgs_quat_to_mat3d(q, R);
  int k = 0;
  for (int j = 1; j < 3; j++) if (g->log_scale[3 * i + j] < g->log_scale[3 * i + k]) k = j;
  for (int r = 0; r < 3; r++) n[r] = R[3 * r + k];
  *smin = exp(g->log_scale[3 * i + k]);
}

/* Rotation whose columns are (a, b, n): local z = n. */
static void frame_quat(const double n_in[3], const double hint[3], float q[4]) {
  double n[3] = {n_in[0], n_in[1], n_in[2]}, a[3], b[3], R[9], qd[4];
  mgs_normalize3d(n);
  double h[3] = {hint[0], hint[1], hint[2]};
  double dn = mgs_dot3d(h, n);
  for (int k = 0; k < 3; k++) h[k] -= dn * n[k];
  if (mgs_normalize3d(h) < 1e-9) { double e[3] = {fabs(n[0]) < 0.9 ? 1 : 0, fabs(n[0]) < 0.9 ? 0 : 1, 0}; mgs_cross3d(n, e, h); mgs_normalize3d(h); }
  memcpy(a, h, sizeof a);
  mgs_cross3d(n, a, b);
  for (int r = 0; r < 3; r++) { R[3 * r] = a[r]; R[3 * r + 1] = b[r]; R[3 * r + 2] = n[r]; }
  mgs_mat3_to_quatd(R, qd);
  for (int k = 0; k < 4; k++) q[k] = (float)qd[k];
}

/* Hessian of the SDF at voxel v by central differences on the grid. */
static void sdf_hessian(const mgs_vdb_grid *sdf, const int32_t v[3], double H[9]) {
  double h = mgs_vdb_grid_voxel_size(sdf);
#define S(dx, dy, dz) ((double)mgs_vdb_value(sdf, (int32_t[3]){v[0] + (dx), v[1] + (dy), v[2] + (dz)}, NULL))
  double c = S(0, 0, 0);
  int e[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) {
      double val;
      if (a == b) val = S(e[a][0], e[a][1], e[a][2]) - 2 * c + S(-e[a][0], -e[a][1], -e[a][2]);
      else
        val = 0.25 * (S(e[a][0] + e[b][0], e[a][1] + e[b][1], e[a][2] + e[b][2]) - S(e[a][0] - e[b][0], e[a][1] - e[b][1], e[a][2] - e[b][2]) -
                      S(-e[a][0] + e[b][0], -e[a][1] + e[b][1], -e[a][2] + e[b][2]) + S(-e[a][0] - e[b][0], -e[a][1] - e[b][1], -e[a][2] - e[b][2]));
      H[3 * a + b] = val / (h * h);
    }
#undef S
}

/* ---- spawn -------------------------------------------------------------------------- */

typedef struct spawn_rec {
  double pers;               /* for the cap: larger first */
  float mean[3], log_scale[3], rot[4], opacity, sh_dc[3];
} spawn_rec;

static int cmp_spawn(const void *a, const void *b) {
  double x = ((const spawn_rec *)a)->pers, y = ((const spawn_rec *)b)->pers;
  return x > y ? -1 : (x < y);
}

/* The literal rule's records. */
static size_t spawn_literal(mgs_morse_ctx *c, const mgs_gaussians *g, spawn_rec *out, size_t cap) {
  const mgs_morse_result *r = &c->r;
  double eps = c->o.eps_p * r->diagonal;
  size_t n = 0;
  for (size_t k = 0; k < r->n && n < cap; k++) {
    const mgs_pair *p = &r->pairs[k].p;
    double pers = p->death - p->birth;
    if (!isfinite(pers) || !(pers > eps) || p->dim > 1) continue;
    size_t j = morse_nearest_gaussian(g, p->b.pos);
    if (j == (size_t)-1) continue;
    spawn_rec *s = &out[n];
    memset(s, 0, sizeof *s);
    s->pers = pers;
    for (int q = 0; q < 3; q++) { s->mean[q] = (float)p->b.pos[q]; s->sh_dc[q] = g->sh_dc[3 * j + q]; }
    if (p->dim == 0) { /* Σ = p² I at the minimum */
      for (int q = 0; q < 3; q++) s->log_scale[q] = (float)log(pers);
      s->rot[0] = 1;
      s->opacity = mgs_logitf(0.1f);
    } else { /* clone the nearest Gaussian onto the saddle, elongated along the ridge */
      double H[9], w[3], V[9], dir[3], d[3];
      if (c->sdf) {
        sdf_hessian(c->sdf, p->b.voxel, H);
        mgs_sym3_eigen(H, w, V);
        for (int q = 0; q < 3; q++) dir[q] = V[3 * q]; /* most negative eigenvalue: column 0 */
      }
      for (int q = 0; q < 3; q++) d[q] = p->b.pos[q] - g->mean[3 * j + q];
      if (!c->sdf) memcpy(dir, d, sizeof d);
      double smax = exp(fmax(g->log_scale[3 * j], fmax(g->log_scale[3 * j + 1], g->log_scale[3 * j + 2])));
      double smin = exp(fmin(g->log_scale[3 * j], fmin(g->log_scale[3 * j + 1], g->log_scale[3 * j + 2])));
      double along = fmax(smax, 0.5 * mgs_norm3d(d));
      /* local z along the ridge: scales (smin, smin, along) */
      double hint[3] = {0, 0, 1};
      frame_quat(dir, hint, s->rot);
      s->log_scale[0] = s->log_scale[1] = (float)log(smin);
      s->log_scale[2] = (float)log(along);
      s->opacity = g->opacity[j];
    }
    n++;
  }
  return n;
}

/* The corrected rule's records: surface gaps. */
static size_t spawn_gaps(mgs_morse_ctx *c, const mgs_gaussians *g, spawn_rec *out, size_t cap) {
  const mgs_morse_result *r = &c->r;
  double gap = c->o.gap_max * r->diagonal, h = r->voxel_size;
  size_t n = 0;
  for (size_t k = 0; k < r->n && n < cap; k++) {
    const mgs_pair *p = &r->pairs[k].p;
    double rho;
    const double *at;
    if (p->dim == 1 && isfinite(p->death) && p->birth <= 0 && p->death > 0 && p->death <= gap && !p->truncated) {
      rho = p->death; at = p->d.pos;       /* a through-hole: the death cell is on its axis */
    } else if (p->dim == 2 && p->birth > 0 && p->birth <= gap && isfinite(p->death)) {
      rho = p->birth; at = p->b.pos;       /* a hole in a closed shell: the cavity closes there */
    } else continue;
    /* neighbours: Gaussians with a mean within 2ρ + 2h */
    double R2 = (2 * rho + 2 * h) * (2 * rho + 2 * h), T[9] = {0}, m[3] = {0}, wsum = 0, col[3] = {0}, op = 0, thin = 0;
    for (size_t i = 0; i < g->n; i++) {
      double d2 = 0;
      for (int q = 0; q < 3; q++) { double dd = g->mean[3 * i + q] - at[q]; d2 += dd * dd; }
      if (d2 > R2) continue;
      double a = mgs_sigmoidf(g->opacity[i]), nv[3], smin;
      shortest_axis(g, i, nv, &smin);
      for (int x = 0; x < 3; x++) {
        m[x] += a * g->mean[3 * i + x];
        col[x] += a * g->sh_dc[3 * i + x];
        for (int y = 0; y < 3; y++) T[3 * x + y] += a * nv[x] * nv[y];
      }
      op += a; thin += a * smin; wsum += a;
    }
    if (!(wsum > 0)) continue;
    double w[3], V[9], nrm[3], cpos[3];
    mgs_sym3_eigen(T, w, V);
    /* a surface around the hole: the neighbours' normals agree (a tube's open end or its
       inside has normals spread in a plane, w[2] ≈ half the trace: not a gap) */
    if (!(w[2] > 0.7 * (w[0] + w[1] + w[2]))) continue;
    for (int q = 0; q < 3; q++) { nrm[q] = V[3 * q + 2]; m[q] /= wsum; }
    /* the hole's centre projected into the neighbours' plane */
    double off = (at[0] - m[0]) * nrm[0] + (at[1] - m[1]) * nrm[1] + (at[2] - m[2]) * nrm[2];
    for (int q = 0; q < 3; q++) cpos[q] = at[q] - off * nrm[q];
    spawn_rec *s = &out[n++];
    memset(s, 0, sizeof *s);
    s->pers = p->death - p->birth;
    double hint[3] = {1, 0, 0};
    frame_quat(nrm, hint, s->rot);
    for (int q = 0; q < 3; q++) { s->mean[q] = (float)cpos[q]; s->sh_dc[q] = (float)(col[q] / wsum); }
    s->log_scale[0] = s->log_scale[1] = (float)log(rho);
    s->log_scale[2] = (float)log(fmax(thin / wsum, 0.25 * h));
    s->opacity = mgs_logitf((float)fmin(fmax(op / wsum, 0.05), 0.99));
  }
  return n;
}

mgs_status mgs_morse_spawn_apply(mgs_morse_ctx *c, mgs_gaussians *g, struct mgs_adam *adam, size_t *spawned,
                                 mgs_error *err) {
  *spawned = 0;
  if (c->o.spawn == MGS_MORSE_SPAWN_NONE || c->r.n == 0 || c->o.max_spawn == 0) return MGS_OK;
  size_t cap = c->r.n;
  spawn_rec *rec = malloc(cap * sizeof *rec);
  if (!rec) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (spawn)");
  size_t n = c->o.spawn == MGS_MORSE_SPAWN_LITERAL ? spawn_literal(c, g, rec, cap) : spawn_gaps(c, g, rec, cap);
  qsort(rec, n, sizeof *rec, cmp_spawn);
  if (n > (size_t)c->o.max_spawn) n = (size_t)c->o.max_spawn;
  size_t first = 0;
  mgs_status st = n == 0 ? MGS_OK : adam ? mgs_model_append(g, adam, n, &first, err) : mgs_gaussians_append(g, n, &first, err);
  for (size_t k = 0; k < n && st == MGS_OK; k++) {
    size_t i = first + k;
    memcpy(g->mean + 3 * i, rec[k].mean, sizeof rec[k].mean);
    memcpy(g->log_scale + 3 * i, rec[k].log_scale, sizeof rec[k].log_scale);
    memcpy(g->rot + 4 * i, rec[k].rot, sizeof rec[k].rot);
    memcpy(g->sh_dc + 3 * i, rec[k].sh_dc, sizeof rec[k].sh_dc);
    g->opacity[i] = rec[k].opacity;
  }
  free(rec);
  if (st == MGS_OK) *spawned = n;
  return st;
}

/* ---- prune -------------------------------------------------------------------------- */

static mgs_status prune_literal(mgs_morse_ctx *c, const mgs_gaussians *g, uint8_t *keep, size_t *pruned, mgs_error *err) {
  const mgs_morse_result *r = &c->r;
  double eps = c->o.eps_p * r->diagonal;
  double *pts = malloc((2 * r->n + 1) * 3 * sizeof(double));
  uint8_t *low = malloc(2 * r->n + 1);
  if (!pts || !low) { free(pts); free(low); return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (prune)"); }
  size_t np = 0;
  for (size_t k = 0; k < r->n; k++) {
    const mgs_pair *p = &r->pairs[k].p;
    double pe = p->death - p->birth;
    /* bars below the SDF's accuracy (min_bar voxels) are no features at all: with them
       nearly every surface Gaussian touches a "low-persistence feature" (measured: 86 %
       of a 10k-Gaussian genus-2 model pruned at once) */
    if (pe < c->o.min_bar * r->voxel_size) continue;
    int is_low = isfinite(p->death) && !p->truncated && pe < eps;
    memcpy(pts + 3 * np, p->b.pos, 3 * sizeof(double)); low[np++] = (uint8_t)is_low;
    if (isfinite(p->death)) { memcpy(pts + 3 * np, p->d.pos, 3 * sizeof(double)); low[np++] = (uint8_t)is_low; }
  }
  morse_gather gt;
  mgs_status st = morse_gather_build(g, pts, np, 3.0, &gt, err);
  if (st == MGS_OK) {
    uint8_t *mark = calloc(g->n ? g->n : 1, 1); /* bit 1: a low cell, bit 2: a high one */
    if (!mark) st = mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (prune)");
    for (size_t q = 0; mark && q < np; q++)
      for (size_t e = gt.start[q]; e < gt.start[q + 1]; e++) mark[gt.idx[e]] |= low[q] ? 1 : 2;
    for (size_t i = 0; mark && i < g->n; i++)
      if (mark[i] == 1 && keep[i]) { keep[i] = 0; (*pruned)++; }
    free(mark);
    morse_gather_free(&gt);
  }
  free(pts); free(low);
  return st;
}

static mgs_status prune_floaters(mgs_morse_ctx *c, const mgs_gaussians *g, uint8_t *keep, size_t *pruned, mgs_error *err) {
  mgs_status st = MGS_OK;
  if (c->comp && c->comp->n > 1 && c->sub) {
    const mgs_topo_component *big = &c->comp->comp[0];
    int32_t *ids = malloc(c->comp->n * sizeof(int32_t));
    if (!ids) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory (prune)");
    size_t nf = mgs_topo_floater_components(c->comp, c->o.floater_volume * big->volume, c->o.floater_mass * big->mass, ids);
    size_t *idx = NULL, *idx0 = NULL, n = 0, n0 = 0;
    int32_t zero = 0;
    if (nf) st = mgs_topo_gaussians_touching(c->comp, ids, nf, c->sub, 3.0, &idx, &n, err);
    if (nf && st == MGS_OK) st = mgs_topo_gaussians_touching(c->comp, &zero, 1, c->sub, 3.0, &idx0, &n0, err);
    /* both lists ascending: drop those also touching the largest component */
    for (size_t a = 0, b = 0; st == MGS_OK && a < n; a++) {
      while (b < n0 && idx0[b] < idx[a]) b++;
      if (b < n0 && idx0[b] == idx[a]) continue;
      size_t i = c->sub_map[idx[a]];
      if (keep[i]) { keep[i] = 0; (*pruned)++; }
    }
    free(idx); free(idx0); free(ids);
  }
  if (st == MGS_OK && c->cam_count && c->cam_n == g->n)
    for (size_t i = 0; i < g->n; i++)
      if (c->cam_count[i] < c->o.min_cameras && keep[i]) { keep[i] = 0; (*pruned)++; }
  return st;
}

mgs_status mgs_morse_prune_select(mgs_morse_ctx *c, const mgs_gaussians *g, uint8_t *keep, size_t *pruned,
                                  mgs_error *err) {
  *pruned = 0;
  if (c->r.iteration == 0) return MGS_OK;
  if (c->o.prune == MGS_MORSE_PRUNE_LITERAL && c->r.n) return prune_literal(c, g, keep, pruned, err);
  if (c->o.prune == MGS_MORSE_PRUNE_FLOATERS) return prune_floaters(c, g, keep, pruned, err);
  return MGS_OK;
}

/* ---- strategy hooks ----------------------------------------------------------------- */

static mgs_status ms_pre(void *self, mgs_strategy_step *s, mgs_error *err) {
  morse_strat *m = self;
  return m->adc->ops->pre_backward ? m->adc->ops->pre_backward(m->adc->self, s, err) : MGS_OK;
}

/* Compacts a per-Gaussian int array with keep and appends `add` zeros into dst. */
static void carry_int(const int *src, size_t n, const uint8_t *keep, size_t add, int *dst) {
  size_t w = 0;
  for (size_t i = 0; i < n; i++) if (keep[i]) dst[w++] = src[i];
  memset(dst + w, 0, add * sizeof(int));
}
static void carry_float(const float *src, size_t n, const uint8_t *keep, size_t add, float *dst) {
  size_t w = 0;
  for (size_t i = 0; i < n; i++) if (keep[i]) dst[w++] = src[i];
  memset(dst + w, 0, add * sizeof(float));
}

static mgs_status ms_post(void *self, mgs_strategy_step *s, mgs_error *err) {
  morse_strat *m = self;
  mgs_morse_ctx *c = m->ctx;
  int it = s->iteration;
  if (!mgs_morse_is_analysis_iteration(c, it) || (c->o.spawn == MGS_MORSE_SPAWN_NONE && c->o.prune == MGS_MORSE_PRUNE_NONE))
    return m->adc->ops->post_backward(m->adc->self, s, err);
  mgs_gaussians *g = s->model;
  mgs_status st = mgs_morse_ctx_update(c, g, it, NULL, err);
  if (st) return st;
  size_t n0 = g->n, pruned = 0, spawned = 0;
  uint8_t *keep = malloc(n0 ? n0 : 1);
  if (!keep) return mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  memset(keep, 1, n0);
  st = mgs_morse_prune_select(c, g, keep, &pruned, err);
  /* keep the ADC accumulators of the survivors */
  mgs_adc_state *as = st == MGS_OK ? mgs_strategy_adc_state(m->adc, n0) : NULL;
  float *acc = malloc((n0 + 1) * sizeof(float));
  int *cnt = malloc((n0 + 1) * sizeof(int)), *rad = malloc((n0 + 1) * sizeof(int));
  if (st == MGS_OK && (!as || !acc || !cnt || !rad)) st = mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  if (st == MGS_OK) {
    memcpy(acc, as->grad_accum, n0 * sizeof(float));
    memcpy(cnt, as->count, n0 * sizeof(int));
    memcpy(rad, as->max_radii, n0 * sizeof(int));
    if (pruned) mgs_model_compact(g, s->adam, keep);
    st = mgs_morse_spawn_apply(c, g, s->adam, &spawned, err);
  }
  /* this iteration's screen statistics, carried the same way, for the ADC fallback */
  float *gm = NULL;
  int *radii = NULL;
  if (st == MGS_OK) {
    gm = malloc((g->n + 1) * sizeof(float));
    radii = malloc((g->n + 1) * sizeof(int));
    as = mgs_strategy_adc_state(m->adc, g->n);
    if (!gm || !radii || !as) st = mgs_error_set(err, MGS_ERR_NOMEM, "morse: out of memory");
  }
  if (st == MGS_OK) {
    carry_float(acc, n0, keep, spawned, as->grad_accum);
    carry_int(cnt, n0, keep, spawned, as->count);
    carry_int(rad, n0, keep, spawned, as->max_radii);
    carry_float(s->grad_mean2d, n0, keep, spawned, gm);
    carry_int(s->radii, n0, keep, spawned, radii);
    mgs_strategy_step s2 = *s;
    s2.grad_mean2d = gm;
    s2.radii = radii;
    s2.replaced_groups = 0;
    st = m->adc->ops->post_backward(m->adc->self, &s2, err);
    s->replaced_groups = s2.replaced_groups;
    s->model_replaced = s2.model_replaced;
    if (pruned || spawned) s->replaced_groups = (1u << MGS_PARAM_COUNT) - 1; /* counts changed: no Adam step now */
  }
  free(keep); free(acc); free(cnt); free(rad); free(gm); free(radii);
  if (st) return st;
  m->total_spawned += spawned;
  m->total_pruned += pruned;
  mgs_morse_ctx_note_spawn(c, spawned, pruned);
  const mgs_morse_result *r = &c->r;
  mgs_info("morse @%d: spawned %zu, pruned %zu beside betti(0) %d %d %d (above eps %d %d %d); %zu Gaussians", it, spawned,
           pruned, r->betti0[0], r->betti0[1], r->betti0[2], r->betti_eps[0], r->betti_eps[1], r->betti_eps[2], g->n);
  return MGS_OK;
}

static int ms_fusable(void *self, const mgs_strategy_step *s) {
  morse_strat *m = self;
  if (mgs_morse_is_analysis_iteration(m->ctx, s->iteration)) return 0;
  return m->adc->ops->fusable ? m->adc->ops->fusable(m->adc->self, s) : 0;
}

static mgs_status ms_save(void *self, FILE *f, mgs_error *err) {
  morse_strat *m = self;
  mgs_status st = m->adc->ops->save(m->adc->self, f, err);
  uint64_t tot[2] = {m->total_spawned, m->total_pruned};
  if (st == MGS_OK && fwrite(tot, 8, 2, f) != 2) st = mgs_error_set(err, MGS_ERR_IO, "morse: cannot write its state");
  return st ? st : mgs_morse_ctx_save(m->ctx, f, err);
}

static mgs_status ms_load(void *self, FILE *f, size_t n, mgs_error *err) {
  morse_strat *m = self;
  mgs_status st = m->adc->ops->load(m->adc->self, f, n, err);
  uint64_t tot[2];
  if (st == MGS_OK && fread(tot, 8, 2, f) != 2) st = mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint truncated in the morse strategy state");
  if (st) return st;
  m->total_spawned = tot[0];
  m->total_pruned = tot[1];
  return mgs_morse_ctx_load(m->ctx, f, err);
}

static void ms_destroy(void *self) {
  morse_strat *m = self;
  if (!m) return;
  mgs_strategy_destroy(m->adc);
  mgs_morse_ctx_unref(m->ctx);
  free(m);
}

static const mgs_strategy_ops morse_ops = {"morse", ms_pre, ms_post, ms_save, ms_load, ms_destroy, ms_fusable, NULL};

mgs_status mgs_strategy_morse_create(const mgs_adc_options *adc, mgs_morse_ctx *ctx, mgs_strategy **out, mgs_error *err) {
  *out = NULL;
  mgs_strategy *s = calloc(1, sizeof *s);
  morse_strat *m = calloc(1, sizeof *m);
  if (m) m->adc = mgs_strategy_adc_create(adc);
  if (!s || !m || !m->adc) {
    if (m) mgs_strategy_destroy(m->adc);
    free(s); free(m);
    return mgs_error_set(err, MGS_ERR_NOMEM, "morse strategy: out of memory");
  }
  m->ctx = mgs_morse_ctx_ref(ctx);
  s->ops = &morse_ops;
  s->self = m;
  *out = s;
  return MGS_OK;
}
