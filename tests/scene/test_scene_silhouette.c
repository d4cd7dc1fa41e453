/* (a) The rendered alpha mask equals the mesh's projected silhouette, computed
 * independently: triangles projected with mgs_camera_project and a point-in-triangle
 * test at pixel centres. Pixels whose footprint the silhouette edge crosses may differ
 * (coverage vs. centre sample); every other pixel must agree exactly. Also: the auto
 * camera distance keeps the whole object in view; alpha is a coverage in [0, 1]; the
 * background colour sits under empty pixels; --specular changes colour, not alpha. */
#include <string.h>
#include "mgs_test.h"
#include "scene_test_util.h"
#include "assets/mgs_assets.h"
#include "render/mgs_scene.h"

static mgs_mesh *normalized(const char *name) {
  mgs_error err;
  mgs_mesh *m = NULL;
  CHECK_OK(mgs_assets_builtin(name, &m, &err), &err);
  if (m) mgs_mesh_normalize(m, 2.0, NULL);
  return m;
}

static double bound_radius(const mgs_mesh *m) {
  double r = 0;
  for (size_t i = 0; i < m->nv; i++) {
    const float *p = m->v + 3 * i;
    double d = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
    if (d > r) r = d;
  }
  return r;
}

static void check_scene(const char *name, int W, int H, int hemisphere) {
  mgs_mesh *m = normalized(name);
  if (!m) return;
  mgs_error err;
  mgs_scene_renderer *r = NULL;
  CHECK_OK(mgs_scene_renderer_create(m, &r, &err), &err);
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.width = W;
  o.height = H;
  o.hemisphere = hemisphere;
  o.seed = 7;
  enum { NV = 4 };
  mgs_camera cams[NV];
  double radius = mgs_scene_camera_radius(&o, bound_radius(m));
  mgs_scene_make_cameras(&o, 0, NV, radius, cams);
  mgs_image *img = mgs_image_create(W, H, 4);
  for (int v = 0; r && img && v < NV; v++) {
    double rays = mgs_scene_render_view(r, &cams[v], &o, (uint32_t)v, img);
    CHECK_NEAR(rays, (double)W * H * 16, 0);
    /* The whole object is in view (auto radius). */
    size_t outside = 0;
    for (size_t i = 0; i < m->nv; i++) {
      double p[3] = {m->v[3 * i], m->v[3 * i + 1], m->v[3 * i + 2]}, u, vv, d;
      if (!mgs_camera_project(&cams[v], p, &u, &vv, &d) || u < 0 || vv < 0 || u > W || vv > H) outside++;
    }
    CHECK_MSG(outside == 0, "%s view %d: %zu vertices outside the image", name, v, outside);
    uint8_t *pr = silhouette_probes(m, &cams[v]);
    mask_compare c = compare_silhouette(img->data + 3, 4, pr, W, H);
    CHECK_MSG(c.interior_mismatch == 0, "%s view %d: %zu interior pixels differ from the projected silhouette", name, v,
              c.interior_mismatch);
    CHECK_MSG(c.inside > (size_t)(W * H) / 50, "%s view %d: silhouette has only %zu pixels", name, v, c.inside);
    CHECK_MSG(c.boundary_mismatch * 2 <= c.boundary, "%s view %d: %zu of %zu edge pixels differ", name, v,
              c.boundary_mismatch, c.boundary);
    size_t bad_alpha = 0, bad_bg = 0, partial = 0;
    for (int i = 0; i < W * H; i++) {
      const float *px = img->data + 4 * (size_t)i;
      if (!(px[3] >= 0 && px[3] <= 1)) bad_alpha++;
      if (px[3] > 0 && px[3] < 1) partial++;
      if (px[3] == 0 && (px[0] != 1 || px[1] != 1 || px[2] != 1)) bad_bg++;
      for (int ch = 0; ch < 3; ch++) if (!(px[ch] >= 0 && px[ch] <= 1)) bad_alpha++;
    }
    CHECK(bad_alpha == 0);
    CHECK(bad_bg == 0);
    CHECK_MSG(partial > 0, "%s view %d: no antialiased edge pixels", name, v);
    free(pr);
  }
  mgs_image_destroy(img);
  mgs_scene_renderer_destroy(r);
  mgs_mesh_destroy(m);
}

static void test_sphere(void) { check_scene("sphere", 64, 64, 0); }
static void test_genus2_hemisphere(void) { check_scene("genus2", 64, 48, 1); }
static void test_thin(void) { check_scene("thin", 72, 64, 0); }

static void test_specular_and_texture(void) {
  mgs_mesh *m = normalized("sphere");
  if (!m) return;
  mgs_error err;
  mgs_scene_renderer *r = NULL;
  CHECK_OK(mgs_scene_renderer_create(m, &r, &err), &err);
  if (!r) { mgs_mesh_destroy(m); return; }
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.width = o.height = 48;
  mgs_camera cam;
  mgs_scene_make_cameras(&o, 1, 1, mgs_scene_camera_radius(&o, bound_radius(m)), &cam);
  mgs_image *a = mgs_image_create(48, 48, 4), *b = mgs_image_create(48, 48, 4);
  mgs_scene_render_view(r, &cam, &o, 0, a);
  o.specular = 1;
  mgs_scene_render_view(r, &cam, &o, 0, b);
  double max_diff = 0, sum = 0, sum2 = 0;
  size_t n = 0, alpha_diff = 0;
  for (int i = 0; i < 48 * 48; i++) {
    if (a->data[4 * i + 3] != b->data[4 * i + 3]) alpha_diff++;
    for (int c = 0; c < 3; c++) {
      double d = b->data[4 * i + c] - a->data[4 * i + c];
      if (d > max_diff) max_diff = d;
      CHECK(d >= -1e-6); /* a highlight only adds light */
    }
    if (a->data[4 * i + 3] == 1) { double g = a->data[4 * i + 1]; sum += g; sum2 += g * g; n++; }
  }
  CHECK(alpha_diff == 0);
  CHECK_MSG(max_diff > 0.2, "specular highlight adds at most %g", max_diff);
  /* Texture: inside the silhouette the colour varies (not a flat shade). */
  double mean = n ? sum / n : 0, var = n ? sum2 / n - mean * mean : 0;
  CHECK_MSG(n > 200 && var > 0.002, "colour variance %g over %zu pixels", var, n);
  /* Albedo is deterministic and within its documented range. */
  float p[3] = {0.3f, -0.2f, 0.1f}, c1[3], c2[3];
  mgs_scene_albedo(p, c1);
  mgs_scene_albedo(p, c2);
  CHECK(!memcmp(c1, c2, sizeof c1));
  for (int c = 0; c < 3; c++) CHECK(c1[c] >= 0.05f && c1[c] <= 0.95f);
  mgs_image_destroy(a);
  mgs_image_destroy(b);
  mgs_scene_renderer_destroy(r);
  mgs_mesh_destroy(m);
}

/* Mean |green difference| of horizontally adjacent pixels both inside the silhouette:
   texture detail (shading varies slowly across a pixel at this size). */
static double detail(const mgs_image *im, size_t *pairs) {
  double s = 0;
  size_t n = 0;
  for (int y = 0; y < im->height; y++)
    for (int x = 0; x + 1 < im->width; x++) {
      const float *a = im->data + 4 * ((size_t)y * im->width + x), *b = a + 4;
      if (a[3] == 1 && b[3] == 1) { s += fabs(a[1] - b[1]); n++; }
    }
  *pairs = n;
  return n ? s / n : 0;
}

/* --texture-scale: same silhouette, finer texture; out-of-range values are refused. */
static void test_texture_scale(void) {
  mgs_mesh *m = normalized("sphere");
  if (!m) return;
  mgs_error err;
  mgs_scene_renderer *r = NULL;
  CHECK_OK(mgs_scene_renderer_create(m, &r, &err), &err);
  if (!r) { mgs_mesh_destroy(m); return; }
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  CHECK(o.texture_scale == 1.0);
  o.width = o.height = 96;
  mgs_camera cam;
  mgs_scene_make_cameras(&o, 1, 1, mgs_scene_camera_radius(&o, bound_radius(m)), &cam);
  mgs_image *a = mgs_image_create(96, 96, 4), *b = mgs_image_create(96, 96, 4), *c = mgs_image_create(96, 96, 4);
  mgs_scene_render_view(r, &cam, &o, 0, a);
  mgs_scene_render_view(r, &cam, &o, 0, c);
  o.texture_scale = 4.0;
  mgs_scene_render_view(r, &cam, &o, 0, b);
  size_t na, nb, alpha_diff = 0;
  for (int i = 0; i < 96 * 96; i++) alpha_diff += a->data[4 * i + 3] != b->data[4 * i + 3];
  CHECK(alpha_diff == 0);
  CHECK(!memcmp(a->data, c->data, (size_t)96 * 96 * 4 * sizeof(float))); /* deterministic */
  double da = detail(a, &na), db = detail(b, &nb);
  CHECK_MSG(na > 1000 && na == nb, "%zu / %zu pixel pairs inside", na, nb);
  CHECK_MSG(db > 1.8 * da, "neighbour difference %g at scale 4 vs %g at scale 1", db, da);
  mgs_image_destroy(a);
  mgs_image_destroy(b);
  mgs_image_destroy(c);
  mgs_scene_renderer_destroy(r);
  mgs_mesh_destroy(m);
}

static void test_cameras(void) {
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.seed = 3;
  enum { N = 30 };
  mgs_camera tr[N], te[N], again[N];
  mgs_scene_make_cameras(&o, 0, N, 4.0, tr);
  mgs_scene_make_cameras(&o, 1, N, 4.0, te);
  mgs_scene_make_cameras(&o, 0, N, 4.0, again);
  CHECK(!memcmp(tr, again, sizeof tr));
  double zsum = 0, min_sep = 1e9;
  for (int i = 0; i < N; i++) {
    double c[3], ct[3];
    mgs_camera_center(&tr[i], c);
    CHECK_NEAR(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), 4.0, 1e-9);
    zsum += c[2];
    /* Looks at the origin: it projects to the image centre. */
    double o3[3] = {0, 0, 0}, u, v, d;
    CHECK(mgs_camera_project(&tr[i], o3, &u, &v, &d));
    CHECK_NEAR(u, o.width / 2.0, 1e-6);
    CHECK_NEAR(v, o.height / 2.0, 1e-6);
    /* World up (+z) points up in the image (v decreases) for cameras off the poles. */
    double up[3] = {0, 0, 0.1}, uu, vu, du;
    if (fabs(c[2]) < 3.5 && mgs_camera_project(&tr[i], up, &uu, &vu, &du)) CHECK(vu < v);
    for (int j = 0; j < N; j++) {
      mgs_camera_center(&te[j], ct);
      double dd = sqrt((c[0] - ct[0]) * (c[0] - ct[0]) + (c[1] - ct[1]) * (c[1] - ct[1]) + (c[2] - ct[2]) * (c[2] - ct[2]));
      if (dd < min_sep) min_sep = dd;
    }
  }
  CHECK(fabs(zsum / N) < 0.5); /* full sphere: balanced */
  CHECK(min_sep > 1e-3);       /* no test pose repeats a training pose */
  o.hemisphere = 1;
  mgs_scene_make_cameras(&o, 0, N, 4.0, tr);
  for (int i = 0; i < N; i++) {
    double c[3];
    mgs_camera_center(&tr[i], c);
    CHECK(c[2] > 0);
  }
  /* A different seed moves the cameras. */
  o.hemisphere = 0;
  o.seed = 4;
  mgs_scene_make_cameras(&o, 0, N, 4.0, again);
  CHECK(memcmp(again[0].c2w, tr[0].c2w, sizeof tr[0].c2w) != 0);
}

int main(void) {
  RUN(test_cameras);
  RUN(test_sphere);
  RUN(test_genus2_hemisphere);
  RUN(test_thin);
  RUN(test_specular_and_texture);
  RUN(test_texture_scale);
  return mgs_test_finish();
}
