/* A mesh's own appearance in `morsegs scene` (render/mgs_scene.h, core/mgs_texture.h):
 * an OBJ + MTL + PNG written here renders its texture's colours at known pixels (UV
 * orientation included, seams kept through the weld); PLY vertex colours likewise; a missing
 * or corrupt texture falls back to the procedural texture with scene.json saying so, the
 * same renders as --procedural-texture; the bilinear wrap lookup; Debian's Khronos duck
 * (assimp-testmodels) renders yellow, as its texture, not as the procedural texture. */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "mgs_test.h"
#include "core/mgs_camera.h"
#include "core/mgs_fs.h"
#include "core/mgs_image.h"
#include "core/mgs_mesh.h"
#include "core/mgs_texture.h"
#include "render/mgs_scene.h"
#include "scene/scene_test_util.h"

static char tmpdir[256];

static void write_text(const char *name, const char *text) {
  char p[512];
  snprintf(p, sizeof p, "%s/%s", tmpdir, name);
  FILE *f = fopen(p, "w");
  CHECK(f != NULL);
  if (!f) return;
  fputs(text, f);
  fclose(f);
}

static const float RED[3] = {0.9f, 0.1f, 0.1f}, BLUE[3] = {0.1f, 0.1f, 0.9f};

/* 8 x 8: the bottom-left quadrant red (u < 0.5, v < 0.5 with v up), the rest blue. */
static void write_texture(const char *name) {
  mgs_image *img = mgs_image_create(8, 8, 3);
  for (int y = 0; y < 8; y++)
    for (int x = 0; x < 8; x++) {
      const float *c = (x < 4 && y >= 4) ? RED : BLUE; /* row 0 is the top */
      memcpy(img->data + 3 * (y * 8 + x), c, sizeof(float) * 3);
    }
  char p[512];
  snprintf(p, sizeof p, "%s/%s", tmpdir, name);
  mgs_error err;
  CHECK_OK(mgs_image_write(p, img, &err), &err);
  mgs_image_destroy(img);
}

/* The quad [-1,1]^2 at z = 0 as two triangles with their own (duplicated) vertices, as OBJ
   exporters write seams: the weld must merge positions and keep the corners' UVs. */
static void write_quad_obj(const char *obj, const char *mtl, const char *texture) {
  char text[1024];
  snprintf(text, sizeof text, "newmtl skin\nKd 1 1 1\nmap_Kd %s\n", texture);
  write_text(mtl, text);
  snprintf(text, sizeof text,
           "mtllib %s\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 -1 0\nv 1 1 0\nv -1 1 0\n"
           "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl skin\nf 1/1 2/2 3/3\nf 4/1 5/3 6/4\n", mtl);
  write_text(obj, text);
}

static mgs_mesh *read_tmp(const char *name) {
  char p[512];
  snprintf(p, sizeof p, "%s/%s", tmpdir, name);
  mgs_mesh *m = NULL;
  mgs_error err;
  CHECK_OK(mgs_mesh_read(p, &m, &err), &err);
  return m;
}

/* Looks at the quad from +z, +y up in the image: x right, y down in pixels. */
static mgs_image *render_front(const mgs_mesh *m, const mgs_texture *tex, int procedural) {
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.spp = 2;
  mgs_camera cam;
  mgs_camera_init_fovx(&cam, 64, 64, 0.8);
  const double eye[3] = {0, 0, 3}, at[3] = {0, 0, 0}, up[3] = {0, 1, 0};
  mgs_camera_look_at(&cam, eye, at, up);
  mgs_scene_renderer *r = NULL;
  mgs_error err;
  CHECK_OK(mgs_scene_renderer_create(m, &r, &err), &err);
  if (!r) return NULL;
  if (!procedural) CHECK_OK(mgs_scene_renderer_set_appearance(r, m, tex, &err), &err);
  mgs_image *img = mgs_image_create(64, 64, 4);
  mgs_scene_render_view(r, &cam, &o, 0, img);
  mgs_scene_renderer_destroy(r);
  return img;
}

static const float *px(const mgs_image *img, int x, int y) { return img->data + 4 * (y * img->width + x); }

static int is_red(const float *p) { return p[3] > 0.99f && p[0] > 4 * p[2] && p[0] > 4 * p[1]; }
static int is_blue(const float *p) { return p[3] > 0.99f && p[2] > 4 * p[0] && p[2] > 4 * p[1]; }

static void test_texture_lookup(void) {
  mgs_image *img = mgs_image_create(2, 2, 1); /* grey: top row 0, 1; bottom row 2, 3 (x 0.25) */
  for (int i = 0; i < 4; i++) img->data[i] = 0.25f * (float)i;
  mgs_texture *t = mgs_texture_from_image(img);
  mgs_image_destroy(img);
  CHECK(t && mgs_texture_width(t) == 2 && mgs_texture_height(t) == 2);
  if (!t) return;
  float c[3];
  mgs_texture_sample(t, 0.25f, 0.75f, c); /* the top-left texel's centre */
  CHECK_NEAR(c[0], 0.0, 1e-6);
  CHECK_NEAR(c[2], 0.0, 1e-6);
  mgs_texture_sample(t, 0.75f, 0.25f, c); /* bottom-right */
  CHECK_NEAR(c[1], 0.75, 1e-6);
  mgs_texture_sample(t, 0.5f, 0.25f, c); /* between the bottom texels */
  CHECK_NEAR(c[0], 0.625, 1e-6);
  mgs_texture_sample(t, 1.25f, -0.25f, c); /* wraps to (0.25, 0.75) */
  CHECK_NEAR(c[0], 0.0, 1e-5);
  mgs_texture_sample(t, -3.75f, 4.25f, c); /* (0.25, 0.25): bottom-left */
  CHECK_NEAR(c[0], 0.5, 1e-5);
  mgs_texture_sample(t, 0.0f, 0.75f, c); /* the left edge: halfway to the wrapped right texel */
  CHECK_NEAR(c[0], 0.125, 1e-6);
  mgs_texture_sample(t, 1e7f + 0.25f, 0.75f, c); /* far tiles stay finite */
  CHECK(isfinite(c[0]));
  mgs_texture_destroy(t);
  mgs_texture *none = NULL;
  mgs_error err;
  char p[512];
  snprintf(p, sizeof p, "%s/nope.png", tmpdir);
  CHECK(mgs_texture_read(p, &none, &err) != MGS_OK && none == NULL && strstr(err.msg, "nope.png"));
}

static void test_obj_texture(void) {
  write_texture("quad.png");
  write_quad_obj("quad.obj", "quad.mtl", "quad.png");
  mgs_mesh *m = read_tmp("quad.obj");
  if (!m) return;
  CHECK_MSG(m->nv == 4 && m->nt == 2, "welded %zu vertices, %zu triangles", m->nv, m->nt);
  CHECK(m->uv != NULL && m->texture != NULL && m->rgb == NULL);
  if (!m->uv || !m->texture) { mgs_mesh_destroy(m); return; }
  char want[512];
  snprintf(want, sizeof want, "%s/quad.png", tmpdir);
  CHECK_MSG(!strcmp(m->texture, want), "texture path %s, want %s", m->texture, want);
  /* every corner's UV is its position mapped from [-1,1] to [0,1], after the weld too */
  for (size_t t = 0; t < m->nt; t++)
    for (int k = 0; k < 3; k++) {
      const float *p = m->v + 3 * m->t[3 * t + (size_t)k], *uv = m->uv + 6 * t + 2 * k;
      CHECK_NEAR(uv[0], 0.5 * (p[0] + 1), 1e-6);
      CHECK_NEAR(uv[1], 0.5 * (p[1] + 1), 1e-6);
    }
  mgs_texture *tex = NULL;
  mgs_error err;
  CHECK_OK(mgs_texture_read(m->texture, &tex, &err), &err);
  mgs_image *img = render_front(m, tex, 0);
  if (img) {
    /* world (-0.5, -0.5) = uv (0.25, 0.25) is red and shows left and below the centre */
    CHECK_MSG(is_red(px(img, 20, 44)), "bottom-left %g %g %g %g", px(img, 20, 44)[0], px(img, 20, 44)[1], px(img, 20, 44)[2], px(img, 20, 44)[3]);
    CHECK(is_blue(px(img, 44, 44)));
    CHECK(is_blue(px(img, 20, 20)));
    CHECK(is_blue(px(img, 44, 20)));
    CHECK(px(img, 1, 1)[3] == 0.0f); /* the quad does not fill the view */
  }
  mgs_image *proc = render_front(m, NULL, 1);
  if (proc) CHECK(!is_red(px(proc, 20, 44)) || !is_blue(px(proc, 44, 44))); /* the checks above can fail */
  mgs_image_destroy(img);
  mgs_image_destroy(proc);
  mgs_texture_destroy(tex);
  mgs_mesh_destroy(m);
}

static void test_vertex_colours(void) {
  write_text("coloured.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                             "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\n"
                             "property list uchar int vertex_indices\nend_header\n"
                             "-1 -1 0 20 230 20\n1 -1 0 20 230 20\n1 1 0 20 230 20\n-1 1 0 20 230 20\n3 0 1 2\n3 0 2 3\n");
  mgs_mesh *m = read_tmp("coloured.ply");
  if (!m) return;
  CHECK(m->rgb != NULL && m->uv == NULL && m->texture == NULL);
  if (m->rgb) CHECK_NEAR(m->rgb[1], 230.0 / 255.0, 1e-3);
  mgs_image *img = render_front(m, NULL, 0);
  if (img) {
    const float *p = px(img, 32, 32);
    CHECK_MSG(p[1] > 4 * p[0] && p[1] > 4 * p[2], "centre %g %g %g", p[0], p[1], p[2]);
  }
  mgs_image_destroy(img);
  mgs_mesh_destroy(m);
}

static cJSON *read_json(const char *path) {
  size_t n = 0;
  char *text = NULL;
  mgs_error err;
  if (mgs_read_file(path, &text, &n, &err) != MGS_OK) return NULL;
  cJSON *j = cJSON_Parse(text);
  free(text);
  return j;
}

static const char *json_str(const cJSON *j, const char *key) {
  const cJSON *v = cJSON_GetObjectItem(j, key);
  return cJSON_IsString(v) ? v->valuestring : "";
}

/* Renders a small dataset of the quad; returns the scene.json (caller deletes). */
static cJSON *dataset(const char *obj, const char *out, int procedural) {
  mgs_mesh *m = read_tmp(obj);
  if (!m) return NULL;
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.n_train = 2; o.n_test = 0; o.width = o.height = 32; o.spp = 2;
  o.allow_open = 1; o.quiet = 1; o.procedural_texture = procedural; o.mesh_name = obj;
  char dir[512];
  snprintf(dir, sizeof dir, "%s/%s", tmpdir, out);
  mgs_error err;
  mgs_status s = mgs_scene_render_dataset(m, &o, dir, &err);
  CHECK_MSG(s == MGS_OK, "%s: %s", obj, err.msg);
  mgs_mesh_destroy(m);
  char p[600];
  snprintf(p, sizeof p, "%s/scene.json", dir);
  return s == MGS_OK ? read_json(p) : NULL;
}

static void test_dataset_appearance(void) {
  /* the texture (test_obj_texture wrote quad.obj and quad.png) */
  cJSON *j = dataset("quad.obj", "ds_tex", 0);
  CHECK(j && !strcmp(json_str(j, "appearance"), "texture") && strstr(json_str(j, "texture"), "quad.png"));
  cJSON_Delete(j);
  j = dataset("quad.obj", "ds_forced", 1);
  CHECK(j && !strcmp(json_str(j, "appearance"), "procedural") && !cJSON_GetObjectItem(j, "texture"));
  cJSON_Delete(j);
  char a[600], b[600];
  snprintf(a, sizeof a, "%s/ds_tex/train/r_0.png", tmpdir);
  snprintf(b, sizeof b, "%s/ds_forced/train/r_0.png", tmpdir);
  CHECK(!files_equal(a, b));
  /* missing and corrupt textures: a warning, the procedural renders, scene.json says why */
  write_quad_obj("missing.obj", "missing.mtl", "no_such_texture.png");
  write_text("corrupt.png", "this is not a PNG\n");
  write_quad_obj("corrupt.obj", "corrupt.mtl", "corrupt.png");
  const char *names[2] = {"missing.obj", "corrupt.obj"}, *outs[2] = {"ds_missing", "ds_corrupt"}, *tex[2] = {"no_such_texture.png", "corrupt.png"};
  for (int i = 0; i < 2; i++) {
    j = dataset(names[i], outs[i], 0);
    CHECK_MSG(j && !strcmp(json_str(j, "appearance"), "procedural"), "%s", names[i]);
    CHECK_MSG(j && strstr(json_str(j, "texture_unusable"), tex[i]), "%s: texture_unusable '%s'", names[i], j ? json_str(j, "texture_unusable") : "");
    cJSON_Delete(j);
    snprintf(a, sizeof a, "%s/%s/train/r_0.png", tmpdir, outs[i]);
    CHECK_MSG(files_equal(a, b), "%s: not the procedural renders", names[i]);
  }
}

/* Debian's assimp-testmodels: the Khronos duck, Collada with duckCM.tga. */
static void test_duck(void) {
  const char *duck = "/usr/share/assimp/models/Collada/duck.dae";
  if (access(duck, R_OK) != 0) {
    fprintf(stderr, "skip test_duck: %s not found (Debian package assimp-testmodels)\n", duck);
    return;
  }
  mgs_mesh *m = NULL;
  mgs_error err;
  CHECK_OK(mgs_mesh_read(duck, &m, &err), &err);
  if (!m) return;
  CHECK_MSG(m->nt == 4212 && m->uv && m->texture && strstr(m->texture, "duckCM.tga"), "%zu triangles, texture %s", m->nt,
            m->texture ? m->texture : "(none)");
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.n_train = 3; o.n_test = 0; o.width = o.height = 48; o.spp = 2; o.quiet = 1; o.mesh_name = duck;
  double mean[2][3] = {{0}};
  for (int proc = 0; proc < 2; proc++) {
    o.procedural_texture = proc;
    char dir[512];
    snprintf(dir, sizeof dir, "%s/duck_%d", tmpdir, proc);
    mgs_status s = mgs_scene_render_dataset(m, &o, dir, &err);
    CHECK_MSG(s == MGS_OK, "duck: %s", err.msg);
    if (s != MGS_OK) continue;
    double n = 0;
    for (int v = 0; v < o.n_train; v++) {
      char p[600];
      snprintf(p, sizeof p, "%s/train/r_%d.png", dir, v);
      mgs_image *img = NULL;
      CHECK_OK(mgs_image_read(p, &img, &err), &err);
      if (!img) continue;
      for (int i = 0; i < img->width * img->height; i++)
        if (img->data[4 * i + 3] > 0.99f) {
          for (int c = 0; c < 3; c++) mean[proc][c] += img->data[4 * i + c];
          n++;
        }
      mgs_image_destroy(img);
    }
    CHECK(n > 100);
    for (int c = 0; c < 3 && n > 0; c++) mean[proc][c] /= n;
    fprintf(stderr, "duck (%s): mean colour %.3f %.3f %.3f over %.0f pixels\n", proc ? "procedural" : "texture", mean[proc][0],
            mean[proc][1], mean[proc][2], n);
  }
  /* the texture's yellow: red and green high and close, blue low; the procedural texture
     (orange/blue patches, cream stripes) is not */
  const double *t = mean[0], *q = mean[1];
  CHECK_MSG(t[0] > 0.45 && t[1] > 0.7 * t[0] && t[2] < 0.4 * t[0], "texture mean %g %g %g", t[0], t[1], t[2]);
  CHECK_MSG(!(q[0] > 0.45 && q[1] > 0.7 * q[0] && q[2] < 0.4 * q[0]), "procedural mean %g %g %g looks yellow too", q[0], q[1], q[2]);
  mgs_mesh_destroy(m);
}

int main(void) {
  snprintf(tmpdir, sizeof tmpdir, "/tmp/test_scene_texture_XXXXXX");
  if (!mkdtemp(tmpdir)) { perror("mkdtemp"); return 1; }
  RUN(test_texture_lookup);
  RUN(test_obj_texture);
  RUN(test_vertex_colours);
  RUN(test_dataset_appearance);
  RUN(test_duck);
  mgs_error err;
  mgs_remove_tree(tmpdir, &err);
  return mgs_test_finish();
}
