/* SSIM of the reference 3DGS (11x11 Gaussian window, sigma 1.5, zero padding as torch's
 * conv2d with padding 5, C1 = 0.01^2, C2 = 0.03^2, mean over pixels and channels) with
 * its analytic gradient.
 *
 * With mu1 = G*x, mu2 = G*y, e11 = G*x^2, e12 = G*xy, e22 = G*y^2 and
 * S = (2 mu1 mu2 + C1)(2 s12 + C2) / ((mu1^2 + mu2^2 + C1)(s11 + s22 + C2)),
 * s11 = e11 - mu1^2, s12 = e12 - mu1 mu2, the gradient is
 *   dSSIM/dx = G*(dS/dmu1) + 2x G*(dS/de11) + y G*(dS/de12), divided by the sample count,
 * because the adjoint of a zero-padded 'same' convolution with a symmetric kernel is
 * the same convolution. The 2D window is separable: every blur is two 1D passes written
 * as contiguous loops the compiler vectorizes; the 5 (forward) and 3 (backward) blurs per
 * channel run in parallel. Per-pixel arithmetic is float, as torch's float32 reference;
 * sums are accumulated in double. Scratch memory is kept between calls. */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include "render/mgs_loss.h"
#include "core/mgs_parallel.h"
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

#define WIN 11
#define HALF 5
#define MAXC 4
static const float C1 = 0.01f * 0.01f, C2 = 0.03f * 0.03f;

/* scratch kept between calls (reachable, so not a leak); a concurrent caller allocates */
static char *g_cache;
static size_t g_cache_len;
static atomic_flag g_cache_busy = ATOMIC_FLAG_INIT;

typedef struct {
  const float *img, *gt;
  int W, H, C;
  float k[WIN];
  float *field;   /* C*5 planes: mu1 mu2 e11 e22 e12 */
  float *tmp;     /* C*5 planes of horizontal-pass scratch */
  float *pad;     /* C*5 rows of W + 2*HALF */
  double *rowsum; /* C*H */
  float *grad;
  float scale;
} ssim_ctx;

static float src_value(const ssim_ctx *c, int ch, int f, size_t i) {
  float x = c->img[i * c->C + ch], y = c->gt[i * c->C + ch];
  switch (f) {
    case 0: return x;
    case 1: return y;
    case 2: return x * x;
    case 3: return y * y;
    default: return x * y;
  }
}

/* One output row of the horizontal pass: o[x] = sum_t k[t] p[x + t], p padded. */
static void hpass_row(const float *p, float *o, int W, const float k[WIN]) {
  int x = 0;
#if defined(__AVX2__) && defined(__FMA__)
  __m256 kk[WIN];
  for (int t = 0; t < WIN; t++) kk[t] = _mm256_set1_ps(k[t]);
  for (; x + 8 <= W; x += 8) {
    __m256 acc = _mm256_mul_ps(kk[0], _mm256_loadu_ps(p + x));
    for (int t = 1; t < WIN; t++) acc = _mm256_fmadd_ps(kk[t], _mm256_loadu_ps(p + x + t), acc);
    _mm256_storeu_ps(o + x, acc);
  }
#endif
  for (; x < W; x++) {
    float a = 0;
    for (int t = 0; t < WIN; t++) a += k[t] * p[x + t];
    o[x] = a;
  }
}

/* One output row of the vertical pass over rows r[a..b] (the valid taps). */
static void vpass_row(const float *tmp, size_t W, int y, int a, int b, float *o, const float k[WIN]) {
  size_t x = 0;
  const float *base = tmp + (size_t)(y - HALF) * W;
#if defined(__AVX2__) && defined(__FMA__)
  for (; x + 8 <= W; x += 8) {
    __m256 acc = _mm256_mul_ps(_mm256_set1_ps(k[a]), _mm256_loadu_ps(base + (size_t)a * W + x));
    for (int t = a + 1; t <= b; t++) acc = _mm256_fmadd_ps(_mm256_set1_ps(k[t]), _mm256_loadu_ps(base + (size_t)t * W + x), acc);
    _mm256_storeu_ps(o + x, acc);
  }
#endif
  for (; x < W; x++) {
    float acc = 0;
    for (int t = a; t <= b; t++) acc += k[t] * base[(size_t)t * W + x];
    o[x] = acc;
  }
}

/* out = G * in (zero padding); the input plane is plane_in, or (NULL) the field f of
 * channel ch computed from the images; pad: one row of W + 2*HALF. */
static void blur_plane(const ssim_ctx *c, int ch, int f, const float *plane_in, float *out, float *tmp, float *pad) {
  const int W = c->W, H = c->H;
  for (int t = 0; t < HALF; t++) { pad[t] = 0; pad[W + HALF + t] = 0; }
  for (int y = 0; y < H; y++) {
    float *p = pad + HALF;
    if (plane_in) memcpy(p, plane_in + (size_t)y * W, (size_t)W * sizeof(float));
    else
      for (int x = 0; x < W; x++) p[x] = src_value(c, ch, f, (size_t)y * W + x);
    hpass_row(pad, tmp + (size_t)y * W, W, c->k);
  }
  for (int y = 0; y < H; y++) {
    int a = y - HALF < 0 ? HALF - y : 0, b = y + HALF >= H ? HALF + (H - 1 - y) : 2 * HALF;
    vpass_row(tmp, (size_t)W, y, a, b, out + (size_t)y * W, c->k);
  }
}

static size_t plane(const ssim_ctx *c) { return (size_t)c->W * c->H; }

static void fwd_blurs(void *vc, size_t b, size_t e) {
  ssim_ctx *c = vc;
  for (size_t task = b; task < e; task++) {
    int ch = (int)(task / 5), f = (int)(task % 5);
    blur_plane(c, ch, f, NULL, c->field + task * plane(c), c->tmp + task * plane(c), c->pad + task * (size_t)(c->W + 2 * HALF));
  }
}

/* S per pixel; with a gradient, the partials overwrite mu1 (dS/dmu1), e11 (dS/de11),
 * e12 (dS/de12) */
static void pixel_rows(void *vc, size_t b, size_t e) {
  ssim_ctx *c = vc;
  const int W = c->W;
  for (size_t row = b; row < e; row++) {
    int ch = (int)(row / (size_t)c->H), y = (int)(row % (size_t)c->H);
    size_t off = (size_t)y * W;
    float *f = c->field + (size_t)ch * 5 * plane(c);
    float *mu1 = f + off, *mu2 = f + plane(c) + off, *e11 = f + 2 * plane(c) + off, *e22 = f + 3 * plane(c) + off,
          *e12 = f + 4 * plane(c) + off;
    double sum = 0;
    for (int x = 0; x < W; x++) {
      float m1 = mu1[x], m2 = mu2[x];
      float s11 = e11[x] - m1 * m1, s22 = e22[x] - m2 * m2, s12 = e12[x] - m1 * m2;
      float A1 = 2 * m1 * m2 + C1, A2 = 2 * s12 + C2;
      float B1 = m1 * m1 + m2 * m2 + C1, B2 = s11 + s22 + C2;
      float inv = 1.0f / (B1 * B2);
      float S = A1 * A2 * inv;
      sum += S;
      if (c->grad) {
        mu1[x] = 2 * m2 * (A2 - A1) * inv - 2 * m1 * S * (1 / B1 - 1 / B2);
        e11[x] = -S / B2;
        e12[x] = 2 * A1 * inv;
      }
    }
    c->rowsum[row] = sum;
  }
}

/* Per channel, after pixel_rows: field slots 0, 2, 4 hold dS/dmu1, dS/de11, dS/de12 and
 * slots 1, 3 are free. Their blurs run in parallel with disjoint buffers:
 *   dS/dmu1: field 0 -> field 1 (scratch tmp 0);  dS/de11: field 2 -> field 3 (tmp 2);
 *   dS/de12: field 4 -> tmp 1 (scratch tmp 4). */
static void back_blurs(void *vc, size_t b, size_t e) {
  ssim_ctx *c = vc;
  static const int in_slot[3] = {0, 2, 4};
  for (size_t task = b; task < e; task++) {
    size_t ch = task / 3, k = task % 3, base = ch * 5;
    size_t in = base + (size_t)in_slot[k];
    float *out = k == 0 ? c->field + (base + 1) * plane(c) : k == 1 ? c->field + (base + 3) * plane(c) : c->tmp + (base + 1) * plane(c);
    blur_plane(c, (int)ch, in_slot[k], c->field + in * plane(c), out, c->tmp + in * plane(c), c->pad + in * (size_t)(c->W + 2 * HALF));
  }
}

static void grad_rows(void *vc, size_t b, size_t e) {
  ssim_ctx *c = vc;
  const int W = c->W, C = c->C;
  for (size_t row = b; row < e; row++) {
    int ch = (int)(row / (size_t)c->H), y = (int)(row % (size_t)c->H);
    size_t off = (size_t)y * W;
    const float *g1 = c->field + ((size_t)ch * 5 + 1) * plane(c) + off;  /* G*dS/dmu1 */
    const float *g11 = c->field + ((size_t)ch * 5 + 3) * plane(c) + off; /* G*dS/de11 */
    const float *g12 = c->tmp + ((size_t)ch * 5 + 1) * plane(c) + off;   /* G*dS/de12 */
    for (int x = 0; x < W; x++) {
      size_t i = (off + (size_t)x) * C + ch;
      c->grad[i] += c->scale * (g1[x] + 2 * c->img[i] * g11[x] + c->gt[i] * g12[x]);
    }
  }
}

double mgs_ssim(const float *img, const float *gt, int width, int height, int channels, float w, float *grad) {
  if (width <= 0 || height <= 0 || channels <= 0) return 1.0;
  if (channels > MAXC) return NAN;
  ssim_ctx c;
  memset(&c, 0, sizeof c);
  c.img = img; c.gt = gt; c.W = width; c.H = height; c.C = channels; c.grad = grad;
  c.scale = w / (float)((size_t)width * height * channels);
  double g[WIN], s = 0;
  for (int i = 0; i < WIN; i++) { double d = i - HALF; g[i] = exp(-d * d / (2 * 1.5 * 1.5)); s += g[i]; }
  for (int i = 0; i < WIN; i++) c.k[i] = (float)(g[i] / s);
  size_t np = plane(&c), nf = (size_t)channels * 5, rows = (size_t)channels * height;
  /* rows doubles first (alignment), then 2*nf planes and nf padded rows of floats */
  size_t need = rows * sizeof(double) + (2 * nf * np + nf * (size_t)(width + 2 * HALF)) * sizeof(float);
  int own = 0;
  char *buf = NULL;
  if (!atomic_flag_test_and_set(&g_cache_busy)) {
    if (g_cache_len < need) {
      free(g_cache);
      g_cache = malloc(need);
      g_cache_len = g_cache ? need : 0;
    }
    buf = g_cache;
    if (!buf) atomic_flag_clear(&g_cache_busy);
  } else {
    buf = malloc(need);
    own = 1;
  }
  if (!buf) return NAN;
  c.rowsum = (double *)(void *)buf;
  c.field = (float *)(void *)(buf + rows * sizeof(double));
  c.tmp = c.field + nf * np;
  c.pad = c.tmp + nf * np;
  mgs_parallel_for(0, nf, 1, fwd_blurs, &c);
  mgs_parallel_for(0, rows, 16, pixel_rows, &c);
  double sum = 0;
  for (size_t r = 0; r < rows; r++) sum += c.rowsum[r];
  if (grad) {
    mgs_parallel_for(0, (size_t)channels * 3, 1, back_blurs, &c);
    mgs_parallel_for(0, rows, 16, grad_rows, &c);
  }
  if (own) free(buf);
  else atomic_flag_clear(&g_cache_busy);
  return sum / ((double)np * channels);
}

/* Per channel, in planes of width x height floats: the 5 forward blurs read their source
 * (x, y, x^2, y^2: one image each, xy: both; 6 planes), write and read back the horizontal
 * pass (5 + 5) and write the fields (5); pixel_rows reads 5 and writes 3; the 3 backward
 * blurs each read a plane, write and read the horizontal pass, write the result (6 + 6);
 * grad_rows reads 3 planes, img, gt and grad and writes grad (6 + 1). */
void mgs_ssim_bytes(int width, int height, int channels, double rw[2]) {
  double p = (double)width * height * sizeof(float), rows = (double)channels * height * sizeof(double);
  rw[0] = channels * (6 + 5 + 5 + 6 + 6) * p + rows;
  rw[1] = channels * (5 + 5 + 3 + 6 + 1) * p + rows;
}
