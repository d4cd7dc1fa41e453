/* Datasets written by the scene maker, read back through the io layer:
 * (b) written camera poses: mesh vertices projected with the loaded cameras land inside
 *     the loaded alpha mask, the mask equals the projected silhouette, and a ray through
 *     a vertex's pixel (loaded camera) first hits the surface at or before that vertex,
 *     exactly at it for the visible ones;
 * (c) the same camera hand-written as a COLMAP text model (quaternion and translation
 *     computed here from transforms_train.json, independently of both loaders) projects
 *     3D points to the same pixels within 1e-6 px;
 * (d) determinism: same seed -> identical files (also with one thread); another seed
 *     -> different cameras;
 * (e) bad input: empty / open / non-manifold / non-finite meshes, an existing dataset
 *     without force, a folder of other files, a file in the way: each an error naming
 *     the problem, with nothing left behind. */
#include <dirent.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "mgs_test.h"
#include "scene_test_util.h"
#include "assets/mgs_assets.h"
#include "core/mgs_dataset.h"
#include "core/mgs_fs.h"
#include "core/mgs_parallel.h"
#include "render/mgs_scene.h"

static char root[4096];

/* "a/b", kept until the end of the test (freed in main). */
static char *pool[1024];
static int n_pool = 0;
static char *path2(const char *a, const char *b) {
  size_t n = strlen(a) + strlen(b) + 2;
  char *p = malloc(n);
  if (!p || n_pool == 1024) { fprintf(stderr, "path2: out of memory\n"); exit(2); }
  snprintf(p, n, "%s/%s", a, b);
  pool[n_pool++] = p;
  return p;
}

static void small_options(mgs_scene_options *o) {
  mgs_scene_options_default(o);
  o->n_train = 4;
  o->n_test = 2;
  o->width = 48;
  o->height = 40;
  o->seed = 11;
  o->init_points = 500;
  o->quiet = 1;
  o->specular = 1;
}

static mgs_mesh *builtin(const char *name) {
  mgs_error err;
  mgs_mesh *m = NULL;
  CHECK_OK(mgs_assets_builtin(name, &m, &err), &err);
  return m;
}

/* Entries of `dir` whose name starts with '.', i.e. staging or old leftovers. */
static int hidden_entries(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return -1;
  int n = 0;
  struct dirent *e;
  while ((e = readdir(d)))
    if (e->d_name[0] == '.' && strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) n++;
  closedir(d);
  return n;
}

static void test_poses_and_silhouette(void) {
  mgs_mesh *m = builtin("sphere");
  if (!m) return;
  mgs_error err;
  mgs_scene_options o;
  small_options(&o);
  const char *out = path2(root, "ds_poses");
  CHECK_OK(mgs_scene_render_dataset(m, &o, out, &err), &err);
  mgs_mesh_destroy(m);
  CHECK(hidden_entries(root) == 0);

  mgs_dataset_options lo;
  mgs_dataset_options_default(&lo);
  lo.load_images = 1;
  mgs_dataset *d = NULL;
  CHECK_OK(mgs_dataset_load(out, &lo, &d, &err), &err);
  mgs_mesh *gt = NULL;
  CHECK_OK(mgs_mesh_read(path2(out, "gt_mesh.ply"), &gt, &err), &err);
  if (!d || !gt) { mgs_dataset_destroy(d); mgs_mesh_destroy(gt); return; }
  CHECK(d->format == MGS_DATASET_NERF_SYNTHETIC);
  CHECK(d->n_views[MGS_SPLIT_TRAIN] == 4);
  CHECK(d->n_views[MGS_SPLIT_TEST] == 2);
  CHECK(d->init_points && d->init_points->n == 500);
  double lo3[3], hi3[3];
  mgs_mesh_bounds(gt, lo3, hi3);
  double ext = 0;
  for (int a = 0; a < 3; a++) {
    CHECK(lo3[a] >= -1 - 1e-5 && hi3[a] <= 1 + 1e-5);
    CHECK_NEAR(lo3[a] + hi3[a], 0, 1e-5);
    if (hi3[a] - lo3[a] > ext) ext = hi3[a] - lo3[a];
  }
  CHECK_NEAR(ext, 2.0, 1e-5);
  CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(gt) == 0);

  mgs_scene_renderer *r = NULL;
  CHECK_OK(mgs_scene_renderer_create(gt, &r, &err), &err);
  for (int s = 0; r && s < MGS_SPLIT_COUNT; s++)
    for (size_t i = 0; i < d->n_views[s]; i++) {
      mgs_view *v = &d->views[s][i];
      CHECK(v->cam.width == 48 && v->cam.height == 40);
      CHECK(v->alpha && v->alpha->channels == 1);
      if (!v->alpha) continue;
      const float *alpha = v->alpha->data;
      size_t off_mask = 0, not_reached = 0, visible = 0;
      double c[3];
      mgs_camera_center(&v->cam, c);
      /* Known 3D points on the surface: triangle centroids (a ray through a centroid
         meets no edge, so the test does not depend on edge tie-breaking). */
      for (size_t k = 0; k < gt->nt; k++) {
        double p[3] = {0, 0, 0}, u, vv, depth;
        for (int q = 0; q < 3; q++)
          for (int a = 0; a < 3; a++) p[a] += gt->v[3 * gt->t[3 * k + q] + a] / 3.0;
        if (!mgs_camera_project(&v->cam, p, &u, &vv, &depth) || u < 0 || vv < 0 || u >= 48 || vv >= 40) { off_mask++; continue; }
        /* In the mask: its pixel or (on the silhouette edge, where coverage may round to
           0) a neighbour is covered. */
        int x = (int)u, y = (int)vv, covered = 0;
        for (int dy = -1; dy <= 1; dy++)
          for (int dx = -1; dx <= 1; dx++) {
            int xx = x + dx, yy = y + dy;
            if (xx >= 0 && yy >= 0 && xx < 48 && yy < 40 && alpha[yy * 48 + xx] > 0) covered = 1;
          }
        if (!covered) off_mask++;
        double org[3], dir[3], t;
        mgs_camera_ray(&v->cam, u, vv, org, dir);
        double dist = sqrt((p[0] - org[0]) * (p[0] - org[0]) + (p[1] - org[1]) * (p[1] - org[1]) + (p[2] - org[2]) * (p[2] - org[2]));
        /* 1e-3 (0.05 % of the object) absorbs float error on grazing rays. */
        /* Grazing rays (nearly in the triangle's plane) cannot locate a point: skip. */
        const float *a0 = gt->v + 3 * gt->t[3 * k], *a1 = gt->v + 3 * gt->t[3 * k + 1], *a2 = gt->v + 3 * gt->t[3 * k + 2];
        double e1[3] = {a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2]}, e2[3] = {a2[0] - a0[0], a2[1] - a0[1], a2[2] - a0[2]};
        double nn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double nlen = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        if (!(nlen > 0) || fabs(nn[0] * dir[0] + nn[1] * dir[1] + nn[2] * dir[2]) < 0.1 * nlen) continue;
        if (!mgs_scene_trace(r, org, dir, 1e-4, &t) || t > dist + 1e-3) not_reached++;
        else if (fabs(t - dist) < 1e-3) visible++;
      }
      CHECK_MSG(off_mask == 0, "view %zu: %zu surface points project outside the alpha mask", i, off_mask);
      CHECK_MSG(not_reached == 0, "view %zu: %zu rays pass their surface point without a hit", i, not_reached);
      CHECK_MSG(visible * 4 > gt->nt, "view %zu: only %zu of %zu surface points seen", i, visible, gt->nt);
      uint8_t *pr = silhouette_probes(gt, &v->cam);
      mask_compare mc = compare_silhouette(alpha, 1, pr, 48, 40);
      CHECK_MSG(mc.interior_mismatch == 0, "view %zu: %zu interior pixels differ", i, mc.interior_mismatch);
      CHECK(mc.inside > 100);
      free(pr);
    }
  mgs_scene_renderer_destroy(r);
  mgs_mesh_destroy(gt);
  mgs_dataset_destroy(d);
}

/* Rotation matrix (row-major) -> quaternion (w, x, y, z), Shepperd's method. */
static void rot_to_quat(const double R[9], double q[4]) {
  double tr = R[0] + R[4] + R[8];
  if (tr > 0) {
    double s = sqrt(tr + 1.0) * 2;
    q[0] = 0.25 * s; q[1] = (R[7] - R[5]) / s; q[2] = (R[2] - R[6]) / s; q[3] = (R[3] - R[1]) / s;
  } else if (R[0] > R[4] && R[0] > R[8]) {
    double s = sqrt(1.0 + R[0] - R[4] - R[8]) * 2;
    q[0] = (R[7] - R[5]) / s; q[1] = 0.25 * s; q[2] = (R[1] + R[3]) / s; q[3] = (R[2] + R[6]) / s;
  } else if (R[4] > R[8]) {
    double s = sqrt(1.0 + R[4] - R[0] - R[8]) * 2;
    q[0] = (R[2] - R[6]) / s; q[1] = (R[1] + R[3]) / s; q[2] = 0.25 * s; q[3] = (R[5] + R[7]) / s;
  } else {
    double s = sqrt(1.0 + R[8] - R[0] - R[4]) * 2;
    q[0] = (R[3] - R[1]) / s; q[1] = (R[2] + R[6]) / s; q[2] = (R[5] + R[7]) / s; q[3] = 0.25 * s;
  }
}

static const mgs_view *find_view(const mgs_dataset *d, const char *stem) {
  for (int s = 0; s < MGS_SPLIT_COUNT; s++)
    for (size_t i = 0; i < d->n_views[s]; i++)
      if (d->views[s][i].name && !strcmp(d->views[s][i].name, stem)) return &d->views[s][i];
  return NULL;
}

static void test_colmap_same_projection(void) {
  const char *out = path2(root, "ds_poses");
  mgs_error err;
  char *json = NULL;
  size_t len = 0;
  CHECK_OK(mgs_read_file(path2(out, "transforms_train.json"), &json, &len, &err), &err);
  if (!json) return;
  cJSON *j = cJSON_Parse(json);
  free(json);
  CHECK(j != NULL);
  if (!j) return;
  double angle = cJSON_GetObjectItem(j, "camera_angle_x")->valuedouble;
  cJSON *f0 = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "frames"), 1);
  CHECK(!strcmp(cJSON_GetObjectItem(f0, "file_path")->valuestring, "./train/r_1"));
  double gl[16];
  cJSON *rows = cJSON_GetObjectItem(f0, "transform_matrix");
  for (int i = 0; i < 4; i++)
    for (int k = 0; k < 4; k++) gl[4 * i + k] = cJSON_GetArrayItem(cJSON_GetArrayItem(rows, i), k)->valuedouble;
  cJSON_Delete(j);
  /* OpenGL c2w -> OpenCV c2w (flip the camera's y and z axes) -> w2c = [R^T | -R^T t]. */
  double Rc2w[9], t[3], Rw2c[9], tw2c[3], q[4];
  for (int i = 0; i < 3; i++) {
    Rc2w[3 * i + 0] = gl[4 * i + 0];
    Rc2w[3 * i + 1] = -gl[4 * i + 1];
    Rc2w[3 * i + 2] = -gl[4 * i + 2];
    t[i] = gl[4 * i + 3];
  }
  for (int i = 0; i < 3; i++)
    for (int k = 0; k < 3; k++) Rw2c[3 * i + k] = Rc2w[3 * k + i];
  for (int i = 0; i < 3; i++) tw2c[i] = -(Rw2c[3 * i] * t[0] + Rw2c[3 * i + 1] * t[1] + Rw2c[3 * i + 2] * t[2]);
  rot_to_quat(Rw2c, q);
  double fx = 0.5 * 48 / tan(0.5 * angle);

  const char *cm = path2(root, "colmap");
  char *sparse = mgs_strdup(path2(cm, "sparse/0")), *images = mgs_strdup(path2(cm, "images"));
  CHECK_OK(mgs_mkdir_p(sparse, &err), &err);
  CHECK_OK(mgs_mkdir_p(images, &err), &err);
  char buf[2048];
  snprintf(buf, sizeof buf, "# Camera list\n1 PINHOLE 48 40 %.17g %.17g %.17g %.17g\n", fx, fx, 24.0, 20.0);
  CHECK_OK(mgs_write_file_atomic(path2(sparse, "cameras.txt"), buf, strlen(buf), &err), &err);
  snprintf(buf, sizeof buf, "# Image list\n1 %.17g %.17g %.17g %.17g %.17g %.17g %.17g 1 r_1.png\n10.0 12.0 1\n",
           q[0], q[1], q[2], q[3], tw2c[0], tw2c[1], tw2c[2]);
  CHECK_OK(mgs_write_file_atomic(path2(sparse, "images.txt"), buf, strlen(buf), &err), &err);
  snprintf(buf, sizeof buf, "# 3D points\n1 0.1 0.2 0.3 200 100 50 0.5 1 0\n2 -0.4 0.1 0.6 20 30 40 0.5 1 0\n");
  CHECK_OK(mgs_write_file_atomic(path2(sparse, "points3D.txt"), buf, strlen(buf), &err), &err);
  char *png = NULL;
  size_t png_len = 0;
  CHECK_OK(mgs_read_file(path2(out, "train/r_1.png"), &png, &png_len, &err), &err);
  if (png) CHECK_OK(mgs_write_file_atomic(path2(images, "r_1.png"), png, png_len, &err), &err);
  free(png);

  mgs_dataset_options lo;
  mgs_dataset_options_default(&lo);
  mgs_dataset *nerf = NULL, *colmap = NULL;
  CHECK_OK(mgs_dataset_load(out, &lo, &nerf, &err), &err);
  CHECK_OK(mgs_dataset_load(cm, &lo, &colmap, &err), &err);
  if (nerf && colmap) {
    CHECK(colmap->format == MGS_DATASET_COLMAP);
    const mgs_view *a = find_view(nerf, "r_1"), *b = find_view(colmap, "r_1");
    CHECK(a && b);
    if (a && b) {
      CHECK(a == &nerf->views[MGS_SPLIT_TRAIN][1]);
      double pts[4][3] = {{0.1, 0.2, 0.3}, {-0.4, 0.1, 0.6}, {0, 0, 0}, {0.7, -0.6, -0.5}};
      for (int k = 0; k < 4; k++) {
        double ua, va, da, ub, vb, db;
        CHECK(mgs_camera_project(&a->cam, pts[k], &ua, &va, &da));
        CHECK(mgs_camera_project(&b->cam, pts[k], &ub, &vb, &db));
        CHECK_NEAR(ua, ub, 1e-6);
        CHECK_NEAR(va, vb, 1e-6);
        CHECK_NEAR(da, db, 1e-9);
      }
      /* The scene origin is where every generated camera looks. */
      double o3[3] = {0, 0, 0}, u, v, dd;
      mgs_camera_project(&b->cam, o3, &u, &v, &dd);
      CHECK_NEAR(u, 24.0, 1e-6);
      CHECK_NEAR(v, 20.0, 1e-6);
    }
    CHECK(colmap->init_points && colmap->init_points->n == 2);
  }
  mgs_dataset_destroy(nerf);
  mgs_dataset_destroy(colmap);
  free(sparse);
  free(images);
}

static const char *dataset_files[] = {"transforms_train.json", "transforms_test.json", "train/r_0.png", "train/r_3.png",
                                      "test/r_0.png", "test/r_1.png", "gt_mesh.ply", "points3d.ply", "scene.json"};

static void test_determinism(void) {
  mgs_mesh *m = builtin("thin");
  if (!m) return;
  mgs_error err;
  mgs_scene_options o;
  small_options(&o);
  const char *a = path2(root, "det_a"), *b = path2(root, "det_b"), *c = path2(root, "det_c");
  CHECK_OK(mgs_scene_render_dataset(m, &o, a, &err), &err);
  mgs_parallel_set_threads(1);
  CHECK_OK(mgs_scene_render_dataset(m, &o, b, &err), &err);
  mgs_parallel_set_threads(0);
  o.seed = 12;
  CHECK_OK(mgs_scene_render_dataset(m, &o, c, &err), &err);
  for (size_t i = 0; i < sizeof dataset_files / sizeof dataset_files[0]; i++) {
    const char *f = dataset_files[i];
    CHECK_MSG(files_equal(path2(a, f), path2(b, f)), "%s differs between two runs with the same seed", f);
  }
  CHECK(!files_equal(path2(a, "transforms_train.json"), path2(c, "transforms_train.json")));
  CHECK(!files_equal(path2(a, "points3d.ply"), path2(c, "points3d.ply")));
  CHECK(files_equal(path2(a, "gt_mesh.ply"), path2(c, "gt_mesh.ply")));
  mgs_mesh_destroy(m);
}

static void test_bad_meshes(void) {
  mgs_error err;
  mgs_scene_options o;
  small_options(&o);
  o.mesh_name = "bad.obj";
  const char *out = path2(root, "bad_out");
  mgs_mesh empty = {.nv = 0, .nt = 0, .v = NULL, .t = NULL};
  CHECK(mgs_scene_render_dataset(&empty, &o, out, &err) == MGS_ERR_FORMAT);
  CHECK(strstr(err.msg, "bad.obj") && strstr(err.msg, "empty"));
  CHECK(!mgs_path_exists(out));

  /* One triangle: open. */
  float tri_v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0.2f};
  uint32_t tri_t[3] = {0, 1, 2};
  mgs_mesh tri = {.nv = 3, .nt = 1, .v = tri_v, .t = tri_t};
  CHECK(mgs_scene_render_dataset(&tri, &o, out, &err) == MGS_ERR_FORMAT);
  CHECK(strstr(err.msg, "bad.obj") && strstr(err.msg, "--allow-open"));
  CHECK(!mgs_path_exists(out));
  CHECK(hidden_entries(root) == 0);
  o.allow_open = 1;
  o.n_train = 2;
  o.n_test = 1;
  CHECK_OK(mgs_scene_render_dataset(&tri, &o, out, &err), &err);
  CHECK(mgs_path_exists(path2(out, "train/r_1.png")));
  o.allow_open = 0;

  /* Two closed tetrahedra sharing one edge: that edge has four triangles. */
  float tv[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0.3f, -0.8f, -0.6f};
  uint32_t tt[24] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, /* tet 0123 */
                     0, 1, 4, 0, 4, 2, 1, 2, 4, 0, 2, 1}; /* not a valid second solid: edge 0-1 reused */
  mgs_mesh nm = {.nv = 5, .nt = 8, .v = tv, .t = tt};
  const char *out2 = path2(root, "bad_out2");
  CHECK(mgs_scene_render_dataset(&nm, &o, out2, &err) == MGS_ERR_FORMAT);
  CHECK(strstr(err.msg, "non-manifold") != NULL);
  CHECK(!mgs_path_exists(out2));
  mgs_mesh tet = {.nv = 4, .nt = 4, .v = tv, .t = tt};
  CHECK(mgs_scene_check_mesh(&tet, &o, &err) == MGS_OK);

  float nanv[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, NAN};
  mgs_mesh nanm = {.nv = 4, .nt = 4, .v = nanv, .t = tt};
  CHECK(mgs_scene_render_dataset(&nanm, &o, out2, &err) == MGS_ERR_FORMAT);
  CHECK(strstr(err.msg, "non-finite") != NULL);
  uint32_t oob[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 9};
  mgs_mesh oobm = {.nv = 4, .nt = 4, .v = tv, .t = oob};
  CHECK(mgs_scene_render_dataset(&oobm, &o, out2, &err) == MGS_ERR_FORMAT);
  CHECK(!mgs_path_exists(out2));

  o.spp = 0;
  CHECK(mgs_scene_render_dataset(&tet, &o, out2, &err) == MGS_ERR_ARG);
  o.spp = 4;
  o.width = 0;
  CHECK(mgs_scene_render_dataset(&tet, &o, out2, &err) == MGS_ERR_ARG);
  CHECK(!mgs_path_exists(out2));
  CHECK(hidden_entries(root) == 0);
}

static void test_existing_output(void) {
  mgs_mesh *m = builtin("sphere");
  if (!m) return;
  mgs_error err;
  mgs_scene_options o;
  small_options(&o);
  o.n_train = 2;
  o.n_test = 1;
  const char *out = path2(root, "exist");
  CHECK_OK(mgs_scene_render_dataset(m, &o, out, &err), &err);
  char *before = NULL;
  size_t nb = 0;
  mgs_read_file(path2(out, "transforms_train.json"), &before, &nb, &err);
  o.seed = 99;
  CHECK(mgs_scene_render_dataset(m, &o, out, &err) == MGS_ERR_EXISTS);
  CHECK(strstr(err.msg, out) && strstr(err.msg, "--force"));
  char *after = NULL;
  size_t na = 0;
  mgs_read_file(path2(out, "transforms_train.json"), &after, &na, &err);
  CHECK(before && after && nb == na && !memcmp(before, after, nb));
  free(after);
  after = NULL;
  CHECK(hidden_entries(root) == 0);
  o.force = 1;
  CHECK_OK(mgs_scene_render_dataset(m, &o, out, &err), &err);
  mgs_read_file(path2(out, "transforms_train.json"), &after, &na, &err);
  CHECK(after && !(nb == na && !memcmp(before, after, nb)));
  CHECK(hidden_entries(root) == 0);
  free(before);
  free(after);

  /* A folder of the user's own files is never replaced, even with force. */
  const char *mine = path2(root, "mine");
  CHECK_OK(mgs_mkdir_p(mine, &err), &err);
  CHECK_OK(mgs_write_file_atomic(path2(mine, "notes.txt"), "keep", 4, &err), &err);
  CHECK(mgs_scene_render_dataset(m, &o, mine, &err) == MGS_ERR_EXISTS);
  CHECK(strstr(err.msg, mine) != NULL);
  CHECK(mgs_path_exists(path2(mine, "notes.txt")) && !mgs_path_exists(path2(mine, "train")));
  /* A file in the way. */
  const char *file = path2(root, "afile");
  CHECK_OK(mgs_write_file_atomic(file, "x", 1, &err), &err);
  CHECK(mgs_scene_render_dataset(m, &o, file, &err) == MGS_ERR_EXISTS);
  /* An existing empty folder is fine. */
  const char *empty = path2(root, "emptydir");
  CHECK_OK(mgs_mkdir_p(empty, &err), &err);
  o.force = 0;
  CHECK_OK(mgs_scene_render_dataset(m, &o, empty, &err), &err);
  CHECK(mgs_path_exists(path2(empty, "scene.json")));
  CHECK(hidden_entries(root) == 0);
  /* "DIR/" is DIR. */
  CHECK_OK(mgs_scene_render_dataset(m, &o, path2(root, "slash/"), &err), &err);
  CHECK(mgs_path_exists(path2(root, "slash/scene.json")));
  CHECK(mgs_scene_render_dataset(m, &o, path2(root, "slash//"), &err) == MGS_ERR_EXISTS);
  CHECK(hidden_entries(root) == 0);
  mgs_mesh_destroy(m);
}

int main(void) {
  snprintf(root, sizeof root, "%s", mgs_test_tmpdir("scene_dataset"));
  RUN(test_poses_and_silhouette);
  RUN(test_colmap_same_projection);
  RUN(test_determinism);
  RUN(test_bad_meshes);
  RUN(test_existing_output);
  for (int i = 0; i < n_pool; i++) free(pool[i]);
  return mgs_test_finish();
}
