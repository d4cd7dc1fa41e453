#include <limits.h>
#include <math.h>
#include <stdlib.h>
/* Dataset loaders: NeRF-synthetic, nerfstudio and COLMAP (bin and txt) datasets written
 * by the test itself load with the right cameras (a known 3D point projects to the
 * hand-computed pixel), and bad input fails with a message naming the file. */
#include <unistd.h>

#include "core/mgs_dataset.h"
#include "io_test_util.h"
#include "mgs_test.h"

static char *join(const char *a, const char *b) {
  static char bufs[4][4096];
  static int k = 0;
  char *r = bufs[k++ & 3];
  size_t la = strlen(a), lb = strlen(b);
  if (la + lb + 2 > 4096) exit(2);
  memcpy(r, a, la);
  r[la] = '/';
  memcpy(r + la + 1, b, lb + 1);
  return r;
}

static void check_project(const mgs_camera *cam, double x, double y, double z, double u_want, double v_want) {
  double p[3] = {x, y, z}, u = -1, v = -1, depth = 0;
  CHECK(mgs_camera_project(cam, p, &u, &v, &depth));
  CHECK_NEAR(u, u_want, 1e-9);
  CHECK_NEAR(v, v_want, 1e-9);
}

/* Loads expecting failure with `want`; the message must contain every non-NULL part. */
static void expect_load_fail(const char *dir, int load_images, mgs_status want, const char *part1, const char *part2) {
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = load_images;
  mgs_dataset *d = NULL;
  mgs_error err = {0};
  mgs_status s = mgs_dataset_load(dir, &o, &d, &err);
  CHECK_MSG(s == want, "%s: status %s, want %s (%s)", dir, mgs_status_name(s), mgs_status_name(want), err.msg);
  CHECK(d == NULL);
  if (part1) CHECK_MSG(strstr(err.msg, part1) != NULL, "message lacks '%s': %s", part1, err.msg);
  if (part2) CHECK_MSG(strstr(err.msg, part2) != NULL, "message lacks '%s': %s", part2, err.msg);
  mgs_dataset_destroy(d);
}

/* ---------------- NeRF-synthetic ---------------- */
static void test_nerf_synthetic(void);
static void test_far_origin(void);

#define FOVX_16 "0.9272952180016122" /* 2 atan(1/2): fx = 16 at width 16 */
#define M_FRONT "[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]"   /* at (0,0,4) looking down -z */
#define M_SIDE "[[0,0,1,4],[0,1,0,0],[-1,0,0,0],[0,0,0,1]]"   /* at (4,0,0) looking down -x */

static const char *make_nerf(const char *name, const char *train_json) {
  const char *dir = mgs_test_tmpdir(name);
  static char d[4096];
  snprintf(d, sizeof d, "%s", dir);
  io_mkdir(join(d, "train"));
  io_mkdir(join(d, "test"));
  io_write_png(join(d, "train/r_0.png"), 16, 12, 4);
  io_write_png(join(d, "train/r_1.png"), 16, 12, 4);
  io_write_png(join(d, "test/r_0.png"), 16, 12, 4);
  io_write_text(join(d, "transforms_train.json"), train_json);
  io_write_text(join(d, "transforms_test.json"),
                "{\"camera_angle_x\": " FOVX_16 ", \"frames\": [{\"file_path\": \"./test/r_0\", \"transform_matrix\": " M_FRONT "}]}");
  return d;
}

static const char *good_train_json =
    "{\"camera_angle_x\": " FOVX_16 ", \"frames\": ["
    "{\"file_path\": \"./train/r_0\", \"rotation\": 0.1, \"transform_matrix\": " M_FRONT "},"
    "{\"file_path\": \"./train/r_1\", \"transform_matrix\": " M_SIDE "}]}";

/* Issue 28: the same two cameras and points moved by (1e6, -3e5, 2e5): the dataset's origin
 * is that translation exactly (on the power-of-two grid of the extent), and cameras and
 * points are the centred ones in the local frame (points exactly: double in the file). */
static void test_far_origin(void) {
  const char *far_json =
      "{\"camera_angle_x\": " FOVX_16 ", \"frames\": ["
      "{\"file_path\": \"./train/r_0\", \"transform_matrix\": [[1,0,0,1000000],[0,1,0,-300000],[0,0,1,200004],[0,0,0,1]]},"
      "{\"file_path\": \"./train/r_1\", \"transform_matrix\": [[0,0,1,1000004],[0,1,0,-300000],[-1,0,0,200000],[0,0,0,1]]}]}";
  const char *dir = make_nerf("io_nerf_far", far_json);
  io_write_text(join(dir, "points3d.ply"),
                "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\nend_header\n"
                "1000000.25 -299999.5 200000.125\n1000001 -300000 200000.0000001\n");
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  mgs_dataset *d = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (!d) return;
  CHECK_MSG(d->origin[0] == 1000000 && d->origin[1] == -300000 && d->origin[2] == 200000, "origin %.17g %.17g %.17g", d->origin[0],
            d->origin[1], d->origin[2]);
  mgs_view *v0 = &d->views[MGS_SPLIT_TRAIN][0], *v1 = &d->views[MGS_SPLIT_TRAIN][1];
  check_project(&v0->cam, 0.5, 0.25, 0, 10, 5);
  check_project(&v1->cam, 0, 0.25, -0.5, 10, 5);
  check_project(&d->views[MGS_SPLIT_TEST][0].cam, 0.5 - 1e6, 0.25 + 3e5, -2e5, 10, 5); /* the test view was not moved */
  CHECK_NEAR(d->center[0], 2, 1e-9);
  CHECK_NEAR(d->center[2], 2, 1e-9);
  CHECK_NEAR(d->extent, 1.1 * sqrt(8.0), 1e-9);
  CHECK(d->init_points && d->init_points->n == 2);
  if (d->init_points && d->init_points->n == 2) {
    const float *x = d->init_points->xyz;
    CHECK(x[0] == 0.25f && x[1] == 0.5f && x[2] == 0.125f && x[3] == 1.0f && x[4] == 0.0f);
    CHECK_NEAR(x[5], 1e-7, 1e-10); /* the file's 200000.0000001 is itself rounded */
    CHECK(d->init_points->xyz64 == NULL);
  }
  double p[3];
  CHECK(mgs_dataset_look_at(d, p)); /* the two optical axes meet at (0,0,0) (local) */
  for (int k = 0; k < 3; k++) CHECK_NEAR(p[k], 0, 1e-9);
  mgs_dataset_destroy(d);
}

static void test_nerf_synthetic(void) {
  const char *dir = make_nerf("io_nerf", good_train_json);
  /* initial points and a ground-truth mesh beside it */
  mgs_point_cloud pc = {2, (float[]){1, 2, 3, 4, 5, 6}, (float[]){1, 0, 0, 0, 1, 0}, NULL};
  mgs_error err = {0};
  CHECK_OK(mgs_ply_write_points(join(dir, "points3d.ply"), &pc, &err), &err);
  io_write_text(join(dir, "gt_mesh.ply"), "not read by the loader");

  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = 1;
  mgs_dataset *d = NULL;
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (!d) return;
  CHECK(d->format == MGS_DATASET_NERF_SYNTHETIC);
  CHECK(d->white_background == 1 && d->background[0] == 1.0f); /* the reference's -w for these */
  CHECK(d->n_views[MGS_SPLIT_TRAIN] == 2 && d->n_views[MGS_SPLIT_VAL] == 0 && d->n_views[MGS_SPLIT_TEST] == 1);
  mgs_view *v0 = &d->views[MGS_SPLIT_TRAIN][0], *v1 = &d->views[MGS_SPLIT_TRAIN][1];
  CHECK(strcmp(v0->name, "r_0") == 0 && strcmp(v1->name, "r_1") == 0);
  CHECK(v0->cam.width == 16 && v0->cam.height == 12);
  CHECK_NEAR(v0->cam.fx, 16, 1e-9);
  CHECK_NEAR(v0->cam.fy, 16, 1e-9);
  CHECK_NEAR(v0->cam.cx, 8, 1e-12);
  CHECK_NEAR(v0->cam.cy, 6, 1e-12);
  /* (0.5, 0.25, 0) seen from (0,0,4): camera coords (0.5, -0.25, 4) -> (8 + 16*0.125, 6 - 16*0.0625) */
  check_project(&v0->cam, 0.5, 0.25, 0, 10, 5);
  /* from (4,0,0) looking down -x, world -z is camera right: (0, 0.25, -0.5) -> same pixel */
  check_project(&v1->cam, 0, 0.25, -0.5, 10, 5);
  check_project(&d->views[MGS_SPLIT_TEST][0].cam, 0.5, 0.25, 0, 10, 5);
  CHECK_NEAR(d->center[0], 2, 1e-12);
  CHECK_NEAR(d->center[1], 0, 1e-12);
  CHECK_NEAR(d->center[2], 2, 1e-12);
  CHECK_NEAR(d->extent, 1.1 * sqrt(8.0), 1e-12);
  CHECK(d->init_points && d->init_points->n == 2 && d->init_points->xyz[4] == 5.0f);
  CHECK(d->mesh_path && strstr(d->mesh_path, "gt_mesh.ply"));
  /* images: RGBA composited on white; alpha kept */
  CHECK(v0->image && v0->image->width == 16 && v0->image->channels == 3);
  CHECK(v0->alpha && v0->alpha->channels == 1);
  if (v0->image && v0->alpha) {
    int x = 3, y = 5; /* odd x: alpha 128/255 */
    float a = io_png_value(x, y, 3);
    CHECK_NEAR(v0->alpha->data[y * 16 + x], a, 1e-6);
    for (int c = 0; c < 3; c++) CHECK_NEAR(v0->image->data[(y * 16 + x) * 3 + c], io_png_value(x, y, c) * a + (1 - a), 1e-6);
    CHECK_NEAR(v0->image->data[(y * 16 + 2) * 3 + 0], io_png_value(2, y, 0), 1e-6); /* opaque */
  }
  mgs_dataset_destroy(d);

  /* black background, downscale 2 */
  o.white_background = 0;
  o.downscale = 2;
  d = NULL;
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (!d) return;
  v0 = &d->views[MGS_SPLIT_TRAIN][0];
  CHECK(v0->cam.width == 8 && v0->cam.height == 6 && v0->full_width == 16);
  check_project(&v0->cam, 0.5, 0.25, 0, 5, 2.5);
  CHECK(v0->image && v0->image->width == 8 && v0->image->height == 6);
  if (v0->image) {
    /* composited on black first, then PIL's bicubic resize (checked against PIL itself in
       test_io_resize) */
    mgs_image *full = mgs_image_create(16, 12, 3);
    for (int y = 0; y < 12; y++)
      for (int x = 0; x < 16; x++)
        for (int c = 0; c < 3; c++) full->data[(y * 16 + x) * 3 + c] = (float)(io_png_value(x, y, c) * io_png_value(x, y, 3));
    mgs_image *want = mgs_image_resize_bicubic(full, 8, 6);
    double maxd = 0;
    for (int i = 0; i < 8 * 6 * 3; i++) maxd = fmax(maxd, fabs(v0->image->data[i] - want->data[i]));
    CHECK(maxd < 1e-6);
    mgs_image_destroy(full);
    mgs_image_destroy(want);
  }
  mgs_dataset_destroy(d);

  /* the reference's width cap (1600 px; here 10 to keep the test small): 16x12 -> 10 x
     int(12 / 1.6) = 7, focal lengths and principal point scaled per axis, so a world point
     lands on the same relative position */
  o.downscale = 1;
  o.max_width = 10;
  d = NULL;
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (d) {
    v0 = &d->views[MGS_SPLIT_TRAIN][0];
    CHECK(v0->cam.width == 10 && v0->cam.height == 7);
    CHECK_NEAR(v0->cam.fx, 16 * 10.0 / 16, 1e-12);
    CHECK_NEAR(v0->cam.fy, 16 * 7.0 / 12, 1e-12);
    CHECK_NEAR(v0->cam.cx, 8 * 10.0 / 16, 1e-12);
    CHECK_NEAR(v0->cam.cy, 6 * 7.0 / 12, 1e-12);
    check_project(&v0->cam, 0.5, 0.25, 0, 10 * 10.0 / 16, 5 * 7.0 / 12);
    CHECK(v0->image && v0->image->width == 10 && v0->image->height == 7);
    CHECK(d->max_width == 10 && !d->white_background);
    mgs_dataset_destroy(d);
  }
  /* a downscale factor given: no cap; round(w / f) as Python's round (16 / 3 -> 5, 12 / 3 -> 4) */
  o.downscale = 3;
  d = NULL;
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (d) {
    v0 = &d->views[MGS_SPLIT_TRAIN][0];
    CHECK(v0->cam.width == 5 && v0->cam.height == 4 && d->max_width == 0);
    CHECK(v0->image && v0->image->width == 5 && v0->image->height == 4);
    mgs_dataset_destroy(d);
  }
  int w, h;
  mgs_dataset_image_size(3000, 2000, 1, 1600, &w, &h);
  CHECK(w == 1600 && h == 1066);
  mgs_dataset_image_size(1600, 900, 1, 1600, &w, &h);
  CHECK(w == 1600 && h == 900);
  mgs_dataset_image_size(1601, 901, 1, 0, &w, &h);
  CHECK(w == 1601 && h == 901);
  mgs_dataset_image_size(10, 6, 4, 1600, &w, &h); /* 2.5 -> 2 and 1.5 -> 2: halves to even */
  CHECK(w == 2 && h == 2);
  o.max_width = 1600;

  /* lazily loaded images */
  o.load_images = 0;
  o.downscale = 1;
  d = NULL;
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (d) {
    CHECK(d->views[MGS_SPLIT_TEST][0].image == NULL);
    CHECK_OK(mgs_dataset_load_image(d, &d->views[MGS_SPLIT_TEST][0], &err), &err);
    CHECK(d->views[MGS_SPLIT_TEST][0].image != NULL);
    mgs_dataset_destroy(d);
  }
}

static void test_nerf_bad(void) {
  expect_load_fail(make_nerf("io_nerf_b1", "{\"frames\": []}"), 0, MGS_ERR_FORMAT, "transforms_train.json", "camera_angle_x");
  expect_load_fail(make_nerf("io_nerf_b2", "{\"camera_angle_x\": \"0.7\", \"frames\": []}"), 0, MGS_ERR_FORMAT,
                   "transforms_train.json", "must be a number");
  expect_load_fail(make_nerf("io_nerf_b3", "{\"camera_angle_x\": 0.7}"), 0, MGS_ERR_FORMAT, "transforms_train.json", "'frames'");
  expect_load_fail(make_nerf("io_nerf_b4", "{\"camera_angle_x\": 0.7, \"frames\": {}}"), 0, MGS_ERR_FORMAT, "transforms_train.json", "array");
  expect_load_fail(make_nerf("io_nerf_b5", "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"./train/r_0\", \"transform_matrix\": " M_FRONT
                                           "}, {\"transform_matrix\": " M_FRONT "}]}"),
                   0, MGS_ERR_FORMAT, "transforms_train.json: frame 1", "file_path");
  expect_load_fail(make_nerf("io_nerf_b6", "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"./train/r_0\", "
                                           "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,4]]}]}"),
                   0, MGS_ERR_FORMAT, "transforms_train.json: frame 0", "transform_matrix must be 4x4");
  expect_load_fail(make_nerf("io_nerf_b7", "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"./train/r_0\", "
                                           "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,\"4\"],[0,0,0,1]]}]}"),
                   0, MGS_ERR_FORMAT, "frame 0", "transform_matrix");
  expect_load_fail(make_nerf("io_nerf_b8", "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": 5, \"transform_matrix\": " M_FRONT "}]}"),
                   0, MGS_ERR_FORMAT, "frame 0", "'file_path' must be a string");
  expect_load_fail(make_nerf("io_nerf_b9", "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"./train/r_0\""), 0,
                   MGS_ERR_FORMAT, "transforms_train.json", "invalid JSON");
  expect_load_fail(make_nerf("io_nerf_b10", "[1, 2]"), 0, MGS_ERR_FORMAT, "transforms_train.json", "not a JSON object");
  expect_load_fail(make_nerf("io_nerf_b15", "{\"camera_angle_x\": 0.7, \"frames\": []}"), 0, MGS_ERR_FORMAT, "transforms_train.json", "no frames");
  expect_load_fail(make_nerf("io_nerf_b16", "{\"camera_angle_x\": 0.7, \"frames\": [7]}"), 0, MGS_ERR_FORMAT, "frame 0", "not an object");
  /* missing image file */
  expect_load_fail(make_nerf("io_nerf_b11", "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"./train/r_9\", \"transform_matrix\": " M_FRONT "}]}"),
                   0, MGS_ERR_IO, "r_9.png", "not found");
  /* image size disagreeing with the file's w/h */
  expect_load_fail(make_nerf("io_nerf_b12", "{\"camera_angle_x\": 0.7, \"w\": 20, \"h\": 12, \"frames\": [{\"file_path\": \"./train/r_0\", "
                                            "\"transform_matrix\": " M_FRONT "}]}"),
                   0, MGS_ERR_FORMAT, "r_0.png", "16x12");
  /* a non-rigid pose */
  expect_load_fail(make_nerf("io_nerf_b13", "{\"camera_angle_x\": 0.7, \"frames\": [{\"file_path\": \"./train/r_0\", "
                                            "\"transform_matrix\": [[2,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]}"),
                   0, MGS_ERR_FORMAT, "frame 0", "orthonormal");
  /* an image replaced by one of another size after loading the cameras */
  {
    const char *dir = make_nerf("io_nerf_b14", good_train_json);
    mgs_dataset_options o;
    mgs_dataset_options_default(&o);
    mgs_dataset *d = NULL;
    mgs_error err = {0};
    CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
    io_write_png(join(dir, "train/r_1.png"), 10, 12, 4);
    if (d) {
      CHECK(mgs_dataset_load_image(d, &d->views[MGS_SPLIT_TRAIN][1], &err) == MGS_ERR_FORMAT);
      CHECK_MSG(strstr(err.msg, "r_1.png") && strstr(err.msg, "10x12"), "%s", err.msg);
      mgs_dataset_destroy(d);
    }
  }
  /* not a dataset at all / missing directory */
  const char *empty = mgs_test_tmpdir("io_empty");
  expect_load_fail(empty, 0, MGS_ERR_FORMAT, "tmp_io_empty", "not a dataset");
  expect_load_fail("tmp_no_such_dir_xyz", 0, MGS_ERR_IO, "tmp_no_such_dir_xyz", NULL);
}

/* ---------------- nerfstudio ---------------- */

static const char *make_ns(const char *name, const char *top_fields, const char *frame3_extra) {
  const char *dir = mgs_test_tmpdir(name);
  static char d[4096];
  snprintf(d, sizeof d, "%s", dir);
  io_mkdir(join(d, "images"));
  char json[16384];
  int len = snprintf(json, sizeof json, "{%s, \"frames\": [", top_fields);
  for (int i = 8; i >= 0; i--) { /* written in reverse: the loader sorts */
    char img[64];
    snprintf(img, sizeof img, "images/frame_%02d.png", i);
    io_write_png(join(d, img), 16, 12, 3);
    len += snprintf(json + len, sizeof json - (size_t)len, "%s{\"file_path\": \"%s\", \"transform_matrix\": " M_FRONT "%s}",
                    i == 8 ? "" : ",", img, i == 3 ? frame3_extra : "");
  }
  snprintf(json + len, sizeof json - (size_t)len, "]}");
  io_write_text(join(d, "transforms.json"), json);
  return d;
}

#define NS_TOP "\"camera_model\": \"OPENCV\", \"fl_x\": 16, \"fl_y\": 16, \"cx\": 8, \"cy\": 6, \"w\": 16, \"h\": 12, \"k1\": 0, \"k2\": 0, \"p1\": 0, \"p2\": 0"

static void test_nerfstudio(void) {
  const char *dir = make_ns("io_ns", NS_TOP ", \"ply_file_path\": \"sparse_pc.ply\"", ", \"fl_x\": 32");
  mgs_point_cloud pc = {1, (float[]){1, 2, 3}, (float[]){1, 0, 0}, NULL};
  mgs_error err = {0};
  CHECK_OK(mgs_ply_write_points(join(dir, "sparse_pc.ply"), &pc, &err), &err);
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = 1;
  mgs_dataset *d = NULL;
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (!d) return;
  CHECK(d->format == MGS_DATASET_NERFSTUDIO);
  CHECK(d->white_background == 0 && d->background[0] == 0.0f); /* the reference's default */
  /* 9 views sorted by name, every 8th (0 and 8) to test */
  CHECK(d->n_views[MGS_SPLIT_TRAIN] == 7 && d->n_views[MGS_SPLIT_TEST] == 2);
  CHECK(strcmp(d->views[MGS_SPLIT_TEST][0].name, "frame_00") == 0 && strcmp(d->views[MGS_SPLIT_TEST][1].name, "frame_08") == 0);
  CHECK(strcmp(d->views[MGS_SPLIT_TRAIN][2].name, "frame_03") == 0);
  check_project(&d->views[MGS_SPLIT_TRAIN][0].cam, 0.5, 0.25, 0, 10, 5);
  /* frame_03 carries its own fl_x = 32: u = 8 + 32 * 0.125 */
  check_project(&d->views[MGS_SPLIT_TRAIN][2].cam, 0.5, 0.25, 0, 12, 5);
  CHECK(d->init_points && d->init_points->n == 1);
  CHECK(d->views[MGS_SPLIT_TRAIN][0].image && d->views[MGS_SPLIT_TRAIN][0].alpha == NULL);
  mgs_dataset_destroy(d);

  /* wrong-size image: error at image loading, naming it */
  io_write_png(join(dir, "images/frame_05.png"), 20, 12, 3);
  expect_load_fail(dir, 1, MGS_ERR_FORMAT, "frame_05.png", "20x12");
  /* missing image */
  unlink(join(dir, "images/frame_05.png"));
  expect_load_fail(dir, 0, MGS_ERR_IO, "frame_05.png", "not found");

  /* the file's own split lists */
  dir = make_ns("io_ns_lists", NS_TOP ", \"train_filenames\": [\"images/frame_01.png\", \"images/frame_02.png\", \"./images/frame_03.png\"],"
                " \"test_filenames\": [\"images/frame_04.png\"]", "");
  d = NULL;
  o.load_images = 0;
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (d) {
    CHECK(d->n_views[MGS_SPLIT_TRAIN] == 3 && d->n_views[MGS_SPLIT_TEST] == 1 && d->n_views[MGS_SPLIT_VAL] == 0);
    CHECK(strcmp(d->views[MGS_SPLIT_TEST][0].name, "frame_04") == 0);
    mgs_dataset_destroy(d);
  }
}

static void test_nerfstudio_bad(void) {
  expect_load_fail(make_ns("io_ns_b1", NS_TOP, ", \"k1\": 0.1"), 0, MGS_ERR_UNSUPPORTED, "OPENCV", "k1");
  expect_load_fail(make_ns("io_ns_b2", "\"camera_model\": \"OPENCV_FISHEYE\", \"fl_x\": 16, \"fl_y\": 16, \"cx\": 8, \"cy\": 6, \"w\": 16, \"h\": 12", ""),
                   0, MGS_ERR_UNSUPPORTED, "transforms.json", "OPENCV_FISHEYE");
  expect_load_fail(make_ns("io_ns_b3", "\"fl_x\": 16, \"cx\": 8, \"cy\": 6, \"w\": 16, \"h\": 12", ""), 0, MGS_ERR_FORMAT,
                   "transforms.json: frame 0", "'fl_y'");
  expect_load_fail(make_ns("io_ns_b4", "\"fl_x\": 16, \"fl_y\": 16, \"cx\": 8, \"cy\": 6, \"w\": \"16\", \"h\": 12", ""), 0, MGS_ERR_FORMAT,
                   "transforms.json", "'w' must be a number");
  expect_load_fail(make_ns("io_ns_b5", NS_TOP, ", \"fl_x\": -5"), 0, MGS_ERR_FORMAT, "transforms.json: frame 5", "positive");
  expect_load_fail(make_ns("io_ns_b6", NS_TOP ", \"ply_file_path\": \"missing.ply\"", ""), 0, MGS_ERR_IO, "missing.ply", NULL);
  expect_load_fail(make_ns("io_ns_b7", "\"fl_x\": 16, \"fl_y\": 16, \"cx\": 8, \"cy\": 6, \"w\": 16.5, \"h\": 12", ""), 0, MGS_ERR_FORMAT,
                   "transforms.json", "integers");
}

/* ---------------- COLMAP ---------------- */

enum { CM_GOOD = 0, CM_SIMPLE_RADIAL, CM_TRUNCATE_IMAGES, CM_UNKNOWN_CAMERA, CM_HUGE_COUNT, CM_OPENCV, CM_HUGE_POINTS };

#define SQRT_HALF 0.70710678118654752440

/* Nine images img_00..img_08 (stored in shuffled order); img_03 uses camera 2
 * (SIMPLE_PINHOLE f=20) rotated 90 degrees about y, the others camera 1 (PINHOLE f=16)
 * with identity rotation; all t = (0, 0, 4). Three points. */
static const char *make_colmap(const char *name, int binary, int variant) {
  const char *dir = mgs_test_tmpdir(name);
  static char d[4096];
  snprintf(d, sizeof d, "%s", dir);
  io_mkdir(join(d, "images"));
  io_mkdir(join(d, "sparse/0"));
  static const int order[9] = {4, 0, 8, 3, 1, 7, 2, 6, 5};
  for (int i = 0; i < 9; i++) {
    char img[64];
    snprintf(img, sizeof img, "images/img_%02d.png", i);
    io_write_png(join(d, img), 16, 12, 3);
  }
  if (binary) {
    io_buf b = {0};
    io_u64(&b, 2);
    io_u32(&b, 1);
    io_i32(&b, variant == CM_SIMPLE_RADIAL ? 2 : 1); /* PINHOLE (or SIMPLE_RADIAL: also 4 params) */
    io_u64(&b, 16);
    io_u64(&b, 12);
    const double p1[4] = {16, 16, 8, 6};
    for (int k = 0; k < 4; k++) io_f64(&b, p1[k]);
    io_u32(&b, 2);
    io_i32(&b, 0); /* SIMPLE_PINHOLE */
    io_u64(&b, 16);
    io_u64(&b, 12);
    io_f64(&b, 20);
    io_f64(&b, 8);
    io_f64(&b, 6);
    io_write_bytes(join(d, "sparse/0/cameras.bin"), b.p, b.n);
    b.n = 0;
    io_u64(&b, variant == CM_HUGE_COUNT ? (1ull << 60) : 9);
    for (int j = 0; j < 9; j++) {
      int i = order[j];
      io_u32(&b, (uint32_t)(100 + i));
      if (i == 3) { io_f64(&b, SQRT_HALF); io_f64(&b, 0); io_f64(&b, SQRT_HALF); io_f64(&b, 0); }
      else { io_f64(&b, 1); io_f64(&b, 0); io_f64(&b, 0); io_f64(&b, 0); }
      io_f64(&b, 0);
      io_f64(&b, 0);
      io_f64(&b, 4);
      io_u32(&b, variant == CM_UNKNOWN_CAMERA && i == 6 ? 7 : (i == 3 ? 2 : 1));
      char nm[32];
      snprintf(nm, sizeof nm, "img_%02d.png", i);
      io_str(&b, nm);
      io_u64(&b, 2); /* two 2D points: x, y, point3D_id */
      for (int k = 0; k < 2; k++) { io_f64(&b, 1.5 * k); io_f64(&b, 2.5); io_u64(&b, (uint64_t)-1); }
    }
    io_write_bytes(join(d, "sparse/0/images.bin"), b.p, variant == CM_TRUNCATE_IMAGES ? b.n - 10 : b.n);
    b.n = 0;
    io_u64(&b, variant == CM_HUGE_POINTS ? (1ull << 31) : 3); /* issue 13: 2^31 points in ~200 bytes */
    for (int i = 0; i < 3; i++) {
      io_u64(&b, (uint64_t)(i + 1));
      io_f64(&b, i);
      io_f64(&b, 2 * i);
      io_f64(&b, -i);
      unsigned char rgb[3] = {(unsigned char)(10 * i), 255, 0};
      io_put(&b, rgb, 3);
      io_f64(&b, 0.5);
      io_u64(&b, 2);
      for (int k = 0; k < 2; k++) { io_i32(&b, 100 + k); io_i32(&b, k); }
    }
    io_write_bytes(join(d, "sparse/0/points3D.bin"), b.p, b.n);
    free(b.p);
  } else {
    char buf[8192];
    snprintf(buf, sizeof buf, "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                              "# Number of cameras: 2\n1 %s 16 12 16 16 8 6%s\n2 SIMPLE_PINHOLE 16 12 20 8 6\n",
             variant == CM_OPENCV ? "OPENCV" : "PINHOLE", variant == CM_OPENCV ? " 0.1 0 0 0" : "");
    io_write_text(join(d, "sparse/0/cameras.txt"), buf);
    int len = snprintf(buf, sizeof buf, "# Image list with two lines of data per image:\n"
                                        "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n#   POINTS2D[] as (X, Y, POINT3D_ID)\n");
    for (int j = 0; j < 9; j++) {
      int i = order[j];
      if (i == 3)
        len += snprintf(buf + len, sizeof buf - (size_t)len, "%d %.17g 0 %.17g 0 0 0 4 2 img_%02d.png\n\n", 100 + i, SQRT_HALF, SQRT_HALF, i);
      else
        len += snprintf(buf + len, sizeof buf - (size_t)len, "%d 1 0 0 0 0 0 4 %d img_%02d.png\n1.5 2.5 -1 3 2.5 -1\n", 100 + i,
                        variant == CM_UNKNOWN_CAMERA && i == 6 ? 7 : 1, i);
    }
    io_write_text(join(d, "sparse/0/images.txt"), buf);
    io_write_text(join(d, "sparse/0/points3D.txt"), "# 3D point list\n1 0 0 0 0 255 0 0.5 100 0 101 1\n2 1 2 -1 10 255 0 0.5 100 1\n"
                                                    "3 2 4 -2 20 255 0 0.5 100 0 101 1\n");
  }
  return d;
}

static void check_colmap_good(const char *dir) {
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = 1;
  mgs_dataset *d = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  if (!d) return;
  CHECK(d->format == MGS_DATASET_COLMAP);
  CHECK(d->white_background == 0 && d->background[0] == 0.0f); /* the reference's default */
  CHECK(d->n_views[MGS_SPLIT_TRAIN] == 7 && d->n_views[MGS_SPLIT_TEST] == 2);
  CHECK(strcmp(d->views[MGS_SPLIT_TEST][0].name, "img_00") == 0 && strcmp(d->views[MGS_SPLIT_TEST][1].name, "img_08") == 0);
  const mgs_view *v1 = &d->views[MGS_SPLIT_TRAIN][0], *v3 = &d->views[MGS_SPLIT_TRAIN][2];
  CHECK(strcmp(v1->name, "img_01") == 0 && strcmp(v3->name, "img_03") == 0);
  CHECK(strstr(v1->image_path, "images/img_01.png") != NULL);
  /* identity rotation, t = (0,0,4): (0.5,0.25,0) -> cam (0.5,0.25,4) -> (8 + 2, 6 + 1) */
  check_project(&v1->cam, 0.5, 0.25, 0, 10, 7);
  /* R_y(90): (x,y,z) -> (z, y, -x) + t: (0,0.25,0.5) -> (0.5, 0.25, 4); f = 20 */
  check_project(&v3->cam, 0, 0.25, 0.5, 10.5, 7.25);
  double c[3];
  mgs_camera_center(&v3->cam, c); /* C = -R^T t = -(R^T (0,0,4)) = -(-4, 0, 0) */
  CHECK_NEAR(c[0], 4, 1e-12);
  CHECK_NEAR(c[2], 0, 1e-12);
  CHECK(d->init_points && d->init_points->n == 3);
  if (d->init_points && d->init_points->n == 3) {
    CHECK(d->init_points->xyz[3] == 1 && d->init_points->xyz[4] == 2 && d->init_points->xyz[5] == -1);
    CHECK_NEAR(d->init_points->rgb[3], 10 / 255.0, 1e-7);
    CHECK_NEAR(d->init_points->rgb[4], 1, 1e-7);
  }
  CHECK(v1->image && v1->image->width == 16);
  mgs_dataset_destroy(d);
}

static void test_colmap(void) {
  check_colmap_good(make_colmap("io_colmap_bin", 1, CM_GOOD));
  check_colmap_good(make_colmap("io_colmap_txt", 0, CM_GOOD));
  /* the same camera as the NeRF-synthetic test, by hand in COLMAP text: at (0,0,4)
     looking down -z is R = diag(1,-1,-1) = q (0,1,0,0), t = -R C = (0,0,4) */
  const char *dir = mgs_test_tmpdir("io_colmap_cross");
  char d[4096];
  snprintf(d, sizeof d, "%s", dir);
  io_mkdir(join(d, "images"));
  io_mkdir(join(d, "sparse/0"));
  io_write_png(join(d, "images/r_0.png"), 16, 12, 4);
  io_write_text(join(d, "sparse/0/cameras.txt"), "1 PINHOLE 16 12 16 16 8 6\n");
  io_write_text(join(d, "sparse/0/images.txt"), "1 0 1 0 0 0 0 4 1 r_0.png\n\n");
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  mgs_dataset *ds = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_dataset_load(d, &o, &ds, &err), &err);
  if (ds) {
    CHECK(ds->n_views[MGS_SPLIT_TRAIN] == 1 && ds->init_points == NULL);
    if (ds->n_views[MGS_SPLIT_TRAIN] == 1) check_project(&ds->views[MGS_SPLIT_TRAIN][0].cam, 0.5, 0.25, 0, 10, 5);
    CHECK(ds->mesh_path == NULL);
    mgs_dataset_destroy(ds);
  }
  /* a GT mesh beside sparse/ (scripts/colmap_scene.sh writes it in the SfM frame) is the
     dataset's, for eval's geometry metrics */
  io_write_text(join(d, "gt_mesh.ply"), "ply\n");
  ds = NULL;
  CHECK_OK(mgs_dataset_load(d, &o, &ds, &err), &err);
  if (ds) CHECK(ds->mesh_path && strstr(ds->mesh_path, "io_colmap_cross/gt_mesh.ply"));
  mgs_dataset_destroy(ds);
}

/* --images images_2 (the reference's -i, as Mip-NeRF 360 ships images_2/4/8 beside the
 * full-size images/ with the full-size cameras): each camera scaled to its image, the same
 * cameras as --downscale 2 of the full-size folder; a folder that is missing, or an image
 * of another aspect ratio, is a named error. */
static void test_colmap_images_folder(void) {
  const char *dir = make_colmap("io_colmap_i2", 0, CM_GOOD);
  io_mkdir(join(dir, "images_2"));
  for (int i = 0; i < 9; i++) {
    char img[64];
    snprintf(img, sizeof img, "images_2/img_%02d.png", i);
    io_write_png(join(dir, img), 8, 6, 3);
  }
  mgs_dataset_options o, oh;
  mgs_dataset_options_default(&o);
  o.load_images = 1;
  o.images = "images_2";
  oh = o;
  oh.images = NULL;
  oh.downscale = 2;
  mgs_dataset *d = NULL, *h = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  CHECK_OK(mgs_dataset_load(dir, &oh, &h, &err), &err);
  if (d && h && d->n_views[MGS_SPLIT_TRAIN] == 7 && h->n_views[MGS_SPLIT_TRAIN] == 7) {
    const mgs_view *v1 = &d->views[MGS_SPLIT_TRAIN][0], *v3 = &d->views[MGS_SPLIT_TRAIN][2];
    CHECK(strstr(v1->image_path, "images_2/img_01.png") != NULL);
    CHECK(v1->cam.width == 8 && v1->cam.height == 6 && v1->image && v1->image->width == 8);
    check_project(&v1->cam, 0.5, 0.25, 0, 5, 3.5);     /* f 16 -> 8, c (8, 6) -> (4, 3) */
    check_project(&v3->cam, 0, 0.25, 0.5, 5.25, 3.625); /* SIMPLE_PINHOLE f 20 -> 10 */
    for (size_t i = 0; i < 7; i++) {
      const mgs_camera *a = &d->views[MGS_SPLIT_TRAIN][i].cam, *b = &h->views[MGS_SPLIT_TRAIN][i].cam;
      CHECK(a->width == b->width && a->height == b->height);
      CHECK_NEAR(a->fx, b->fx, 1e-12);
      CHECK_NEAR(a->fy, b->fy, 1e-12);
      CHECK_NEAR(a->cx, b->cx, 1e-12);
      CHECK_NEAR(a->cy, b->cy, 1e-12);
    }
    CHECK_NEAR(d->extent, h->extent, 1e-12);
  }
  mgs_dataset_destroy(d);
  mgs_dataset_destroy(h);
  /* another aspect ratio: named */
  io_write_png(join(dir, "images_2/img_05.png"), 8, 8, 3);
  d = NULL;
  CHECK(mgs_dataset_load(dir, &o, &d, &err) == MGS_ERR_FORMAT && d == NULL);
  CHECK_MSG(strstr(err.msg, "images_2/img_05.png") && strstr(err.msg, "aspect ratio"), "%s", err.msg);
  /* an absolute folder is taken as it is (os.path.join's rule, as the reference) */
  {
    char abs_dir[PATH_MAX];
    CHECK(realpath(join(dir, "images_2"), abs_dir) != NULL);
    io_write_png(join(dir, "images_2/img_05.png"), 8, 6, 3);
    o.images = abs_dir;
    CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
    if (d) CHECK(!strncmp(d->views[MGS_SPLIT_TRAIN][0].image_path, abs_dir, strlen(abs_dir)) &&
                 d->views[MGS_SPLIT_TRAIN][0].cam.width == 8);
    mgs_dataset_destroy(d);
    d = NULL;
  }
  /* a folder that is not there: named */
  o.images = "images_8";
  CHECK(mgs_dataset_load(dir, &o, &d, &err) == MGS_ERR_IO && d == NULL);
  CHECK_MSG(strstr(err.msg, "images_8: image folder not found"), "%s", err.msg);
}

/* nerfstudio's downscale folders (ns-process-data writes images_2/4/8): --images images_2
 * reads each frame's file name there, cameras scaled to the images (the same as
 * --downscale 2); a NeRF-synthetic dataset refuses another folder, naming it. */
static void test_images_folder_other_formats(void) {
  const char *dir = make_ns("io_ns_i2", NS_TOP, ", \"fl_x\": 32");
  io_mkdir(join(dir, "images_2"));
  for (int i = 0; i < 9; i++) {
    char img[64];
    snprintf(img, sizeof img, "images_2/frame_%02d.png", i);
    io_write_png(join(dir, img), 8, 6, 3);
  }
  mgs_dataset_options o, oh;
  mgs_dataset_options_default(&o);
  o.load_images = 1;
  o.images = "images_2";
  oh = o;
  oh.images = NULL;
  oh.downscale = 2;
  mgs_dataset *d = NULL, *h = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_dataset_load(dir, &o, &d, &err), &err);
  CHECK_OK(mgs_dataset_load(dir, &oh, &h, &err), &err);
  if (d && h && d->n_views[MGS_SPLIT_TRAIN] == 7 && h->n_views[MGS_SPLIT_TRAIN] == 7) {
    CHECK(strstr(d->views[MGS_SPLIT_TRAIN][2].image_path, "images_2/frame_03.png") != NULL);
    check_project(&d->views[MGS_SPLIT_TRAIN][2].cam, 0.5, 0.25, 0, 6, 2.5); /* fl_x 32 -> 16 */
    for (size_t i = 0; i < 7; i++) {
      const mgs_camera *a = &d->views[MGS_SPLIT_TRAIN][i].cam, *b = &h->views[MGS_SPLIT_TRAIN][i].cam;
      CHECK(a->width == 8 && a->width == b->width && a->height == b->height);
      CHECK_NEAR(a->fx, b->fx, 1e-12);
      CHECK_NEAR(a->cy, b->cy, 1e-12);
    }
  }
  mgs_dataset_destroy(d);
  mgs_dataset_destroy(h);
  /* NeRF-synthetic: refused, named */
  dir = make_nerf("io_nerf_i2", good_train_json);
  io_mkdir(join(dir, "images_2"));
  d = NULL;
  CHECK(mgs_dataset_load(dir, &o, &d, &err) == MGS_ERR_ARG && d == NULL);
  CHECK_MSG(strstr(err.msg, "NeRF-synthetic") && strstr(err.msg, "images_2"), "%s", err.msg);
}

static void test_colmap_bad(void) {
  expect_load_fail(make_colmap("io_cm_b1", 1, CM_SIMPLE_RADIAL), 0, MGS_ERR_UNSUPPORTED, "cameras.bin", "SIMPLE_RADIAL");
  expect_load_fail(make_colmap("io_cm_b2", 0, CM_OPENCV), 0, MGS_ERR_UNSUPPORTED, "cameras.txt", "OPENCV");
  expect_load_fail(make_colmap("io_cm_b3", 1, CM_TRUNCATE_IMAGES), 0, MGS_ERR_FORMAT, "images.bin", "truncated");
  expect_load_fail(make_colmap("io_cm_b4", 1, CM_UNKNOWN_CAMERA), 0, MGS_ERR_FORMAT, "images.bin", "camera 7");
  expect_load_fail(make_colmap("io_cm_b5", 0, CM_UNKNOWN_CAMERA), 0, MGS_ERR_FORMAT, "images.txt", "camera 7");
  expect_load_fail(make_colmap("io_cm_b6", 1, CM_HUGE_COUNT), 0, MGS_ERR_FORMAT, "images.bin", "does not fit");
  expect_load_fail(make_colmap("io_cm_b6p", 1, CM_HUGE_POINTS), 0, MGS_ERR_FORMAT, "points3D.bin", "2147483648");
  const char *dir = make_colmap("io_cm_b7", 1, CM_GOOD);
  unlink(join(dir, "images/img_04.png"));
  expect_load_fail(dir, 0, MGS_ERR_IO, "img_04.png", "not found");
  dir = make_colmap("io_cm_b8", 0, CM_GOOD);
  io_write_png(join(dir, "images/img_02.png"), 16, 13, 3);
  expect_load_fail(dir, 1, MGS_ERR_FORMAT, "img_02.png", "16x13");
  dir = make_colmap("io_cm_b9", 0, CM_GOOD);
  io_write_text(join(dir, "sparse/0/images.txt"), "# header\n1 1 0 zero 0 0 0 4 1 img_00.png\n\n");
  expect_load_fail(dir, 0, MGS_ERR_FORMAT, "images.txt", "line 2");
  dir = make_colmap("io_cm_b10", 0, CM_GOOD);
  io_write_text(join(dir, "sparse/0/cameras.txt"), "1 SIMPLE_RADIAL 16 12 16 8 6 0.01\n");
  expect_load_fail(dir, 0, MGS_ERR_UNSUPPORTED, "cameras.txt", "SIMPLE_RADIAL");
  dir = make_colmap("io_cm_b11", 0, CM_GOOD);
  io_write_text(join(dir, "sparse/0/points3D.txt"), "1 0 0 nan 0 255 0 0.5\n");
  expect_load_fail(dir, 0, MGS_ERR_FORMAT, "points3D.txt", "line 1");
  dir = make_colmap("io_cm_b12", 1, CM_GOOD);
  io_write_bytes(join(dir, "sparse/0/cameras.bin"), "\x01\0\0\0\0\0\0\0\x01\0\0\0\x63\0\0\0", 16);
  expect_load_fail(dir, 0, MGS_ERR_FORMAT, "cameras.bin", NULL);
  /* fuzz_colmap_bin's finding: a focal length of 3.5e-323 px passed "> 0" and became 0
     when the 33296 px wide image was resized to 1600 */
  dir = make_colmap("io_cm_b13", 0, CM_GOOD);
  io_write_text(join(dir, "sparse/0/cameras.txt"), "1 PINHOLE 16 12 3.5e-323 16 8 6\n");
  expect_load_fail(dir, 0, MGS_ERR_FORMAT, "cameras.txt", "180 degrees");
  dir = make_colmap("io_cm_b14", 0, CM_GOOD);
  io_write_text(join(dir, "sparse/0/cameras.txt"), "1 PINHOLE 16 12 16 1e300 8 6\n");
  expect_load_fail(dir, 0, MGS_ERR_FORMAT, "cameras.txt", "field of view");
}

int main(void) {
  RUN(test_nerf_synthetic);
  RUN(test_far_origin);
  RUN(test_nerf_bad);
  RUN(test_nerfstudio);
  RUN(test_nerfstudio_bad);
  RUN(test_colmap);
  RUN(test_colmap_images_folder);
  RUN(test_images_folder_other_formats);
  RUN(test_colmap_bad);
  return mgs_test_finish();
}
