/* Point-to-mesh distances through Embree 3's BVH (rtcPointQuery with a closest-point-on-
 * triangle callback that shrinks the query radius), area-uniform sampling, Chamfer/F-score. */
#include "render/mgs_mesh_distance.h"
#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"

struct mgs_mesh_distance {
  RTCDevice device;
  RTCScene scene;
  size_t nv, nt;
  float *v;     /* own copies for the callback */
  uint32_t *t;
};

/* Closest point on triangle abc to p (Ericson, Real-Time Collision Detection §5.1.5). */
static void closest_on_triangle(const float p[3], const float a[3], const float b[3], const float c[3], float out[3]) {
  float ab[3], ac[3], ap[3];
  for (int k = 0; k < 3; k++) { ab[k] = b[k] - a[k]; ac[k] = c[k] - a[k]; ap[k] = p[k] - a[k]; }
  float d1 = ab[0]*ap[0] + ab[1]*ap[1] + ab[2]*ap[2], d2 = ac[0]*ap[0] + ac[1]*ap[1] + ac[2]*ap[2];
  if (d1 <= 0 && d2 <= 0) { memcpy(out, a, 3 * sizeof(float)); return; }
  float bp[3];
  for (int k = 0; k < 3; k++) bp[k] = p[k] - b[k];
  float d3 = ab[0]*bp[0] + ab[1]*bp[1] + ab[2]*bp[2], d4 = ac[0]*bp[0] + ac[1]*bp[1] + ac[2]*bp[2];
  if (d3 >= 0 && d4 <= d3) { memcpy(out, b, 3 * sizeof(float)); return; }
  float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    float w = d1 / (d1 - d3);
    for (int k = 0; k < 3; k++) out[k] = a[k] + w * ab[k];
    return;
  }
  float cp[3];
  for (int k = 0; k < 3; k++) cp[k] = p[k] - c[k];
  float d5 = ab[0]*cp[0] + ab[1]*cp[1] + ab[2]*cp[2], d6 = ac[0]*cp[0] + ac[1]*cp[1] + ac[2]*cp[2];
  if (d6 >= 0 && d5 <= d6) { memcpy(out, c, 3 * sizeof(float)); return; }
  float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    float w = d2 / (d2 - d6);
    for (int k = 0; k < 3; k++) out[k] = a[k] + w * ac[k];
    return;
  }
  float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    float w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    for (int k = 0; k < 3; k++) out[k] = b[k] + w * (c[k] - b[k]);
    return;
  }
  float denom = 1.0f / (va + vb + vc), v = vb * denom, w = vc * denom;
  for (int k = 0; k < 3; k++) out[k] = a[k] + ab[k] * v + ac[k] * w;
}

typedef struct { const mgs_mesh_distance *d; float best[3]; int found; unsigned prim; } query_state;

static bool query_cb(struct RTCPointQueryFunctionArguments *args) {
  query_state *s = (query_state *)args->userPtr;
  const mgs_mesh_distance *d = s->d;
  const uint32_t *tri = d->t + 3 * (size_t)args->primID;
  const float p[3] = {args->query->x, args->query->y, args->query->z};
  float q[3];
  closest_on_triangle(p, d->v + 3 * tri[0], d->v + 3 * tri[1], d->v + 3 * tri[2], q);
  float dist = sqrtf((q[0]-p[0])*(q[0]-p[0]) + (q[1]-p[1])*(q[1]-p[1]) + (q[2]-p[2])*(q[2]-p[2]));
  if (dist < args->query->radius) {
    args->query->radius = dist;
    memcpy(s->best, q, sizeof q);
    s->found = 1;
    s->prim = args->primID;
    return true;
  }
  return false;
}

mgs_status mgs_mesh_distance_create(const mgs_mesh *m, mgs_mesh_distance **out, mgs_error *err) {
  *out = NULL;
  if (!m || m->nv == 0 || m->nt == 0) return mgs_error_set(err, MGS_ERR_ARG, "mesh distance: empty mesh");
  for (size_t i = 0; i < 3 * m->nt; i++)
    if (m->t[i] >= m->nv) return mgs_error_set(err, MGS_ERR_FORMAT, "mesh distance: triangle index out of range");
  mgs_mesh_distance *d = calloc(1, sizeof *d);
  if (!d) return mgs_error_set(err, MGS_ERR_NOMEM, "mesh distance: out of memory");
  d->nv = m->nv;
  d->nt = m->nt;
  d->v = malloc(m->nv * 3 * sizeof(float));
  d->t = malloc(m->nt * 3 * sizeof(uint32_t));
  d->device = rtcNewDevice(NULL);
  if (!d->v || !d->t || !d->device) {
    mgs_mesh_distance_destroy(d);
    return mgs_error_set(err, MGS_ERR_NOMEM, "mesh distance: cannot create the Embree device");
  }
  memcpy(d->v, m->v, m->nv * 3 * sizeof(float));
  memcpy(d->t, m->t, m->nt * 3 * sizeof(uint32_t));
  d->scene = rtcNewScene(d->device);
  RTCGeometry geom = rtcNewGeometry(d->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m->nv);
  unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), m->nt);
  if (!vb || !ib) {
    rtcReleaseGeometry(geom);
    mgs_mesh_distance_destroy(d);
    return mgs_error_set(err, MGS_ERR_NOMEM, "mesh distance: Embree buffers for %zu triangles", m->nt);
  }
  memcpy(vb, m->v, m->nv * 3 * sizeof(float));
  memcpy(ib, m->t, m->nt * 3 * sizeof(unsigned));
  rtcCommitGeometry(geom);
  rtcAttachGeometry(d->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(d->scene);
  *out = d;
  return MGS_OK;
}

void mgs_mesh_distance_destroy(mgs_mesh_distance *d) {
  if (!d) return;
  if (d->scene) rtcReleaseScene(d->scene);
  if (d->device) rtcReleaseDevice(d->device);
  free(d->v);
  free(d->t);
  free(d);
}

typedef struct { const mgs_mesh_distance *d; const float *xyz; float *dist, *closest; int sign; } query_job;

/* The sign of p - q against the face normal of triangle prim (zero distance: +). */
static float side(const mgs_mesh_distance *d, unsigned prim, const float p[3], const float q[3]) {
  const uint32_t *tri = d->t + 3 * (size_t)prim;
  const float *a = d->v + 3 * tri[0], *b = d->v + 3 * tri[1], *c = d->v + 3 * tri[2];
  float e1[3], e2[3];
  for (int k = 0; k < 3; k++) e1[k] = b[k] - a[k], e2[k] = c[k] - a[k];
  const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  return (p[0] - q[0]) * n[0] + (p[1] - q[1]) * n[1] + (p[2] - q[2]) * n[2] < 0 ? -1.0f : 1.0f;
}

static void query_range(void *ctx, size_t b, size_t e) {
  query_job *j = ctx;
  for (size_t i = b; i < e; i++) {
    struct RTCPointQuery q;
    q.x = j->xyz[3 * i]; q.y = j->xyz[3 * i + 1]; q.z = j->xyz[3 * i + 2];
    q.time = 0;
    q.radius = INFINITY;
    struct RTCPointQueryContext ctxq;
    rtcInitPointQueryContext(&ctxq);
    query_state s = {j->d, {0, 0, 0}, 0, 0};
    rtcPointQuery(j->d->scene, &q, &ctxq, query_cb, &s);
    j->dist[i] = s.found ? q.radius : INFINITY;
    if (s.found && j->sign) j->dist[i] *= side(j->d, s.prim, j->xyz + 3 * i, s.best);
    if (j->closest) memcpy(j->closest + 3 * i, s.best, sizeof s.best);
  }
}

void mgs_mesh_distance_query(const mgs_mesh_distance *d, size_t n, const float *xyz, float *dist, float *closest) {
  query_job j = {d, xyz, dist, closest, 0};
  mgs_parallel_for(0, n, 256, query_range, &j);
}

void mgs_mesh_distance_query_signed(const mgs_mesh_distance *d, size_t n, const float *xyz, float *signed_dist) {
  query_job j = {d, xyz, signed_dist, NULL, 1};
  mgs_parallel_for(0, n, 256, query_range, &j);
}

mgs_status mgs_mesh_sample_surface(const mgs_mesh *m, size_t n, uint64_t seed, float *xyz, float *normal, mgs_error *err) {
  if (!m || m->nt == 0) return mgs_error_set(err, MGS_ERR_ARG, "surface sampling: empty mesh");
  double *cdf = malloc(m->nt * sizeof(double));
  if (!cdf) return mgs_error_set(err, MGS_ERR_NOMEM, "surface sampling: out of memory");
  double total = 0;
  for (size_t i = 0; i < m->nt; i++) {
    const float *a = m->v + 3 * m->t[3 * i], *b = m->v + 3 * m->t[3 * i + 1], *c = m->v + 3 * m->t[3 * i + 2];
    double u[3], w[3];
    for (int k = 0; k < 3; k++) { u[k] = (double)b[k] - a[k]; w[k] = (double)c[k] - a[k]; }
    double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2], cz = u[0] * w[1] - u[1] * w[0];
    double area = 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
    total += isfinite(area) ? area : 0;
    cdf[i] = total;
  }
  if (!(total > 0)) {
    free(cdf);
    return mgs_error_set(err, MGS_ERR_ARG, "surface sampling: the mesh has zero area");
  }
  mgs_rng rng;
  mgs_rng_init(&rng, seed, 17);
  for (size_t s = 0; s < n; s++) {
    double target = mgs_rng_uniform(&rng) * total;
    size_t lo = 0, hi = m->nt - 1;
    while (lo < hi) {
      size_t mid = (lo + hi) / 2;
      if (cdf[mid] <= target) lo = mid + 1; else hi = mid;
    }
    const float *a = m->v + 3 * m->t[3 * lo], *b = m->v + 3 * m->t[3 * lo + 1], *c = m->v + 3 * m->t[3 * lo + 2];
    double r1 = sqrt(mgs_rng_uniform(&rng)), r2 = mgs_rng_uniform(&rng);
    double wa = 1 - r1, wb = r1 * (1 - r2), wc = r1 * r2;
    for (int k = 0; k < 3; k++) xyz[3 * s + k] = (float)(wa * a[k] + wb * b[k] + wc * c[k]);
    if (normal) {
      double u[3], w[3];
      for (int k = 0; k < 3; k++) { u[k] = (double)b[k] - a[k]; w[k] = (double)c[k] - a[k]; }
      double nn[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      double len = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
      for (int k = 0; k < 3; k++) normal[3 * s + k] = (float)(len > 0 ? nn[k] / len : 0);
    }
  }
  free(cdf);
  return MGS_OK;
}

/* Mean distance of samples of `from` to surface `to`, and share within threshold. */
static mgs_status one_way(const mgs_mesh *from, const mgs_mesh *to, size_t n, double thr, uint64_t seed, double *mean,
                          double *within, double *offset, mgs_error *err) {
  float *pts = malloc(n * 3 * sizeof(float)), *dist = malloc(n * sizeof(float));
  mgs_mesh_distance *d = NULL;
  mgs_status st = MGS_ERR_NOMEM;
  if (!pts || !dist) { mgs_error_set(err, st, "mesh compare: out of memory"); goto done; }
  if ((st = mgs_mesh_sample_surface(from, n, seed, pts, NULL, err)) != MGS_OK) goto done;
  if ((st = mgs_mesh_distance_create(to, &d, err)) != MGS_OK) goto done;
  if (offset) {
    mgs_mesh_distance_query_signed(d, n, pts, dist);
    const double orient = mgs_mesh_signed_volume(to) < 0 ? -1.0 : 1.0;
    double s = 0;
    for (size_t i = 0; i < n; i++) s += dist[i], dist[i] = fabsf(dist[i]);
    *offset = orient * s / (double)n;
  } else {
    mgs_mesh_distance_query(d, n, pts, dist, NULL);
  }
  double sum = 0;
  size_t in = 0;
  for (size_t i = 0; i < n; i++) { sum += dist[i]; in += dist[i] <= thr; }
  *mean = sum / (double)n;
  *within = (double)in / (double)n;
done:
  mgs_mesh_distance_destroy(d);
  free(pts);
  free(dist);
  return st;
}

mgs_status mgs_mesh_compare(const mgs_mesh *pred, const mgs_mesh *gt, size_t samples, double threshold, uint64_t seed,
                            mgs_geometry_metrics *out, mgs_error *err) {
  memset(out, 0, sizeof *out);
  if (samples == 0 || !(threshold > 0)) return mgs_error_set(err, MGS_ERR_ARG, "mesh compare: samples and threshold must be positive");
  mgs_status st = one_way(pred, gt, samples, threshold, seed, &out->accuracy, &out->precision, &out->offset, err);
  if (st != MGS_OK) return st;
  st = one_way(gt, pred, samples, threshold, seed + 1, &out->completeness, &out->recall, NULL, err);
  if (st != MGS_OK) return st;
  out->chamfer = 0.5 * (out->accuracy + out->completeness);
  out->threshold = threshold;
  out->samples = samples;
  double pr = out->precision + out->recall;
  out->fscore = pr > 0 ? 2 * out->precision * out->recall / pr : 0;
  return MGS_OK;
}
