/* Surface points from the train views' silhouettes: the visual hull (train/mgs_init_levelset.h,
 * mgs_init_points_from_views). Without alpha, train/init_warmup.c. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_core.h"
#include "core/mgs_dataset.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"
#include "train/init_views.h"
#include "train/mgs_init_levelset.h"

#define ALPHA_IN 0.5f
#define MAX_EXITS 8 /* per boundary segment: the smallest silhouette exits kept (miss tolerance) */

void mgs_view_points_options_default(mgs_view_points_options *o) {
  o->resolution = 128;
  o->coarse = 64;
  o->min_views = 3;
  o->min_seen = 0.5;
  o->miss_fraction = 0.02;
  o->max_points = 10000;
  o->warmup_iterations = 500;
  o->warmup_points = 100000;
  o->warmup_opacity = 0.5;
  o->image_cache_mb = 0;
  o->seed = 0;
}

/* ---------------------------------------------------------------- one view's images */
mgs_status mgs_view_images_open(mgs_dataset *ds, mgs_view *v, mgs_view_images *vi, mgs_error *err) {
  memset(vi, 0, sizeof *vi);
  if (v->image) {
    vi->rgb = v->image;
    vi->alpha = v->alpha;
    return MGS_OK;
  }
  /* a copy of the view decodes into its own fields: the dataset stays as it was (the image
     cache, created later, expects unloaded views) */
  vi->tmp = *v;
  vi->tmp.image = vi->tmp.alpha = NULL;
  mgs_status st = mgs_dataset_load_image(ds, &vi->tmp, err);
  if (st) return st;
  vi->owned = 1;
  vi->rgb = vi->tmp.image;
  vi->alpha = vi->tmp.alpha;
  return MGS_OK;
}

void mgs_view_images_close(mgs_view_images *vi) {
  if (vi->owned) {
    mgs_image_destroy(vi->tmp.image);
    mgs_image_destroy(vi->tmp.alpha);
  }
  memset(vi, 0, sizeof *vi);
}

/* ---------------------------------------------------------------- grid and projection */
typedef struct grid {
  double lo[3], h;
  int64_t dim[3];
} grid;

static size_t gidx(const grid *g, int64_t x, int64_t y, int64_t z) { return ((size_t)z * (size_t)g->dim[1] + (size_t)y) * (size_t)g->dim[0] + (size_t)x; }
static size_t gcount(const grid *g) { return (size_t)g->dim[0] * (size_t)g->dim[1] * (size_t)g->dim[2]; }
static void gcentre(const grid *g, size_t i, double p[3]) {
  const size_t nx = (size_t)g->dim[0], ny = (size_t)g->dim[1];
  p[0] = g->lo[0] + ((double)(i % nx) + 0.5) * g->h;
  p[1] = g->lo[1] + ((double)(i / nx % ny) + 0.5) * g->h;
  p[2] = g->lo[2] + ((double)(i / nx / ny) + 0.5) * g->h;
}

/* pixel (u, v) of p; 0 behind the camera or outside the image */
static int project(const mgs_camera *c, const double p[3], double *u, double *v, double *z) {
  const double *m = c->w2c;
  const double x = m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3];
  const double y = m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7];
  *z = m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11];
  if (!(*z > c->znear)) return 0;
  *u = c->fx * x / *z + c->cx;
  *v = c->fy * y / *z + c->cy;
  return *u >= 0 && *v >= 0 && *u < c->width && *v < c->height;
}

/* bilinear sample of channel ch at continuous pixel (u, v) (centres at +0.5) */
static float sample(const mgs_image *im, int ch, double u, double v) {
  double x = u - 0.5, y = v - 0.5;
  x = x < 0 ? 0 : x > im->width - 1 ? im->width - 1 : x;
  y = y < 0 ? 0 : y > im->height - 1 ? im->height - 1 : y;
  const int x0 = (int)x, y0 = (int)y, x1 = x0 + 1 < im->width ? x0 + 1 : x0, y1 = y0 + 1 < im->height ? y0 + 1 : y0;
  const float fx = (float)(x - x0), fy = (float)(y - y0);
  const int C = im->channels;
  const float *d = im->data;
  const float a = d[((size_t)y0 * im->width + x0) * C + ch], b = d[((size_t)y0 * im->width + x1) * C + ch];
  const float c = d[((size_t)y1 * im->width + x0) * C + ch], e = d[((size_t)y1 * im->width + x1) * C + ch];
  return (a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + e * fx) * fy;
}

/* ---------------------------------------------------------------- carving */
/* One view's vote on every voxel still alive. Coarse pass (sat != NULL): conservative, in
   if any silhouette pixel lies in the voxel's projected bounding square (a coarse voxel
   must not lose a thin part); fine pass: the voxel centre's bilinear alpha. */
typedef struct carve_job {
  const grid *g;
  const mgs_camera *cam;
  const mgs_image *alpha;
  const uint32_t *sat; /* (w+1)*(h+1) summed-area table of alpha >= 0.5, or NULL */
  uint16_t *seen, *miss;
  uint16_t max_miss;   /* a voxel past this many misses is dead: skipped */
} carve_job;

static void carve_range(void *ctx, size_t b, size_t e) {
  const carve_job *j = ctx;
  const mgs_camera *c = j->cam;
  const double half_diag = 0.87 * j->g->h, f = c->fx > c->fy ? c->fx : c->fy;
  const int W = c->width, H = c->height;
  for (size_t i = b; i < e; i++) {
    if (j->miss[i] > j->max_miss) continue;
    double p[3], u, v, z;
    gcentre(j->g, i, p);
    if (!project(c, p, &u, &v, &z)) continue;
    j->seen[i]++;
    int in;
    if (j->sat) {
      const double r = half_diag * f / z;
      int x0 = (int)floor(u - r), x1 = (int)floor(u + r) + 1, y0 = (int)floor(v - r), y1 = (int)floor(v + r) + 1;
      x0 = x0 < 0 ? 0 : x0, y0 = y0 < 0 ? 0 : y0, x1 = x1 > W ? W : x1, y1 = y1 > H ? H : y1;
      const uint32_t *s = j->sat;
      const size_t w1 = (size_t)W + 1;
      in = s[(size_t)y1 * w1 + x1] - s[(size_t)y0 * w1 + x1] - s[(size_t)y1 * w1 + x0] + s[(size_t)y0 * w1 + x0] > 0;
    } else {
      in = sample(j->alpha, 0, u, v) >= ALPHA_IN;
    }
    if (!in) j->miss[i]++;
  }
}

static int keep_voxel(uint16_t seen, uint16_t miss, int min_views, double frac) {
  return seen >= min_views && miss <= (uint16_t)floor(frac * seen);
}

/* Carves grid g with every train view; keep[i] = 1 for survivors. */
static mgs_status carve(mgs_dataset *ds, const grid *g, int conservative, int min_views, double frac, uint8_t *keep,
                        mgs_error *err) {
  const size_t n = gcount(g), nv = ds->n_views[MGS_SPLIT_TRAIN];
  uint16_t *seen = calloc(n, sizeof *seen), *miss = calloc(n, sizeof *miss);
  uint32_t *sat = NULL;
  mgs_status st = MGS_OK;
  if (!seen || !miss) st = mgs_error_set(err, MGS_ERR_NOMEM, "visual hull: out of memory for %zu voxels", n);
  const uint16_t max_miss = (uint16_t)(frac * (double)nv < 65535 ? floor(frac * (double)nv) : 65535);
  for (size_t k = 0; k < nv && !st; k++) {
    mgs_view *v = &ds->views[MGS_SPLIT_TRAIN][k];
    mgs_view_images vi;
    if ((st = mgs_view_images_open(ds, v, &vi, err))) break;
    if (vi.alpha) {
      const int W = vi.alpha->width, H = vi.alpha->height;
      if (conservative) {
        uint32_t *s2 = realloc(sat, (size_t)(W + 1) * (size_t)(H + 1) * sizeof *sat);
        if (!s2) {
          mgs_view_images_close(&vi);
          st = mgs_error_set(err, MGS_ERR_NOMEM, "visual hull: out of memory for a %dx%d mask", W, H);
          break;
        }
        sat = s2;
        memset(sat, 0, (size_t)(W + 1) * sizeof *sat);
        for (int y = 0; y < H; y++) {
          uint32_t row = 0;
          sat[(size_t)(y + 1) * (W + 1)] = 0;
          for (int x = 0; x < W; x++) {
            row += vi.alpha->data[(size_t)y * W + x] >= ALPHA_IN;
            sat[(size_t)(y + 1) * (W + 1) + x + 1] = sat[(size_t)y * (W + 1) + x + 1] + row;
          }
        }
      }
      carve_job j = {g, &v->cam, vi.alpha, conservative ? sat : NULL, seen, miss, max_miss};
      mgs_parallel_for(0, n, 4096, carve_range, &j);
    }
    mgs_view_images_close(&vi);
  }
  if (!st)
    for (size_t i = 0; i < n; i++) keep[i] = (uint8_t)keep_voxel(seen[i], miss[i], min_views, frac);
  free(seen), free(miss), free(sat);
  return st;
}

/* ---------------------------------------------------------------- boundary points */
typedef struct seg {
  double a[3], b[3];    /* inside voxel centre, outside neighbour centre */
  float n[3];           /* outward normal (occupancy gradient) */
  uint16_t seen;        /* views that see a */
  uint8_t nexit;        /* exits kept (sorted) */
  float exit[MAX_EXITS];
} seg;

/* Where, along a -> b, this view's silhouette ends: first alpha < 0.5 sampled every 1/4
   pixel, linearly interpolated; 1 if it never ends, -1 if the view does not see a. */
static double seg_exit(const mgs_camera *c, const mgs_image *alpha, const seg *s) {
  double ua, va, za, ub, vb, zb;
  if (!project(c, s->a, &ua, &va, &za)) return -1;
  if (!project(c, s->b, &ub, &vb, &zb)) return 1; /* b off the image: no evidence past a */
  const double len = hypot(ub - ua, vb - va);
  const int steps = (int)ceil(len * 4) + 1;
  float prev = sample(alpha, 0, ua, va) - ALPHA_IN;
  if (prev < 0) return 0;
  for (int k = 1; k <= steps; k++) {
    const double t = (double)k / steps;
    /* perspective-correct: interpolate the 3D point, project it */
    double p[3], u, v, z;
    for (int a = 0; a < 3; a++) p[a] = s->a[a] + t * (s->b[a] - s->a[a]);
    if (!project(c, p, &u, &v, &z)) return 1;
    const float cur = sample(alpha, 0, u, v) - ALPHA_IN;
    if (cur < 0) return (k - 1 + prev / (prev - cur)) / steps;
    prev = cur;
  }
  return 1;
}

typedef struct exit_job {
  const mgs_camera *cam;
  const mgs_image *alpha;
  seg *s;
} exit_job;

static void exit_range(void *ctx, size_t b, size_t e) {
  const exit_job *j = ctx;
  for (size_t i = b; i < e; i++) {
    seg *s = &j->s[i];
    const double t = seg_exit(j->cam, j->alpha, s);
    if (t < 0 || t >= 1) continue;
    /* insert into the sorted list of the smallest exits */
    int k;
    if (s->nexit < MAX_EXITS) k = s->nexit++;
    else if (t < s->exit[MAX_EXITS - 1]) k = MAX_EXITS - 1;
    else continue;
    while (k > 0 && s->exit[k - 1] > t) { s->exit[k] = s->exit[k - 1]; k--; }
    s->exit[k] = (float)t;
  }
}

/* Colour: cosine-weighted mean over views that see the point with no hull voxel between. */
typedef struct colour_job {
  const grid *g;
  const uint8_t *keep;
  const mgs_camera *cam;
  const mgs_image *rgb;
  const seg *s;
  const float *xyz;
  double *acc; /* n*4: rgb sums and weight */
} colour_job;

static int occluded(const grid *g, const uint8_t *keep, const double p0[3], const double cam[3]) {
  double d[3], len = 0;
  for (int a = 0; a < 3; a++) d[a] = cam[a] - p0[a], len += d[a] * d[a];
  len = sqrt(len);
  const double step = 0.5 * g->h;
  for (double t = step; t < len; t += step) {
    int64_t c[3];
    for (int a = 0; a < 3; a++) {
      c[a] = (int64_t)floor((p0[a] + d[a] * t / len - g->lo[a]) / g->h);
      if (c[a] < 0 || c[a] >= g->dim[a]) return 0; /* left the grid: nothing more to hit */
    }
    if (keep[gidx(g, c[0], c[1], c[2])]) return 1;
  }
  return 0;
}

static void colour_range(void *ctx, size_t b, size_t e) {
  const colour_job *j = ctx;
  double cc[3];
  mgs_camera_center(j->cam, cc);
  for (size_t i = b; i < e; i++) {
    double p[3], d[3], len = 0, cosv = 0, u, v, z;
    for (int a = 0; a < 3; a++) p[a] = j->xyz[3 * i + a], d[a] = cc[a] - p[a], len += d[a] * d[a];
    len = sqrt(len);
    for (int a = 0; a < 3; a++) cosv += j->s[i].n[a] * d[a] / len;
    if (cosv < 0.2 || !project(j->cam, p, &u, &v, &z)) continue;
    /* start a voxel out along the normal: the point's own voxel is in the hull */
    double q[3];
    for (int a = 0; a < 3; a++) q[a] = p[a] + 1.01 * j->g->h * j->s[i].n[a];
    if (occluded(j->g, j->keep, q, cc)) continue;
    for (int c = 0; c < 3; c++) j->acc[4 * i + c] += cosv * sample(j->rgb, c, u, v);
    j->acc[4 * i + 3] += cosv;
  }
}

/* ---------------------------------------------------------------- the hull */
static mgs_status hull_points(mgs_dataset *ds, const mgs_view_points_options *o, float **xyz_out, float **rgb_out,
                              size_t *n_out, mgs_view_points_info *info, mgs_error *err) {
  const size_t nv = ds->n_views[MGS_SPLIT_TRAIN];
  int min_views = (int)ceil(o->min_seen * (double)nv);
  if (min_views < o->min_views) min_views = o->min_views;
  if (min_views > (int)nv) min_views = (int)nv;
  /* coarse: a cube over the cameras' sphere (an object they all look at lies inside) */
  double r = ds->extent / 1.1;
  if (!(r > 0)) r = 1;
  grid gc = {{ds->center[0] - r, ds->center[1] - r, ds->center[2] - r}, 2 * r / o->coarse, {o->coarse, o->coarse, o->coarse}};
  uint8_t *kc = malloc(gcount(&gc));
  if (!kc) return mgs_error_set(err, MGS_ERR_NOMEM, "visual hull: out of memory");
  mgs_status st = carve(ds, &gc, 1, min_views, o->miss_fraction, kc, err);
  double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
  size_t nkc = 0;
  for (size_t i = 0; !st && i < gcount(&gc); i++)
    if (kc[i]) {
      double p[3];
      gcentre(&gc, i, p);
      nkc++;
      for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], p[a] - gc.h), hi[a] = fmax(hi[a], p[a] + gc.h);
    }
  free(kc);
  if (st) return st;
  if (!nkc)
    return mgs_error_set(err, MGS_ERR_ARG, "%s: the train views' silhouettes (alpha >= 0.5) share no volume: no visual hull",
                         ds->root);
  /* fine: over the coarse survivors, one coarse voxel of margin */
  double side = 0;
  for (int a = 0; a < 3; a++) side = fmax(side, hi[a] - lo[a]);
  grid g = {{lo[0], lo[1], lo[2]}, side / o->resolution, {0, 0, 0}};
  for (int a = 0; a < 3; a++) g.dim[a] = (int64_t)ceil((hi[a] - lo[a]) / g.h) + 2, g.lo[a] -= g.h;
  const size_t n = gcount(&g);
  uint8_t *keep = malloc(n);
  if (!keep) return mgs_error_set(err, MGS_ERR_NOMEM, "visual hull: out of memory for %zu voxels", n);
  if ((st = carve(ds, &g, 0, min_views, o->miss_fraction, keep, err))) {
    free(keep);
    return st;
  }
  size_t kept = 0, faces = 0;
  static const int F[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int64_t z = 0; z < g.dim[2]; z++)
    for (int64_t y = 0; y < g.dim[1]; y++)
      for (int64_t x = 0; x < g.dim[0]; x++) {
        if (!keep[gidx(&g, x, y, z)]) continue;
        kept++;
        for (int f = 0; f < 6; f++) {
          const int64_t q[3] = {x + F[f][0], y + F[f][1], z + F[f][2]};
          if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= g.dim[0] || q[1] >= g.dim[1] || q[2] >= g.dim[2] ||
              !keep[gidx(&g, q[0], q[1], q[2])])
            faces++;
        }
      }
  if (!faces) {
    free(keep);
    return mgs_error_set(err, MGS_ERR_ARG, "%s: the visual hull is empty at voxel %.4g", ds->root, g.h);
  }
  /* subsample the boundary faces to max_points (reservoir over the face order: seeded) */
  const size_t m = o->max_points && o->max_points < faces ? o->max_points : faces;
  size_t *pick = malloc(m * sizeof *pick);
  seg *s = calloc(m, sizeof *s);
  float *xyz = malloc(m * 3 * sizeof *xyz), *rgb = malloc(m * 3 * sizeof *rgb);
  double *acc = calloc(m * 4, sizeof *acc);
  if (!pick || !s || !xyz || !rgb || !acc) {
    st = mgs_error_set(err, MGS_ERR_NOMEM, "visual hull: out of memory for %zu points", m);
    goto done;
  }
  {
    mgs_rng rng;
    mgs_rng_init(&rng, o->seed, 0x68756c6cu);
    size_t k = 0;
    for (int64_t z = 0; z < g.dim[2]; z++)
      for (int64_t y = 0; y < g.dim[1]; y++)
        for (int64_t x = 0; x < g.dim[0]; x++) {
          if (!keep[gidx(&g, x, y, z)]) continue;
          for (int f = 0; f < 6; f++) {
            const int64_t q[3] = {x + F[f][0], y + F[f][1], z + F[f][2]};
            if (q[0] >= 0 && q[1] >= 0 && q[2] >= 0 && q[0] < g.dim[0] && q[1] < g.dim[1] && q[2] < g.dim[2] &&
                keep[gidx(&g, q[0], q[1], q[2])])
              continue;
            const size_t code = gidx(&g, x, y, z) * 6 + (size_t)f;
            if (k < m) pick[k] = code;
            else {
              const size_t j = (size_t)(mgs_rng_uniform(&rng) * (double)(k + 1));
              if (j < m) pick[j] = code;
            }
            k++;
          }
        }
  }
  for (size_t i = 0; i < m; i++) {
    const size_t vox = pick[i] / 6;
    const int f = (int)(pick[i] % 6);
    gcentre(&g, vox, s[i].a);
    for (int a = 0; a < 3; a++) s[i].b[a] = s[i].a[a] + F[f][a] * g.h;
    /* outward normal: the 26-neighbourhood's empty voxels, summed by offset */
    const int64_t cx = (int64_t)(vox % (size_t)g.dim[0]), cy = (int64_t)(vox / (size_t)g.dim[0] % (size_t)g.dim[1]),
                  cz = (int64_t)(vox / (size_t)g.dim[0] / (size_t)g.dim[1]);
    double nn[3] = {0, 0, 0};
    for (int dz = -1; dz <= 1; dz++)
      for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
          const int64_t q[3] = {cx + dx, cy + dy, cz + dz};
          const int out = q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= g.dim[0] || q[1] >= g.dim[1] || q[2] >= g.dim[2] ||
                          !keep[gidx(&g, q[0], q[1], q[2])];
          if (out) nn[0] += dx, nn[1] += dy, nn[2] += dz;
        }
    double l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    if (!(l > 0)) nn[0] = F[f][0], nn[1] = F[f][1], nn[2] = F[f][2], l = 1;
    for (int a = 0; a < 3; a++) s[i].n[a] = (float)(nn[a] / l);
  }
  /* per view: where the segment leaves its silhouette */
  for (size_t k = 0; k < nv && !st; k++) {
    mgs_view *v = &ds->views[MGS_SPLIT_TRAIN][k];
    mgs_view_images vi;
    if ((st = mgs_view_images_open(ds, v, &vi, err))) break;
    if (vi.alpha) {
      exit_job j = {&v->cam, vi.alpha, s};
      mgs_parallel_for(0, m, 256, exit_range, &j);
      for (size_t i = 0; i < m; i++) {
        double u, vv, zz;
        if (project(&v->cam, s[i].a, &u, &vv, &zz)) s[i].seen++;
      }
    }
    mgs_view_images_close(&vi);
  }
  if (st) goto done;
  /* the hull's surface on the segment: the exit past the allowed misses (else the midpoint:
     the fine carving put b outside by a sample the refinement does not see) */
  for (size_t i = 0; i < m; i++) {
    const size_t allowed = (size_t)floor(o->miss_fraction * s[i].seen);
    const double t = allowed < s[i].nexit ? s[i].exit[allowed] : 0.5;
    for (int a = 0; a < 3; a++) xyz[3 * i + a] = (float)(s[i].a[a] + t * (s[i].b[a] - s[i].a[a]));
  }
  for (size_t k = 0; k < nv && !st; k++) {
    mgs_view *v = &ds->views[MGS_SPLIT_TRAIN][k];
    mgs_view_images vi;
    if ((st = mgs_view_images_open(ds, v, &vi, err))) break;
    colour_job j = {&g, keep, &v->cam, vi.rgb, s, xyz, acc};
    mgs_parallel_for(0, m, 256, colour_range, &j);
    mgs_view_images_close(&vi);
  }
  if (st) goto done;
  for (size_t i = 0; i < m; i++)
    for (int c = 0; c < 3; c++) rgb[3 * i + c] = acc[4 * i + 3] > 0 ? (float)(acc[4 * i + c] / acc[4 * i + 3]) : 0.5f;
  if (info) info->hull_voxels = kept, info->boundary_faces = faces, info->voxel_size = g.h;
  *xyz_out = xyz, *rgb_out = rgb, *n_out = m;
  xyz = rgb = NULL;
done:
  free(keep), free(pick), free(s), free(xyz), free(rgb), free(acc);
  return st;
}

/* Does any train view carry a silhouette (alpha below 0.5 somewhere)? Checks the first
   views only: a dataset's images share their format. */
static mgs_status views_have_alpha(mgs_dataset *ds, int *yes, mgs_error *err) {
  *yes = 0;
  const size_t nv = ds->n_views[MGS_SPLIT_TRAIN];
  for (size_t k = 0; k < nv && k < 3 && !*yes; k++) {
    mgs_view_images vi;
    mgs_status st = mgs_view_images_open(ds, &ds->views[MGS_SPLIT_TRAIN][k], &vi, err);
    if (st) return st;
    if (vi.alpha) {
      const size_t np = (size_t)vi.alpha->width * vi.alpha->height;
      for (size_t i = 0; i < np; i++)
        if (vi.alpha->data[i] < ALPHA_IN) { *yes = 1; break; }
    }
    mgs_view_images_close(&vi);
  }
  return MGS_OK;
}

mgs_status mgs_init_points_from_views(mgs_dataset *ds, const mgs_view_points_options *opt, float **xyz, float **rgb,
                                      size_t *n, mgs_view_points_info *info, mgs_error *err) {
  *xyz = *rgb = NULL;
  *n = 0;
  mgs_view_points_options o;
  if (opt) o = *opt;
  else mgs_view_points_options_default(&o);
  if (o.resolution < 8 || o.resolution > 2048 || o.coarse < 8 || o.coarse > 1024 || o.min_views < 1 || !(o.min_seen >= 0 && o.min_seen <= 1) ||
      !(o.miss_fraction >= 0 && o.miss_fraction < 1))
    return mgs_error_set(err, MGS_ERR_ARG, "view points: resolution 8..2048, coarse 8..1024, min_views >= 1, min_seen in [0,1], miss_fraction in [0,1)");
  if (!ds->n_views[MGS_SPLIT_TRAIN]) return mgs_error_set(err, MGS_ERR_ARG, "%s: no train views", ds->root);
  mgs_view_points_info local;
  if (!info) info = &local;
  memset(info, 0, sizeof *info);
  info->views = ds->n_views[MGS_SPLIT_TRAIN];
  const double t0 = mgs_now();
  int alpha;
  mgs_status st = views_have_alpha(ds, &alpha, err);
  if (st) return st;
  info->from_alpha = alpha;
  st = alpha ? hull_points(ds, &o, xyz, rgb, n, info, err) : mgs_warmup_points(ds, &o, xyz, rgb, n, err);
  info->seconds = mgs_now() - t0;
  return st;
}

mgs_status mgs_init_dataset_points(mgs_dataset *ds, const mgs_view_points_options *o, mgs_error *err) {
  if (ds->init_points && ds->init_points->n > 0) return MGS_OK;
  mgs_point_cloud *pc = calloc(1, sizeof *pc);
  if (!pc) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", ds->root);
  mgs_view_points_info info;
  mgs_status st = mgs_init_points_from_views(ds, o, &pc->xyz, &pc->rgb, &pc->n, &info, err);
  if (st) {
    mgs_point_cloud_destroy(pc);
    return st;
  }
  if (info.from_alpha)
    mgs_info("%s: no initial points; %zu from the visual hull of %zu views' alpha (voxel %.4g, %zu boundary faces, %.2f s)",
             ds->root, pc->n, info.views, info.voxel_size, info.boundary_faces, info.seconds);
  else
    mgs_info("%s: no initial points and no alpha; %zu from a baseline warm-up (%.2f s)", ds->root, pc->n, info.seconds);
  mgs_point_cloud_destroy(ds->init_points);
  ds->init_points = pc;
  return MGS_OK;
}
