/* The Embree side of the scene maker: one triangle geometry in one scene, and the
 * per-view renderer (rows in parallel through mgs_parallel_for; each pixel casts
 * spp x spp stratified, hash-jittered rays; alpha = coverage, colour = mean of the hit
 * samples, i.e. straight alpha). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <embree3/rtcore.h>
#include "render/mgs_scene.h"
#include "render/scene_internal.h"
#include "core/mgs_parallel.h"

struct mgs_scene_renderer {
  RTCDevice device;
  RTCScene scene;
  uint32_t *tri;    /* nt*3 indices (copy) */
  float *vnormal;   /* nv*3 area-weighted vertex normals (unit) */
  uint8_t *smooth;  /* per triangle: 1 = interpolate vertex normals, 0 = flat (a crease) */
  float *uv, *rgb;  /* copies of the mesh's appearance (mgs_scene_renderer_set_appearance) */
  const mgs_texture *tex; /* borrowed */
};

/* Smooth shading hides the facets of polygonized surfaces; triangles at a crease (box
   edges, cylinder rims: a vertex normal far from the face normal) stay flat. */
static int build_normals(mgs_scene_renderer *r, const mgs_mesh *m) {
  r->tri = malloc(m->nt * 3 * sizeof *r->tri);
  r->vnormal = calloc(m->nv * 3, sizeof *r->vnormal);
  r->smooth = malloc(m->nt);
  if (!r->tri || !r->vnormal || !r->smooth) return 0;
  memcpy(r->tri, m->t, m->nt * 3 * sizeof *r->tri);
  for (size_t t = 0; t < m->nt; t++) {
    const uint32_t *ix = m->t + 3 * t;
    const float *a = m->v + 3 * ix[0], *b = m->v + 3 * ix[1], *c = m->v + 3 * ix[2];
    float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    for (int k = 0; k < 3; k++)
      for (int d = 0; d < 3; d++) r->vnormal[3 * ix[k] + d] += n[d]; /* |n| = 2 area: area weighting */
  }
  for (size_t i = 0; i < m->nv; i++) {
    float *n = r->vnormal + 3 * i, l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (l > 0) { n[0] /= l; n[1] /= l; n[2] /= l; }
  }
  const float crease_cos = 0.8f; /* about 37 degrees */
  for (size_t t = 0; t < m->nt; t++) {
    const uint32_t *ix = m->t + 3 * t;
    const float *a = m->v + 3 * ix[0], *b = m->v + 3 * ix[1], *c = m->v + 3 * ix[2];
    float e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    int ok = l > 0;
    for (int k = 0; k < 3 && ok; k++) {
      const float *vn = r->vnormal + 3 * ix[k];
      ok = (vn[0] * n[0] + vn[1] * n[1] + vn[2] * n[2]) > crease_cos * l;
    }
    r->smooth[t] = (uint8_t)ok;
  }
  return 1;
}

static void embree_error(void *user, enum RTCError code, const char *str) {
  (void)user; (void)code; (void)str; /* reported through rtcGetDeviceError below */
}

void mgs_scene_renderer_destroy(mgs_scene_renderer *r) {
  if (!r) return;
  if (r->scene) rtcReleaseScene(r->scene);
  if (r->device) rtcReleaseDevice(r->device);
  free(r->tri);
  free(r->vnormal);
  free(r->smooth);
  free(r->uv);
  free(r->rgb);
  free(r);
}

mgs_status mgs_scene_renderer_set_appearance(mgs_scene_renderer *r, const mgs_mesh *mesh, const mgs_texture *tex, mgs_error *err) {
  free(r->uv);
  free(r->rgb);
  r->uv = r->rgb = NULL;
  r->tex = NULL;
  if (!mesh) return MGS_OK;
  if (mesh->uv && tex) {
    if (!(r->uv = malloc(sizeof(float) * 6 * mesh->nt))) return mgs_error_set(err, MGS_ERR_NOMEM, "scene renderer: out of memory for texture coordinates");
    memcpy(r->uv, mesh->uv, sizeof(float) * 6 * mesh->nt);
    r->tex = tex;
  }
  if (mesh->rgb) {
    if (!(r->rgb = malloc(sizeof(float) * 9 * mesh->nt))) return mgs_error_set(err, MGS_ERR_NOMEM, "scene renderer: out of memory for vertex colours");
    memcpy(r->rgb, mesh->rgb, sizeof(float) * 9 * mesh->nt);
  }
  return MGS_OK;
}

mgs_status mgs_scene_renderer_create(const mgs_mesh *mesh, mgs_scene_renderer **out, mgs_error *err) {
  *out = NULL;
  if (!mesh || mesh->nv == 0 || mesh->nt == 0)
    return mgs_error_set(err, MGS_ERR_ARG, "scene renderer: mesh is empty");
  if (mesh->nv > 0xffffffffu || mesh->nt > 0x7fffffffu)
    return mgs_error_set(err, MGS_ERR_ARG, "scene renderer: mesh too large for Embree (%zu triangles)", mesh->nt);
  mgs_scene_renderer *r = calloc(1, sizeof *r);
  if (!r) return mgs_error_set(err, MGS_ERR_NOMEM, "scene renderer: out of memory");
  r->device = rtcNewDevice("verbose=0");
  if (!r->device) {
    free(r);
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "scene renderer: Embree device creation failed (%d)", (int)rtcGetDeviceError(NULL));
  }
  rtcSetDeviceErrorFunction(r->device, embree_error, NULL);
  r->scene = rtcNewScene(r->device);
  rtcSetSceneBuildQuality(r->scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geom = rtcNewGeometry(r->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  /* Embree-allocated buffers carry the padding its SIMD loads need past the last vertex. */
  float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh->nv);
  unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh->nt);
  if (!vb || !ib) {
    rtcReleaseGeometry(geom);
    mgs_scene_renderer_destroy(r);
    return mgs_error_set(err, MGS_ERR_NOMEM, "scene renderer: Embree could not allocate buffers for %zu triangles", mesh->nt);
  }
  memcpy(vb, mesh->v, mesh->nv * 3 * sizeof(float));
  for (size_t i = 0; i < mesh->nt * 3; i++) {
    if (mesh->t[i] >= mesh->nv) {
      rtcReleaseGeometry(geom);
      mgs_scene_renderer_destroy(r);
      return mgs_error_set(err, MGS_ERR_FORMAT, "scene renderer: triangle %zu uses vertex %u of %zu", i / 3, mesh->t[i], mesh->nv);
    }
    ib[i] = mesh->t[i];
  }
  if (!build_normals(r, mesh)) {
    rtcReleaseGeometry(geom);
    mgs_scene_renderer_destroy(r);
    return mgs_error_set(err, MGS_ERR_NOMEM, "scene renderer: out of memory for %zu vertex normals", mesh->nv);
  }
  rtcCommitGeometry(geom);
  rtcAttachGeometry(r->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(r->scene);
  enum RTCError e = rtcGetDeviceError(r->device);
  if (e != RTC_ERROR_NONE) {
    mgs_scene_renderer_destroy(r);
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "scene renderer: Embree error %d while building the BVH", (int)e);
  }
  *out = r;
  return MGS_OK;
}

static void init_ray(struct RTCRayHit *rh, const double org[3], const double dir[3], double tnear, double tfar) {
  rh->ray.org_x = (float)org[0]; rh->ray.org_y = (float)org[1]; rh->ray.org_z = (float)org[2];
  rh->ray.dir_x = (float)dir[0]; rh->ray.dir_y = (float)dir[1]; rh->ray.dir_z = (float)dir[2];
  rh->ray.tnear = (float)tnear;
  rh->ray.tfar = (float)tfar;
  rh->ray.time = 0.0f;
  rh->ray.mask = 0xffffffffu;
  rh->ray.id = 0;
  rh->ray.flags = 0;
  rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

int mgs_scene_trace(const mgs_scene_renderer *r, const double org[3], const double dir[3], double tnear, double *t_hit) {
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  struct RTCRayHit rh;
  init_ray(&rh, org, dir, tnear, INFINITY);
  rtcIntersect1(r->scene, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0;
  if (t_hit) *t_hit = rh.ray.tfar;
  return 1;
}

typedef struct {
  const mgs_scene_renderer *r;
  const mgs_camera *cam;
  const mgs_scene_options *o;
  uint32_t view;
  mgs_image *img;
} view_job;

/* Camera rays inline (the same model as mgs_camera_ray: pinhole, OpenCV axes, pixel
   centres at +0.5), with the per-view constants hoisted out of the sample loop. */
typedef struct {
  double o[3], R[9]; /* centre, camera-to-world rotation (columns = camera axes) */
  double fx, fy, cx, cy;
} ray_gen;

static void ray_gen_init(ray_gen *g, const mgs_camera *cam) {
  for (int i = 0; i < 3; i++) {
    g->o[i] = cam->c2w[4 * i + 3];
    for (int k = 0; k < 3; k++) g->R[3 * i + k] = cam->c2w[4 * i + k];
  }
  g->fx = cam->fx; g->fy = cam->fy; g->cx = cam->cx; g->cy = cam->cy;
}

static void ray_gen_dir(const ray_gen *g, double u, double v, float d[3]) {
  double x = (u - g->cx) / g->fx, y = (v - g->cy) / g->fy;
  double w[3] = {g->R[0] * x + g->R[1] * y + g->R[2], g->R[3] * x + g->R[4] * y + g->R[5], g->R[6] * x + g->R[7] * y + g->R[8]};
  double n = 1.0 / sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  d[0] = (float)(w[0] * n); d[1] = (float)(w[1] * n); d[2] = (float)(w[2] * n);
}

enum { MAX_SAMPLES = 16 * 16 };

static void render_rows(void *vctx, size_t y0, size_t y1) {
  const view_job *job = vctx;
  const mgs_camera *cam = job->cam;
  const int spp = job->o->spp > 0 ? (job->o->spp > 16 ? 16 : job->o->spp) : 1, ns = spp * spp;
  const float bg = job->o->white_background ? 1.0f : 0.0f;
  const float tnear = (float)(cam->znear > 0 ? cam->znear : 1e-4);
  const float tfar = cam->zfar > tnear ? (float)cam->zfar : INFINITY;
  ray_gen g;
  ray_gen_init(&g, cam);
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  struct RTCRayHit rays[MAX_SAMPLES];
  const uint32_t seed_mix = (uint32_t)job->o->seed * 0x9e3779b1u ^ (uint32_t)(job->o->seed >> 32);
  const mgs_scene_look look = {job->r->uv, job->r->tex, job->r->rgb, (float)job->o->texture_scale};
  for (size_t y = y0; y < y1; y++) {
    for (int x = 0; x < cam->width; x++) {
      /* One hash per pixel, then a cheap LCG for the sample jitter: deterministic and
         independent of how rows are split among threads. */
      uint32_t h = mgs_scene_hash4(job->view, (uint32_t)x, (uint32_t)y, seed_mix);
      for (int s = 0; s < ns; s++) {
        h = h * 1664525u + 1013904223u;
        double jx = (double)(h >> 16) / 65536.0;
        h = h * 1664525u + 1013904223u;
        double jy = (double)(h >> 16) / 65536.0;
        double u = x + ((s % spp) + jx) / spp, v = (double)y + ((s / spp) + jy) / spp;
        float d[3];
        ray_gen_dir(&g, u, v, d);
        struct RTCRayHit *rh = &rays[s];
        rh->ray.org_x = (float)g.o[0]; rh->ray.org_y = (float)g.o[1]; rh->ray.org_z = (float)g.o[2];
        rh->ray.dir_x = d[0]; rh->ray.dir_y = d[1]; rh->ray.dir_z = d[2];
        rh->ray.tnear = tnear; rh->ray.tfar = tfar; rh->ray.time = 0.0f;
        rh->ray.mask = 0xffffffffu; rh->ray.id = (unsigned)s; rh->ray.flags = 0;
        rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      }
      /* The samples of a pixel are coherent: let Embree trace them as a stream. */
      rtcIntersect1M(job->r->scene, &ctx, rays, (unsigned)ns, sizeof(struct RTCRayHit));
      float sum[3] = {0, 0, 0};
      int hits = 0;
      for (int s = 0; s < ns; s++) {
        const struct RTCRayHit *rh = &rays[s];
        if (rh->hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
        float d[3] = {rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
        float p[3] = {rh->ray.org_x + rh->ray.tfar * d[0], rh->ray.org_y + rh->ray.tfar * d[1], rh->ray.org_z + rh->ray.tfar * d[2]};
        float ng[3] = {rh->hit.Ng_x, rh->hit.Ng_y, rh->hit.Ng_z}, n[3];
        float back = (ng[0] * d[0] + ng[1] * d[1] + ng[2] * d[2]) > 0 ? -1.0f : 1.0f; /* face the viewer */
        if (job->r->smooth[rh->hit.primID]) {
          const uint32_t *ix = job->r->tri + 3 * (size_t)rh->hit.primID;
          const float *n0 = job->r->vnormal + 3 * ix[0], *n1 = job->r->vnormal + 3 * ix[1], *n2 = job->r->vnormal + 3 * ix[2];
          float w0 = 1.0f - rh->hit.u - rh->hit.v;
          for (int k = 0; k < 3; k++) n[k] = w0 * n0[k] + rh->hit.u * n1[k] + rh->hit.v * n2[k];
        } else {
          n[0] = ng[0]; n[1] = ng[1]; n[2] = ng[2];
        }
        float nl = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(nl > 0)) { n[0] = -d[0]; n[1] = -d[1]; n[2] = -d[2]; nl = 1; back = 1.0f; }
        n[0] *= back / nl; n[1] *= back / nl; n[2] *= back / nl;
        float view[3] = {-d[0], -d[1], -d[2]}, rgb[3], albedo[3];
        mgs_scene_look_albedo(&look, rh->hit.primID, rh->hit.u, rh->hit.v, p, albedo);
        mgs_scene_shade_albedo(albedo, n, view, job->o->specular, rgb);
        sum[0] += rgb[0]; sum[1] += rgb[1]; sum[2] += rgb[2];
        hits++;
      }
      float *px = job->img->data + ((size_t)y * (size_t)cam->width + (size_t)x) * 4;
      if (hits) {
        float inv = 1.0f / (float)hits;
        px[0] = sum[0] * inv; px[1] = sum[1] * inv; px[2] = sum[2] * inv;
      } else {
        px[0] = px[1] = px[2] = bg;
      }
      px[3] = (float)hits / (float)ns;
    }
  }
}

double mgs_scene_render_view(const mgs_scene_renderer *r, const mgs_camera *cam, const mgs_scene_options *o,
                             uint32_t view_index, mgs_image *rgba) {
  if (!r || !cam || !o || !rgba || rgba->channels != 4 || rgba->width != cam->width || rgba->height != cam->height) return 0;
  view_job job = {r, cam, o, view_index, rgba};
  mgs_parallel_for(0, (size_t)cam->height, 1, render_rows, &job);
  int spp = o->spp > 0 ? (o->spp > 16 ? 16 : o->spp) : 1;
  return (double)cam->width * cam->height * spp * spp;
}
