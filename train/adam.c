/* Adam over the model's parameter groups, as torch.optim.Adam (non-amsgrad, no weight
 * decay) that the reference 3DGS uses, with moments that follow count changes. */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include "train/mgs_train.h"
#include "train/adam_internal.h"
#include "core/mgs_parallel.h"
#if defined(__AVX512F__) || defined(__AVX2__)
#include <immintrin.h>
#endif

mgs_adam *mgs_adam_create(size_t n) {
  mgs_adam *a = calloc(1, sizeof *a);
  if (!a) return NULL;
  a->beta1 = 0.9; a->beta2 = 0.999; a->eps = 1e-15;
  a->sh_rest_active = 15;
  size_t cap = n ? n : 1;
  for (int g = 0; g < MGS_PARAM_COUNT; g++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)g);
    a->m[g] = calloc(cap * d, sizeof(float));
    a->v[g] = calloc(cap * d, sizeof(float));
    if (!a->m[g] || !a->v[g]) { mgs_adam_destroy(a); return NULL; }
  }
  a->n = n; a->capacity = cap;
  return a;
}

void mgs_adam_destroy(mgs_adam *a) {
  if (!a) return;
  for (int g = 0; g < MGS_PARAM_COUNT; g++) { free(a->m[g]); free(a->v[g]); }
  free(a);
}

mgs_status mgs_adam_append(mgs_adam *a, size_t count, mgs_error *err) {
  size_t need = a->n + count;
  if (need > a->capacity) {
    size_t cap = a->capacity * 2 > need ? a->capacity * 2 : need;
    for (int g = 0; g < MGS_PARAM_COUNT; g++) {
      size_t d = (size_t)mgs_param_dim((mgs_param_group)g);
      float *m = realloc(a->m[g], cap * d * sizeof(float));
      if (m) a->m[g] = m;
      /* packed SH-rest moments have no v array (mgs_adam.sh_rest_bf16) */
      float *v = m && a->v[g] ? realloc(a->v[g], cap * d * sizeof(float)) : NULL;
      if (v) a->v[g] = v;
      if (!m || (a->v[g] && !v)) return mgs_error_set(err, MGS_ERR_NOMEM, "adam: cannot grow moments to %zu Gaussians", cap);
    }
    a->capacity = cap;
  }
  for (int g = 0; g < MGS_PARAM_COUNT; g++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)g);
    memset(a->m[g] + a->n * d, 0, count * d * sizeof(float));
    if (a->v[g]) memset(a->v[g] + a->n * d, 0, count * d * sizeof(float));
  }
  a->n = need;
  return MGS_OK;
}

void mgs_adam_compact(mgs_adam *a, const uint8_t *keep) {
  size_t n = a->n;
  for (int g = 0; g < MGS_PARAM_COUNT; g++) {
    int d = mgs_param_dim((mgs_param_group)g);
    n = mgs_rows_compact(a->m[g], a->n, d, keep);
    if (a->v[g]) mgs_rows_compact(a->v[g], a->n, d, keep);
  }
  a->n = n;
}

void mgs_adam_reset_group(mgs_adam *a, mgs_param_group group) {
  size_t d = (size_t)mgs_param_dim(group);
  memset(a->m[group], 0, a->n * d * sizeof(float));
  if (a->v[group]) memset(a->v[group], 0, a->n * d * sizeof(float));
}

/* One fused pass: every selected group's elements are cut into units of ADAM_UNIT floats
 * (whole rows for a partly active SH-rest group) and all units of all groups go through
 * one parallel loop. */
#define ADAM_UNIT 8192

typedef struct {
  mgs_adam_group grp[MGS_PARAM_COUNT];
  int n_grp;
  int zero_grad;
  atomic_int bad;     /* bit k: group k had a non-finite value */
} step_ctx;

/* ---- bfloat16 SH-rest moments (mgs_adam.sh_rest_bf16) ---- */
static inline uint32_t f2u(float f) { uint32_t u; memcpy(&u, &f, 4); return u; }
static inline float u2f(uint32_t u) { float f; memcpy(&f, &u, 4); return f; }
/* lowbias32 (Wellons): 16 random bits for m (low half) and v (high half) of an element */
static inline uint32_t sr_hash(uint32_t x) {
  x ^= x >> 16; x *= 0x7feb352dU; x ^= x >> 15; x *= 0x846ca68bU; x ^= x >> 16;
  return x;
}

/* As mgs_adam_span on packed words: the step in float from the decoded moments, the
 * parameter updated with the unrounded ones, the moments stored rounded stochastically
 * (add 16 random bits below the kept ones, truncate: rounds up with probability equal to
 * the dropped fraction). */
static int adam_span_bf16(const mgs_adam_group *c, size_t b, size_t e) {
  float *restrict P = c->p;
  uint32_t *restrict MV = (uint32_t *)(void *)c->m;
  const float *restrict G = c->g;
  const float b1 = c->b1, b2 = c->b2, ob1 = 1 - c->b1, ob2 = 1 - c->b2;
  const float ss = c->step_size, isb = c->inv_sqrt_bc2, eps = c->eps;
  const uint32_t seed = c->seed, base = (uint32_t)c->elem0;
  int bad = 0;
  size_t i = b;
#if defined(__AVX512F__)
  const __m512 vb1 = _mm512_set1_ps(b1), vb2 = _mm512_set1_ps(b2), vob1 = _mm512_set1_ps(ob1), vob2 = _mm512_set1_ps(ob2);
  const __m512 vss = _mm512_set1_ps(ss), visb = _mm512_set1_ps(isb), veps = _mm512_set1_ps(eps), zero = _mm512_setzero_ps();
  const __m512i hi = _mm512_set1_epi32((int)0xFFFF0000u), lo = _mm512_set1_epi32(0xFFFF);
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512i k1 = _mm512_set1_epi32(0x7feb352d), k2 = _mm512_set1_epi32((int)0x846ca68bU);
  __mmask16 badm = 0;
  for (; i + 16 <= e; i += 16) {
    __m512 g = _mm512_loadu_ps(G + i);
    __m512i w = _mm512_loadu_si512((const void *)(MV + i));
    __m512 m0 = _mm512_castsi512_ps(_mm512_slli_epi32(w, 16)), v0 = _mm512_castsi512_ps(_mm512_and_si512(w, hi));
    __m512 m = _mm512_add_ps(_mm512_mul_ps(vb1, m0), _mm512_mul_ps(vob1, g));
    __m512 v = _mm512_add_ps(_mm512_mul_ps(vb2, v0), _mm512_mul_ps(_mm512_mul_ps(vob2, g), g));
    __m512 den = _mm512_add_ps(_mm512_mul_ps(_mm512_sqrt_ps(v), visb), veps);
    __m512 p = _mm512_sub_ps(_mm512_loadu_ps(P + i), _mm512_div_ps(_mm512_mul_ps(vss, m), den));
    _mm512_storeu_ps(P + i, p);
    __m512i x = _mm512_add_epi32(_mm512_set1_epi32((int)(base + (uint32_t)i)), lane);
    x = _mm512_xor_si512(x, _mm512_set1_epi32((int)seed));
    x = _mm512_xor_si512(x, _mm512_srli_epi32(x, 16)); x = _mm512_mullo_epi32(x, k1);
    x = _mm512_xor_si512(x, _mm512_srli_epi32(x, 15)); x = _mm512_mullo_epi32(x, k2);
    x = _mm512_xor_si512(x, _mm512_srli_epi32(x, 16));
    __m512i mb = _mm512_srli_epi32(_mm512_add_epi32(_mm512_castps_si512(m), _mm512_and_si512(x, lo)), 16);
    __m512i vb = _mm512_and_si512(_mm512_add_epi32(_mm512_castps_si512(v), _mm512_srli_epi32(x, 16)), hi);
    _mm512_storeu_si512((void *)(MV + i), _mm512_or_si512(mb, vb));
    __m512 chk = _mm512_add_ps(_mm512_sub_ps(p, p), _mm512_sub_ps(g, g));
    badm |= _mm512_cmp_ps_mask(chk, zero, _CMP_NEQ_UQ);
  }
  bad = badm != 0;
#endif
  for (; i < e; i++) {
    float g = G[i];
    uint32_t w = MV[i];
    float m = b1 * u2f(w << 16) + ob1 * g;
    float v = b2 * u2f(w & 0xFFFF0000u) + ob2 * g * g;
    float p = P[i] - ss * m / (sqrtf(v) * isb + eps);
    P[i] = p;
    uint32_t x = sr_hash((base + (uint32_t)i) ^ seed);
    MV[i] = ((f2u(m) + (x & 0xFFFFu)) >> 16) | ((f2u(v) + (x >> 16)) & 0xFFFF0000u);
    bad |= !isfinite(p) || !isfinite(g);
  }
  return bad;
}

mgs_status mgs_adam_set_sh_rest_bf16(mgs_adam *a, int on, mgs_error *err) {
  on = on != 0;
  if (on == a->sh_rest_bf16) return MGS_OK;
  uint32_t *w = (uint32_t *)(void *)a->m[MGS_PARAM_SH_REST];
  size_t n = a->n * MGS_SH_REST_MAX;
  float *v = a->v[MGS_PARAM_SH_REST];
  if (!on) {
    v = malloc(a->capacity * MGS_SH_REST_MAX * sizeof(float));
    if (!v) return mgs_error_set(err, MGS_ERR_NOMEM, "adam: cannot unpack the SH-rest moments of %zu Gaussians", a->n);
  }
  for (size_t i = 0; i < n; i++) {
    if (on) { /* round to nearest even */
      uint32_t mu = f2u(u2f(w[i])), vu = f2u(v[i]);
      mu += 0x7FFFu + ((mu >> 16) & 1u);
      vu += 0x7FFFu + ((vu >> 16) & 1u);
      w[i] = (mu >> 16) | (vu & 0xFFFF0000u);
    } else {
      v[i] = u2f(w[i] & 0xFFFF0000u);
      w[i] = w[i] << 16;
    }
  }
  /* packed: the v array is freed, which is the memory the option saves (180 bytes a
     Gaussian, about a fifth of the trainer's per-Gaussian state) */
  if (on) { free(v); v = NULL; }
  a->v[MGS_PARAM_SH_REST] = v;
  a->sh_rest_bf16 = on;
  return MGS_OK;
}

/* The element loop is written so the compiler vectorizes it (restrict pointers, constants
 * in locals, the finiteness test as arithmetic). */
int mgs_adam_span(const mgs_adam_group *c, size_t b, size_t e) {
  float *restrict P = c->p, *restrict M = c->m, *restrict V = c->v;
  if (c->packed) return adam_span_bf16(c, b, e);
  const float *restrict G = c->g;
  const float b1 = c->b1, b2 = c->b2, ob1 = 1 - c->b1, ob2 = 1 - c->b2;
  const float ss = c->step_size, isb = c->inv_sqrt_bc2, eps = c->eps;
  int bad = 0;
  size_t i = b;
#if defined(__AVX512F__)
  /* the scalar loop's operations in the same order, no contraction: identical results */
  const __m512 vb1 = _mm512_set1_ps(b1), vb2 = _mm512_set1_ps(b2), vob1 = _mm512_set1_ps(ob1), vob2 = _mm512_set1_ps(ob2);
  const __m512 vss = _mm512_set1_ps(ss), visb = _mm512_set1_ps(isb), veps = _mm512_set1_ps(eps), zero = _mm512_setzero_ps();
  __mmask16 badm = 0;
  for (; i + 16 <= e; i += 16) {
    __m512 g = _mm512_loadu_ps(G + i);
    __m512 m = _mm512_add_ps(_mm512_mul_ps(vb1, _mm512_loadu_ps(M + i)), _mm512_mul_ps(vob1, g));
    __m512 v = _mm512_add_ps(_mm512_mul_ps(vb2, _mm512_loadu_ps(V + i)), _mm512_mul_ps(_mm512_mul_ps(vob2, g), g));
    _mm512_storeu_ps(M + i, m);
    _mm512_storeu_ps(V + i, v);
    __m512 den = _mm512_add_ps(_mm512_mul_ps(_mm512_sqrt_ps(v), visb), veps);
    __m512 p = _mm512_sub_ps(_mm512_loadu_ps(P + i), _mm512_div_ps(_mm512_mul_ps(vss, m), den));
    _mm512_storeu_ps(P + i, p);
    __m512 chk = _mm512_add_ps(_mm512_sub_ps(p, p), _mm512_sub_ps(g, g));
    badm |= _mm512_cmp_ps_mask(chk, zero, _CMP_NEQ_UQ);
  }
  bad = badm != 0;
#elif defined(__AVX2__)
  /* the same in 8 lanes (GCC leaves the scalar loop scalar on AVX2: sqrt, divide and the
     finiteness flag); identical results */
  const __m256 vb1 = _mm256_set1_ps(b1), vb2 = _mm256_set1_ps(b2), vob1 = _mm256_set1_ps(ob1), vob2 = _mm256_set1_ps(ob2);
  const __m256 vss = _mm256_set1_ps(ss), visb = _mm256_set1_ps(isb), veps = _mm256_set1_ps(eps), zero = _mm256_setzero_ps();
  __m256 badv = zero;
  for (; i + 8 <= e; i += 8) {
    __m256 g = _mm256_loadu_ps(G + i);
    __m256 m = _mm256_add_ps(_mm256_mul_ps(vb1, _mm256_loadu_ps(M + i)), _mm256_mul_ps(vob1, g));
    __m256 v = _mm256_add_ps(_mm256_mul_ps(vb2, _mm256_loadu_ps(V + i)), _mm256_mul_ps(_mm256_mul_ps(vob2, g), g));
    _mm256_storeu_ps(M + i, m);
    _mm256_storeu_ps(V + i, v);
    __m256 den = _mm256_add_ps(_mm256_mul_ps(_mm256_sqrt_ps(v), visb), veps);
    __m256 p = _mm256_sub_ps(_mm256_loadu_ps(P + i), _mm256_div_ps(_mm256_mul_ps(vss, m), den));
    _mm256_storeu_ps(P + i, p);
    /* (p - p) + (g - g) is 0 for finite p and g, NaN otherwise; NaN stays NaN in the sum */
    badv = _mm256_add_ps(badv, _mm256_add_ps(_mm256_sub_ps(p, p), _mm256_sub_ps(g, g)));
  }
  bad = _mm256_movemask_ps(_mm256_cmp_ps(badv, zero, _CMP_NEQ_UQ)) != 0;
#endif
  for (; i < e; i++) {
    float g = G[i];
    float m = b1 * M[i] + ob1 * g;
    float v = b2 * V[i] + ob2 * g * g;
    M[i] = m; V[i] = v;
    float p = P[i] - ss * m / (sqrtf(v) * isb + eps);
    P[i] = p;
    bad |= !isfinite(p) || !isfinite(g);
  }
  return bad;
}

static void step_units(void *vc, size_t ub, size_t ue) {
  step_ctx *c = vc;
  int bad = 0;
  for (size_t u = ub; u < ue; u++) {
    int k = c->n_grp - 1;
    while (k > 0 && c->grp[k].unit0 > u) k--;
    const mgs_adam_group *gp = &c->grp[k];
    size_t b = (u - gp->unit0) * gp->per_unit, e = b + gp->per_unit;
    if (e > gp->n_elem) e = gp->n_elem;
    int ub_bad = 0;
    if (gp->used == gp->row) {
      ub_bad = mgs_adam_span(gp, b, e);
      if (c->zero_grad && !ub_bad) memset(gp->g + b, 0, (e - b) * sizeof(float));
    } else { /* b, e count rows */
      for (size_t r = b; r < e; r++) ub_bad |= mgs_adam_span(gp, r * gp->row, r * gp->row + gp->used);
      if (c->zero_grad && !ub_bad)
        for (size_t r = b; r < e; r++) memset(gp->g + r * gp->row, 0, gp->used * sizeof(float));
    }
    /* a unit with a non-finite value keeps its gradients for the report */
    if (ub_bad) bad |= 1 << k;
  }
  if (bad) atomic_fetch_or(&c->bad, bad);
}

int mgs_adam_prepare(mgs_adam *a, mgs_gaussians *model, mgs_gaussians *grad, unsigned group_mask,
                     mgs_adam_group grp[MGS_PARAM_COUNT], int gid[MGS_PARAM_COUNT]) {
  int n_grp = 0;
  for (int gi = 0; gi < MGS_PARAM_COUNT; gi++) {
    if (!(group_mask & (1u << gi))) continue;
    mgs_param_group pg = (mgs_param_group)gi;
    size_t d = (size_t)mgs_param_dim(pg);
    a->t[gi]++;
    double bc1 = 1.0 - pow(a->beta1, (double)a->t[gi]);
    double bc2 = 1.0 - pow(a->beta2, (double)a->t[gi]);
    mgs_adam_group *gp = &grp[n_grp];
    memset(gp, 0, sizeof *gp);
    gp->p = mgs_gaussians_group(model, pg);
    gp->m = a->m[gi]; gp->v = a->v[gi];
    gp->g = grad ? mgs_gaussians_group(grad, pg) : NULL;
    gp->b1 = (float)a->beta1; gp->b2 = (float)a->beta2;
    gp->step_size = (float)(a->lr[gi] / bc1);
    gp->inv_sqrt_bc2 = (float)(1.0 / sqrt(bc2));
    gp->eps = (float)a->eps;
    gp->row = d;
    gp->used = d;
    if (pg == MGS_PARAM_SH_REST && a->sh_rest_active >= 0 && a->sh_rest_active < 15) gp->used = 3 * (size_t)a->sh_rest_active;
    if (pg == MGS_PARAM_SH_REST && a->sh_rest_bf16) {
      gp->packed = 1;
      gp->seed = sr_hash((uint32_t)a->t[gi] * 0x9E3779B9u);
    }
    if (gp->used == 0 || model->n == 0) continue;
    gid[n_grp++] = gi;
  }
  return n_grp;
}

mgs_status mgs_adam_step(mgs_adam *a, mgs_gaussians *model, const mgs_gaussians *grad,
                         unsigned group_mask, mgs_error *err) {
  return mgs_adam_step_zero(a, model, (mgs_gaussians *)grad, group_mask, 0, err);
}

mgs_status mgs_adam_step_zero(mgs_adam *a, mgs_gaussians *model, mgs_gaussians *grad,
                              unsigned group_mask, int zero_grad, mgs_error *err) {
  if (a->n != model->n || grad->n != model->n)
    return mgs_error_set(err, MGS_ERR_ARG, "adam: %zu moments for %zu Gaussians (%zu gradients)", a->n, model->n, grad->n);
  step_ctx c;
  memset(&c, 0, sizeof c);
  c.zero_grad = zero_grad;
  atomic_init(&c.bad, 0);
  int gid[MGS_PARAM_COUNT];
  c.n_grp = mgs_adam_prepare(a, model, grad, group_mask, c.grp, gid);
  size_t units = 0;
  for (int k = 0; k < c.n_grp; k++) {
    mgs_adam_group *gp = &c.grp[k];
    if (gp->used == gp->row) { gp->n_elem = model->n * gp->row; gp->per_unit = ADAM_UNIT; }
    else { gp->n_elem = model->n; gp->per_unit = ADAM_UNIT / gp->row; }
    gp->unit0 = units;
    units += (gp->n_elem + gp->per_unit - 1) / gp->per_unit;
  }
  if (units) mgs_parallel_for(0, units, 1, step_units, &c);
  int bad = atomic_load(&c.bad);
  for (int k = 0; k < c.n_grp && bad; k++) {
    if (!(bad & (1 << k))) continue;
    const mgs_adam_group *gp = &c.grp[k];
    mgs_param_group grp = (mgs_param_group)gid[k];
    size_t total = model->n * gp->row;
    for (size_t i = 0; i < total; i++) {
      if (i % gp->row >= gp->used) continue;
      if (!isfinite(gp->g[i])) return mgs_adam_report(grp, i / gp->row, 0, err);
      if (!isfinite(gp->p[i])) return mgs_adam_report(grp, i / gp->row, 1, err);
    }
  }
  return MGS_OK;
}

void mgs_adam_bytes(const mgs_adam *a, size_t rows, unsigned group_mask, int grad_arrays, int zero_grad,
                    double *read, double *written) {
  double fl = 0, packed = 0; /* active floats per row over the selected groups; of them packed */
  for (int gi = 0; gi < MGS_PARAM_COUNT; gi++) {
    if (!(group_mask & (1u << gi))) continue;
    int d = mgs_param_dim((mgs_param_group)gi);
    /* as mgs_adam_prepare: a partly active SH-rest group steps its first 3*active floats */
    if (gi == MGS_PARAM_SH_REST && a->sh_rest_active >= 0 && a->sh_rest_active < 15) d = 3 * a->sh_rest_active;
    fl += d;
    if (gi == MGS_PARAM_SH_REST && a->sh_rest_bf16) packed = d;
  }
  double per = (double)rows * fl * sizeof(float);
  /* p, m, v (+ g); packed SH-rest moments: one 4-byte word for m and v */
  *read = 3 * per - (double)rows * packed * sizeof(float) + (grad_arrays ? per : 0);
  *written = 3 * per - (double)rows * packed * sizeof(float) + (grad_arrays && zero_grad ? per : 0);
}

mgs_status mgs_adam_report(mgs_param_group group, size_t gaussian, int value, mgs_error *err) {
  if (!value)
    return mgs_error_set(err, MGS_ERR_NUMERIC, "non-finite gradient in parameter group '%s' (Gaussian %zu)",
                         mgs_param_name(group), gaussian);
  return mgs_error_set(err, MGS_ERR_NUMERIC, "non-finite value in parameter group '%s' (Gaussian %zu) after the Adam step",
                       mgs_param_name(group), gaussian);
}

double mgs_expon_lr(int64_t step, double lr_init, double lr_final, int64_t max_steps) {
  if (step < 0 || (lr_init == 0.0 && lr_final == 0.0)) return 0.0;
  double t = max_steps > 0 ? (double)step / (double)max_steps : 1.0;
  if (t > 1) t = 1;
  return exp(log(lr_init) * (1 - t) + log(lr_final) * t);
}

mgs_status mgs_model_append(mgs_gaussians *g, mgs_adam *a, size_t count, size_t *first, mgs_error *err) {
  mgs_status st = mgs_gaussians_append(g, count, first, err);
  if (st != MGS_OK) return st;
  if (a) {
    st = mgs_adam_append(a, count, err);
    if (st != MGS_OK) { g->n -= count; return st; }
  }
  return MGS_OK;
}

size_t mgs_model_compact(mgs_gaussians *g, mgs_adam *a, const uint8_t *keep) {
  if (a) mgs_adam_compact(a, keep);
  return mgs_gaussians_compact(g, keep);
}
