/* MorseGS-R: L_topo on the model (SPEC §5.2 item 5, §6), through train/mgs_term.h.
 *
 * The diagram is not recomputed every iteration. The Morse analysis (every K iterations)
 * fixes the pairing, the critical voxels and, for every bar end the loss can move, the
 * closest point c on {A = τ} of its voxel. In between, each end's value is re-evaluated
 * from the current Gaussians to first order, value = value₀ − (A(c) − A₀(c)) / |∇A₀(c)|
 * (the implicit-function step: the surface moves by −δA/|∇A| along its normal at c), the
 * loss (eliminate: Σ_{p<ε_sig} p², or the seed's literal Σ max(0, ε_sig − p)²) is taken on
 * those values, and its gradient goes to the Gaussians whose support reaches c through
 * ∂d/∂θ = −(∂A(c)/∂θ)/|∇A(c)| (mgs_morse_sdf_point_grad). Ends set by the band clamp are
 * constants. Bars in the loss are those with persistence in [min_bar voxels, ε_sig) at the
 * analysis (morse_in_loss). The loss is measured in units of ε_sig² (scale-free β). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "train/morse_internal.h"
#include "train/mgs_morse_grad.h"
#include "train/mgs_term.h"
#include "topo/mgs_topo_grad.h"
#include "core/mgs_parallel.h"
#include "core/mgs_log.h"

typedef struct topo_term {
  mgs_morse_ctx *ctx;
  int owns_state;
  /* candidate Gaussians per bar end; rebuilt when the analysis, the count or the
     25-iteration tick changes (their 3.5σ supports: a superset of what the 3σ evaluation
     reads, so a rebuild at another iteration gives the same sums) */
  morse_gather gat;
  int built_analysis, built_it;
  int replaced_at;             /* last iteration the strategy replaced every Gaussian (0: never) */
  size_t built_n;
  size_t n_ends;
  size_t stale;                /* pairs left out at the last evaluation (moved > 1 voxel) */
  size_t *end_pair;            /* end -> 2 * pair + (0 birth, 1 death) */
  double *pts;
  /* Derived from the lists and the analysis at the first step after a rebuild (or after a
     checkpoint restored the lists), all together (lists_derive):
     - the lists inverted: each Gaussian that is a candidate of some end, and its candidate
       rows in ascending order;
     - the analysis' pairs in the loss set (morse_in_loss) and each end's place among them:
       the others add nothing to the loss, so it is taken on these alone, not on a copy of
       the whole diagram every iteration. */
  int derived;
  size_t n_inv, *inv_id, *inv_start, *inv_rows;
  size_t n_lp, *lp, *end_local;
  mgs_gaussians *loc, *locg;
} topo_term;

static void derived_free(topo_term *t) {
  free(t->inv_id); free(t->inv_start); free(t->inv_rows);
  free(t->lp); free(t->end_local);
  t->inv_id = t->inv_start = t->inv_rows = t->lp = t->end_local = NULL;
  t->n_inv = t->n_lp = 0;
  t->derived = 0;
}

static void topo_clear(topo_term *t) {
  if (t->gat.start) morse_gather_free(&t->gat);
  free(t->end_pair); t->end_pair = NULL;
  free(t->pts); t->pts = NULL;
  derived_free(t);
  t->n_ends = 0;
  t->built_analysis = -1;
}

static mgs_status topo_prepare(topo_term *t, const mgs_gaussians *g, int it, mgs_error *err) {
  const mgs_morse_result *r = &t->ctx->r;
  if (t->built_analysis == r->iteration && t->built_n == g->n && it - t->built_it < 25 && t->gat.start) return MGS_OK;
  topo_clear(t);
  t->end_pair = malloc((2 * r->n + 1) * sizeof(size_t));
  t->pts = malloc((2 * r->n + 1) * 3 * sizeof(double));
  if (!t->end_pair || !t->pts) return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  for (size_t k = 0; k < r->n; k++) {
    const mgs_morse_pair *mp = &r->pairs[k];
    if (mp->has_cb) { memcpy(t->pts + 3 * t->n_ends, mp->cb, 3 * sizeof(double)); t->end_pair[t->n_ends++] = 2 * k; }
    if (mp->has_cd) { memcpy(t->pts + 3 * t->n_ends, mp->cd, 3 * sizeof(double)); t->end_pair[t->n_ends++] = 2 * k + 1; }
  }
  mgs_status st = morse_gather_build(g, t->pts, t->n_ends, 3.5, &t->gat, err);
  if (st) return st;
  t->built_analysis = r->iteration;
  t->built_n = g->n;
  t->built_it = it;
  mgs_debug("topo loss @%d: %zu bar ends, %zu candidate rows (%.1f per end) of %zu Gaussians", it, t->n_ends,
            t->gat.start[t->n_ends], t->n_ends ? (double)t->gat.start[t->n_ends] / (double)t->n_ends : 0.0, g->n);
  return MGS_OK;
}

/* A model view of rows [s, s + n) of m (no ownership). */
static mgs_gaussians slice(const mgs_gaussians *m, size_t s, size_t n) {
  mgs_gaussians v = *m;
  v.n = v.capacity = n;
  v.mean += 3 * s; v.log_scale += 3 * s; v.rot += 4 * s; v.opacity += s;
  v.sh_dc += 3 * s; v.sh_rest += (size_t)MGS_SH_REST_MAX * s;
  return v;
}

typedef struct copy_job { const mgs_gaussians *g; mgs_gaussians *L; const size_t *idx; } copy_job;

static void copy_rows(void *vp, size_t b, size_t e) {
  const copy_job *c = vp;
  const mgs_gaussians *g = c->g;
  mgs_gaussians *L = c->L;
  for (size_t j = b; j < e; j++) {
    size_t i = c->idx[j];
    for (int q = 0; q < 3; q++) { L->mean[3 * j + q] = g->mean[3 * i + q]; L->log_scale[3 * j + q] = g->log_scale[3 * i + q]; }
    for (int q = 0; q < 4; q++) L->rot[4 * j + q] = g->rot[4 * i + q];
    L->opacity[j] = g->opacity[i];
  }
}

/* The candidates of every end, in order, into t->loc (the field's groups only). */
static mgs_status gather_all(topo_term *t, const mgs_gaussians *g, size_t total, mgs_error *err) {
  mgs_status st = MGS_OK;
  if (t->loc->capacity < total) st = mgs_gaussians_reserve(t->loc, total, err);
  if (st == MGS_OK && t->locg->capacity < total) st = mgs_gaussians_reserve(t->locg, total, err);
  if (st) return st;
  t->loc->n = t->locg->n = total;
  copy_job job = {g, t->loc, t->gat.idx};
  mgs_parallel_for(0, total, 4096, copy_rows, &job);
  return MGS_OK;
}

typedef struct end_job {
  topo_term *t;
  float tau;
  double *aval;          /* out: A at each end's c */
  double *den;           /* out: the normal length each end's derivative divides by */
  const double *weight;  /* scale pass: beta * dL/d(end) */
  mgs_status *st;
} end_job;

/* One pass per end: A(c) and ∂A(c)/∂θ of its candidates (into locg); the loss' weight of
   an end depends on every end's value, so the gradient is scaled once it is known
   (end_scale) instead of visiting the candidates a second and third time. */
static void end_value(void *vp, size_t b, size_t e) {
  end_job *j = vp;
  for (size_t q = b; q < e; q++) {
    size_t s = j->t->gat.start[q], cnt = j->t->gat.start[q + 1] - s;
    mgs_gaussians v = slice(j->t->loc, s, cnt), vg = slice(j->t->locg, s, cnt);
    mgs_morse_point pt = {0};
    j->aval[q] = 0;
    j->den[q] = 1;
    if (cnt) j->st[q] = mgs_morse_sdf_point_unit_grad(&v, j->t->pts + 3 * q, j->tau, &vg, &pt, &j->den[q], NULL);
    j->aval[q] = pt.alpha;
  }
}

static void end_scale(void *vp, size_t b, size_t e) {
  end_job *j = vp;
  for (size_t q = b; q < e; q++) {
    size_t s = j->t->gat.start[q], cnt = j->t->gat.start[q + 1] - s;
    mgs_gaussians *L = j->t->locg;
    if (!isfinite(j->weight[q])) { j->st[q] = MGS_ERR_NUMERIC; continue; }
    /* no contributor at c (den 0) or no weight: no gradient, as the two-pass form */
    const double f = j->weight[q] != 0 && j->den[q] > 0 ? -j->weight[q] / j->den[q] : 0.0;
    for (size_t r = s; r < s + cnt; r++) {
      L->opacity[r] = (float)(f * L->opacity[r]);
      for (int k = 0; k < 3; k++) {
        L->mean[3 * r + k] = (float)(f * L->mean[3 * r + k]);
        L->log_scale[3 * r + k] = (float)(f * L->log_scale[3 * r + k]);
      }
      for (int k = 0; k < 4; k++) L->rot[4 * r + k] = (float)(f * L->rot[4 * r + k]);
    }
  }
}

/* The derived lists (see topo_term). The inversion is a counting sort of the candidate rows
   by Gaussian; rows are visited in ascending order, so each Gaussian's rows stay ascending
   and the scatter below sums every element in the order a serial loop over rows would, bit
   for bit, but in parallel and with sequential writes (the serial loop's random writes were
   most of L_topo's own time). */
static mgs_status lists_derive(topo_term *t, mgs_error *err) {
  const mgs_morse_options *o = &t->ctx->o;
  const mgs_morse_result *r = &t->ctx->r;
  const size_t total = t->gat.start[t->n_ends], n = t->built_n;
  size_t nu = 0, *cur = calloc(n + 1, sizeof(size_t)), *local = malloc((r->n + 1) * sizeof(size_t));
  for (size_t j = 0; cur && j < total; j++) cur[t->gat.idx[j]]++;
  for (size_t i = 0; cur && i < n; i++) nu += cur[i] > 0;
  t->inv_id = malloc((nu + 1) * sizeof(size_t));
  t->inv_start = malloc((nu + 1) * sizeof(size_t));
  t->inv_rows = malloc((total + 1) * sizeof(size_t));
  t->lp = malloc((r->n + 1) * sizeof(size_t));
  t->end_local = malloc((t->n_ends + 1) * sizeof(size_t));
  if (!cur || !local || !t->inv_id || !t->inv_start || !t->inv_rows || !t->lp || !t->end_local) {
    free(cur);
    free(local);
    derived_free(t); /* (so the next step derives them again) */
    return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  }
  size_t u = 0, pos = 0;
  for (size_t i = 0; i < n; i++) {
    if (!cur[i]) continue;
    t->inv_id[u] = i;
    t->inv_start[u++] = pos;
    size_t c = cur[i];
    cur[i] = pos; /* from here on: the next free slot of Gaussian i */
    pos += c;
  }
  t->inv_start[nu] = pos;
  for (size_t j = 0; j < total; j++) t->inv_rows[cur[t->gat.idx[j]]++] = j;
  t->n_inv = nu;
  const double eps_sig = o->eps_sig * r->diagonal;
  size_t m = 0;
  for (size_t k = 0; k < r->n; k++) {
    local[k] = SIZE_MAX;
    if (morse_in_loss(o, &r->pairs[k].p, eps_sig, r->voxel_size)) { local[k] = m; t->lp[m++] = k; }
  }
  t->n_lp = m;
  /* (the analysis gives ends only to pairs in the set; one outside would carry no weight) */
  for (size_t e = 0; e < t->n_ends; e++) t->end_local[e] = local[t->end_pair[e] / 2];
  free(cur);
  free(local);
  t->derived = 1;
  return MGS_OK;
}

typedef struct scatter_job { const topo_term *t; mgs_gaussians *grad; } scatter_job;

static void scatter_rows(void *vp, size_t b, size_t e) {
  const scatter_job *sj = vp;
  const topo_term *t = sj->t;
  const mgs_gaussians *L = t->locg;
  mgs_gaussians *G = sj->grad;
  for (size_t u = b; u < e; u++) {
    const size_t i = t->inv_id[u];
    for (size_t r = t->inv_start[u]; r < t->inv_start[u + 1]; r++) {
      const size_t j = t->inv_rows[r];
      for (int q = 0; q < 3; q++) G->mean[3 * i + q] += L->mean[3 * j + q];
      for (int q = 0; q < 3; q++) G->log_scale[3 * i + q] += L->log_scale[3 * j + q];
      for (int q = 0; q < 4; q++) G->rot[4 * i + q] += L->rot[4 * j + q];
      G->opacity[i] += L->opacity[j];
    }
  }
}

/* Loss (unweighted) on the current model; with grad, adds beta * dL/dθ into it. */
static mgs_status topo_eval(topo_term *t, const mgs_gaussians *g, int it, mgs_gaussians *grad, double beta,
                            double *loss, double *short_pers, mgs_error *err) {
  const mgs_morse_ctx *c = t->ctx;
  const mgs_morse_options *o = &c->o;
  const mgs_morse_result *r = &c->r;
  *loss = 0;
  if (short_pers) *short_pers = 0;
  if (r->iteration == 0 || r->n == 0) return MGS_OK;
  mgs_status st = topo_prepare(t, g, it, err);
  if (st) return st;
  if (!t->derived && (st = lists_derive(t, err)) != MGS_OK) return st;
  const size_t nl = t->n_lp;
  mgs_diagram d;
  memset(&d, 0, sizeof d);
  d.n = d.capacity = nl;
  d.pairs = malloc((nl + 1) * sizeof(mgs_pair));
  double *dlb = calloc(nl + 1, sizeof(double)), *dld = calloc(nl + 1, sizeof(double));
  if (!d.pairs || !dlb || !dld) { free(d.pairs); free(dlb); free(dld); return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory"); }
  double eps_sig = o->eps_sig * r->diagonal;
  for (size_t m = 0; m < nl; m++) d.pairs[m] = r->pairs[t->lp[m]].p;
  /* every end's candidate Gaussians side by side, gathered once per iteration; each end
     reads (and writes its gradient into) its own slice, so ends run in parallel */
  size_t total = t->gat.start[t->n_ends];
  st = gather_all(t, g, total, err);
  double *aval = malloc((t->n_ends + 1) * sizeof(double)), *den = malloc((t->n_ends + 1) * sizeof(double));
  mgs_status *est = calloc(t->n_ends + 1, sizeof(mgs_status));
  if (st == MGS_OK && (!aval || !den || !est)) st = mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  end_job job = {t, (float)o->tau, aval, den, NULL, est};
  if (st == MGS_OK) {
    mgs_parallel_for(0, t->n_ends, 8, end_value, &job);
    for (size_t e = 0; e < t->n_ends && st == MGS_OK; e++)
      if (est[e]) st = mgs_error_set(err, est[e], "topo loss: the field at a bar end is not finite");
  }
  /* The first-order value holds while the surface near c moved less than a voxel. An end
     that moved more (an opacity reset, a split, the term's own push) takes its pair out of
     the loss until the next analysis: extrapolating there pushes at a feature that is no
     longer where the analysis saw it, and makes new sub-voxel ones (measured: +60 % short
     bars at 7000 iterations with resets, before this rule). */
  size_t stale = 0;
  int *out = malloc((nl + 1) * sizeof(int)); /* dimension of a stale pair, else -1 */
  if (!out && st == MGS_OK) st = mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  for (size_t m = 0; out && m < nl; m++) out[m] = -1;
  for (size_t e = 0; e < t->n_ends && st == MGS_OK; e++) {
    const size_t m = t->end_local[e];
    if (m == SIZE_MAX) continue;
    const mgs_morse_pair *mp = &r->pairs[t->end_pair[e] / 2];
    double shift = (t->end_pair[e] & 1) ? -(aval[e] - mp->ad) / mp->gd : -(aval[e] - mp->ab) / mp->gb;
    if (!(fabs(shift) <= r->voxel_size) && d.pairs[m].dim < 3) { stale++; out[m] = d.pairs[m].dim; d.pairs[m].dim = 3; }
    if (t->end_pair[e] & 1) d.pairs[m].death = mp->p.death + shift;
    else d.pairs[m].birth = mp->p.birth + shift;
  }
  t->stale = stale;
  if (st == MGS_OK) {
    mgs_topo_loss_kind kind = o->topo == MGS_MORSE_TOPO_LITERAL ? MGS_TOPO_LOSS_LITERAL : MGS_TOPO_LOSS_ELIMINATE;
    /* in units of ε_sig², so β does not depend on the scene's scale (a bar of ε_sig
       costs β whatever the units of the scene) */
    double unit = 1.0 / (eps_sig * eps_sig);
    *loss = unit * mgs_topo_loss(&d, kind, eps_sig, o->dims, dlb, dld);
    for (size_t m = 0; m < nl; m++) { dlb[m] *= unit; dld[m] *= unit; }
    if (short_pers) /* every pair the analysis put in the loss, stale ones included */
      for (size_t m = 0; m < nl; m++) {
        int dim = out[m] >= 0 ? out[m] : d.pairs[m].dim;
        if (dim < 3 && ((o->dims >> dim) & 1u)) *short_pers += fabs(d.pairs[m].death - d.pairs[m].birth);
      }
  }
  if (grad && st == MGS_OK) {
    double *w = aval; /* reused: the weight of each end */
    for (size_t e = 0; e < t->n_ends; e++) {
      const size_t m = t->end_local[e];
      w[e] = m == SIZE_MAX ? 0.0 : beta * ((t->end_pair[e] & 1) ? dld[m] : dlb[m]);
    }
    job.weight = w;
    mgs_parallel_for(0, t->n_ends, 8, end_scale, &job);
    for (size_t e = 0; e < t->n_ends && st == MGS_OK; e++)
      if (est[e]) st = mgs_error_set(err, est[e], "topo loss: the gradient at a bar end is not finite");
    /* scatter: per Gaussian, its rows in ascending order (the same sums as a serial pass) */
    if (st == MGS_OK) {
      scatter_job sj = {t, grad};
      mgs_parallel_for(0, t->n_inv, 256, scatter_rows, &sj);
    }
  }
  free(aval); free(den); free(est); free(out);
  free(d.pairs); free(dlb); free(dld);
  return st;
}

static unsigned topo_active(void *self, int it) {
  topo_term *t = self;
  if (t->ctx->o.beta <= 0) return 0;
  if (mgs_morse_is_analysis_iteration(t->ctx, it)) return MGS_TERM_MODEL;
  /* an analysis of a model the strategy has since replaced (Mini-Splatting's
     reinitialisations) guides nothing: off until the next analysis */
  return t->ctx->r.iteration > 0 && t->ctx->r.iteration > t->replaced_at ? MGS_TERM_MODEL : 0;
}

static void topo_model_replaced(void *self, int it) {
  topo_term *t = self;
  t->replaced_at = it;
  topo_clear(t);
}

static mgs_status topo_model_grad(void *self, mgs_term_step *s, mgs_error *err) {
  topo_term *t = self;
  mgs_status st = mgs_morse_ctx_update(t->ctx, s->model, s->iteration, NULL, err);
  if (st) return st;
  double L = 0;
  st = topo_eval(t, s->model, s->iteration, s->grad, t->ctx->o.beta, &L, NULL, err);
  s->value = t->ctx->o.beta * L;
  mgs_morse_ctx_note_topo(t->ctx, s->value);
  return st;
}

/* The candidate lists go into checkpoints too: they are built from the model of the
   iteration they were built at, so a resumed run must not rebuild them from a later one. */
static int gather_save(const topo_term *t, FILE *f) {
  uint8_t has = t->gat.start != NULL;
  if (fwrite(&has, 1, 1, f) != 1) return 0;
  if (!has) return 1;
  int32_t head[2] = {t->built_analysis, t->built_it};
  uint64_t sizes[3] = {t->built_n, t->n_ends, t->gat.n};
  size_t nidx = t->gat.start[t->gat.n];
  return fwrite(head, sizeof head, 1, f) == 1 && fwrite(sizes, sizeof sizes, 1, f) == 1 &&
         fwrite(t->end_pair, sizeof(size_t), t->n_ends, f) == t->n_ends &&
         fwrite(t->pts, 3 * sizeof(double), t->n_ends, f) == t->n_ends &&
         fwrite(t->gat.start, sizeof(size_t), t->gat.n + 1, f) == t->gat.n + 1 &&
         (nidx == 0 || fwrite(t->gat.idx, sizeof(size_t), nidx, f) == nidx);
}

static mgs_status gather_load(topo_term *t, FILE *f, mgs_error *err) {
  uint8_t has = 0;
  if (fread(&has, 1, 1, f) != 1 || !has) return MGS_OK; /* none, or a checkpoint made before they were kept */
  int32_t head[2];
  uint64_t sizes[3];
  if (fread(head, sizeof head, 1, f) != 1 || fread(sizes, sizeof sizes, 1, f) != 1 || sizes[1] > ((uint64_t)1 << 32) ||
      sizes[2] > ((uint64_t)1 << 32))
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the topological loss' candidate lists are damaged");
  t->built_analysis = head[0];
  t->built_it = head[1];
  t->built_n = (size_t)sizes[0];
  t->n_ends = (size_t)sizes[1];
  t->gat.n = (size_t)sizes[2];
  t->end_pair = malloc((t->n_ends + 1) * sizeof(size_t));
  t->pts = malloc((t->n_ends + 1) * 3 * sizeof(double));
  t->gat.start = malloc((t->gat.n + 1) * sizeof(size_t));
  if (!t->end_pair || !t->pts || !t->gat.start) return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  if (fread(t->end_pair, sizeof(size_t), t->n_ends, f) != t->n_ends || fread(t->pts, 3 * sizeof(double), t->n_ends, f) != t->n_ends ||
      fread(t->gat.start, sizeof(size_t), t->gat.n + 1, f) != t->gat.n + 1 || t->gat.start[t->gat.n] > ((size_t)1 << 40))
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the topological loss' candidate lists are truncated");
  size_t nidx = t->gat.start[t->gat.n];
  t->gat.idx = malloc((nidx + 1) * sizeof(size_t));
  if (!t->gat.idx) return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  if (nidx && fread(t->gat.idx, sizeof(size_t), nidx, f) != nidx)
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the topological loss' candidate lists are truncated");
  for (size_t k = 0; k < nidx; k++)
    if (t->gat.idx[k] >= t->built_n) return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: a candidate Gaussian index is out of range");
  return MGS_OK;
}

static mgs_status topo_save(void *self, FILE *f, mgs_error *err) {
  topo_term *t = self;
  /* bit 7: an int32 replacement iteration follows (absent, the byte and the file are as
     before the replacement notice existed) */
  uint8_t own = (uint8_t)(t->owns_state | (t->replaced_at > 0 ? 0x80 : 0));
  if (fwrite(&own, 1, 1, f) != 1) return mgs_error_set(err, MGS_ERR_IO, "topo loss: cannot write its state");
  if (t->replaced_at > 0) {
    int32_t r = t->replaced_at;
    if (fwrite(&r, sizeof r, 1, f) != 1) return mgs_error_set(err, MGS_ERR_IO, "topo loss: cannot write its state");
  }
  mgs_status st = own ? mgs_morse_ctx_save(t->ctx, f, err) : MGS_OK;
  if (st == MGS_OK && !gather_save(t, f)) st = mgs_error_set(err, MGS_ERR_IO, "topo loss: cannot write its state");
  return st;
}

static mgs_status topo_load(void *self, FILE *f, mgs_error *err) {
  topo_term *t = self;
  uint8_t own = 0;
  if (fread(&own, 1, 1, f) != 1 || (own & 0x7f) != (uint8_t)t->owns_state)
    return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the topological loss state does not match this run's setup");
  t->replaced_at = 0;
  if (own & 0x80) {
    int32_t r = 0;
    if (fread(&r, sizeof r, 1, f) != 1 || r <= 0)
      return mgs_error_set(err, MGS_ERR_FORMAT, "checkpoint: the topological loss state is truncated");
    t->replaced_at = r;
  }
  own &= 0x7f;
  topo_clear(t);
  mgs_status st = own ? mgs_morse_ctx_load(t->ctx, f, err) : MGS_OK;
  if (st == MGS_OK) st = gather_load(t, f, err);
  if (st) topo_clear(t);
  return st;
}

static void topo_destroy(void *self) {
  topo_term *t = self;
  if (!t) return;
  topo_clear(t);
  mgs_gaussians_destroy(t->loc);
  mgs_gaussians_destroy(t->locg);
  mgs_morse_ctx_unref(t->ctx);
  free(t);
}

static const mgs_term_ops topo_ops = {"morse_topo", topo_active, NULL, topo_model_grad, topo_save, topo_load, topo_destroy,
                                      topo_model_replaced};

static topo_term *topo_new(mgs_morse_ctx *ctx, int owns_state) {
  topo_term *t = calloc(1, sizeof *t);
  if (!t) return NULL;
  t->loc = mgs_gaussians_create(64, 0);
  t->locg = mgs_gaussians_create(64, 0);
  if (!t->loc || !t->locg) { mgs_gaussians_destroy(t->loc); mgs_gaussians_destroy(t->locg); free(t); return NULL; }
  t->ctx = mgs_morse_ctx_ref(ctx);
  t->owns_state = owns_state;
  t->built_analysis = -1;
  return t;
}

mgs_status mgs_term_topo_create(mgs_morse_ctx *ctx, int owns_state, mgs_term **out, mgs_error *err) {
  *out = NULL;
  topo_term *t = topo_new(ctx, owns_state);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  *out = mgs_term_create(&topo_ops, t);
  if (!*out) return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  return MGS_OK;
}

mgs_status mgs_term_topo_eval(mgs_morse_ctx *ctx, const mgs_gaussians *g, double *loss, double *short_pers,
                              mgs_error *err) {
  topo_term *t = topo_new(ctx, 0);
  if (!t) return mgs_error_set(err, MGS_ERR_NOMEM, "topo loss: out of memory");
  mgs_status st = topo_eval(t, g, ctx->r.iteration, NULL, 0, loss, short_pers, err);
  topo_destroy(t);
  return st;
}
