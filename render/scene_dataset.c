/* The dataset writer of `morsegs scene`: checks the mesh and the output folder, renders
 * every view into a staging folder beside the target, writes the NeRF-synthetic JSON
 * (cJSON), the normalized mesh, the initial points and a scene.json record, then renames
 * the staging folder into place. Any failure removes the staging folder, so nothing
 * partial is ever left at -o. */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cjson/cJSON.h>
#include "render/mgs_scene.h"
#include "render/scene_internal.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "core/mgs_ply.h"
#include "core/mgs_rng.h"

void mgs_scene_options_default(mgs_scene_options *o) {
  memset(o, 0, sizeof *o);
  o->n_train = 60;
  o->n_test = 20;
  o->width = 200;
  o->height = 200;
  o->fovx = 0.6911112070083618; /* NeRF-synthetic's camera_angle_x */
  o->spp = 4;
  o->texture_scale = 1.0;
  o->white_background = 1;
  o->init = MGS_SCENE_INIT_SURFACE;
  o->init_noise = 0.01;
}

static const char *mesh_label(const mgs_scene_options *o) { return o && o->mesh_name ? o->mesh_name : "mesh"; }

mgs_status mgs_scene_check_mesh(const mgs_mesh *m, const mgs_scene_options *o, mgs_error *err) {
  const char *name = mesh_label(o);
  if (!m || m->nv == 0 || m->nt == 0 || !m->v || !m->t)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: mesh is empty (%zu vertices, %zu triangles)", name, m ? m->nv : 0, m ? m->nt : 0);
  for (size_t i = 0; i < m->nv * 3; i++)
    if (!isfinite(m->v[i]))
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: vertex %zu has a non-finite coordinate", name, i / 3);
  for (size_t i = 0; i < m->nt * 3; i++)
    if (m->t[i] >= m->nv)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: triangle %zu uses vertex %u but the mesh has %zu", name, i / 3, m->t[i], m->nv);
  double lo[3], hi[3];
  mgs_mesh_bounds(m, lo, hi);
  if (!(hi[0] - lo[0] > 0 || hi[1] - lo[1] > 0 || hi[2] - lo[2] > 0))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: mesh is degenerate (all vertices at one point)", name);
  if (!(o && o->allow_open)) {
    size_t bad = mgs_mesh_count_boundary_or_nonmanifold_edges(m);
    if (bad)
      return mgs_error_set(err, MGS_ERR_FORMAT,
                           "%s: mesh is not a closed manifold surface (%zu boundary or non-manifold edges); pass --allow-open to render it anyway",
                           name, bad);
  }
  return MGS_OK;
}

static mgs_status check_options(const mgs_scene_options *o, mgs_error *err) {
  if (o->n_train < 1 || o->n_test < 0 || o->n_train > 100000 || o->n_test > 100000)
    return mgs_error_set(err, MGS_ERR_ARG, "scene: view counts must be train >= 1, test >= 0 (got %d, %d)", o->n_train, o->n_test);
  if (o->width < 1 || o->height < 1 || o->width > 16384 || o->height > 16384)
    return mgs_error_set(err, MGS_ERR_ARG, "scene: image size %dx%d out of range (1..16384)", o->width, o->height);
  if (!(o->fovx > 0.01 && o->fovx < 3.1))
    return mgs_error_set(err, MGS_ERR_ARG, "scene: field of view %g rad out of range", o->fovx);
  if (o->spp < 1 || o->spp > 16) return mgs_error_set(err, MGS_ERR_ARG, "scene: --spp %d out of range (1..16)", o->spp);
  if (!(o->texture_scale > 0 && o->texture_scale <= 1000))
    return mgs_error_set(err, MGS_ERR_ARG, "scene: --texture-scale %g out of range (0 < F <= 1000)", o->texture_scale);
  if (!(o->radius >= 0) || !isfinite(o->radius)) return mgs_error_set(err, MGS_ERR_ARG, "scene: bad camera radius %g", o->radius);
  if (!(o->init_noise >= 0) || !isfinite(o->init_noise)) return mgs_error_set(err, MGS_ERR_ARG, "scene: bad init noise %g", o->init_noise);
  if (o->init != MGS_SCENE_INIT_NONE && o->init != MGS_SCENE_INIT_RANDOM && o->init != MGS_SCENE_INIT_SURFACE)
    return mgs_error_set(err, MGS_ERR_ARG, "scene: unknown init mode %d", (int)o->init);
  if (o->init_points > 50000000) return mgs_error_set(err, MGS_ERR_ARG, "scene: --init-points %zu too large", o->init_points);
  return MGS_OK;
}

/* 0 = absent, 1 = empty directory, 2 = holds a dataset, 3 = holds other files, 4 = not a directory. */
static int out_dir_state(const char *dir) {
  if (!mgs_path_exists(dir)) return 0;
  if (!mgs_is_dir(dir)) return 4;
  DIR *d = opendir(dir);
  if (!d) return 3;
  int any = 0, dataset = 0;
  struct dirent *e;
  while ((e = readdir(d))) {
    if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
    any = 1;
    if (!strcmp(e->d_name, "transforms_train.json") || !strcmp(e->d_name, "transforms_test.json") ||
        !strcmp(e->d_name, "scene.json"))
      dataset = 1;
  }
  closedir(d);
  return dataset ? 2 : (any ? 3 : 1);
}

static mgs_status check_out_dir(const char *dir, int force, int *state, mgs_error *err) {
  *state = out_dir_state(dir);
  switch (*state) {
  case 2:
    if (!force)
      return mgs_error_set(err, MGS_ERR_EXISTS, "%s: already holds a dataset; pass --force to replace it", dir);
    return MGS_OK;
  case 3:
    return mgs_error_set(err, MGS_ERR_EXISTS, "%s: exists and holds files that are not a dataset; refusing to write there (even with --force)", dir);
  case 4:
    return mgs_error_set(err, MGS_ERR_EXISTS, "%s: exists and is not a directory", dir);
  default:
    return MGS_OK;
  }
}

/* "<parent>/.<base>.<tag>-<pid>": a sibling, so the final rename stays on one file system. */
static char *sibling_path(const char *dir, const char *tag) {
  char *parent = mgs_path_dirname(dir);
  if (!parent) return NULL;
  size_t n = strlen(dir);
  while (n > 1 && dir[n - 1] == '/') n--;
  size_t b = n;
  while (b > 0 && dir[b - 1] != '/') b--;
  char name[512];
  snprintf(name, sizeof name, ".%.*s.%s-%ld", (int)(n - b > 300 ? 300 : n - b), dir + b, tag, (long)getpid());
  char *p = mgs_path_join(parent, name);
  free(parent);
  return p;
}

static cJSON *matrix_json(const double m[16]) {
  cJSON *rows = cJSON_CreateArray();
  for (int i = 0; i < 4; i++) cJSON_AddItemToArray(rows, cJSON_CreateDoubleArray(m + 4 * i, 4));
  return rows;
}

static mgs_status write_json(const char *path, cJSON *root, mgs_error *err) {
  char *text = cJSON_Print(root);
  if (!text) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot format JSON", path);
  size_t len = strlen(text);
  mgs_status s = mgs_write_file_atomic(path, text, len, err);
  cJSON_free(text);
  return s;
}

static mgs_status write_transforms(const char *path, const char *split, const mgs_scene_options *o,
                                   const mgs_camera *cams, int n, mgs_error *err) {
  cJSON *root = cJSON_CreateObject();
  cJSON_AddNumberToObject(root, "camera_angle_x", n > 0 ? mgs_camera_fovx(&cams[0]) : o->fovx);
  cJSON *frames = cJSON_AddArrayToObject(root, "frames");
  for (int i = 0; i < n; i++) {
    cJSON *f = cJSON_CreateObject();
    char fp[64];
    snprintf(fp, sizeof fp, "./%s/r_%d", split, i);
    cJSON_AddStringToObject(f, "file_path", fp);
    cJSON_AddNumberToObject(f, "rotation", 0.0);
    double m[16];
    mgs_camera_get_c2w_opengl(&cams[i], m);
    cJSON_AddItemToObject(f, "transform_matrix", matrix_json(m));
    cJSON_AddItemToArray(frames, f);
  }
  mgs_status s = write_json(path, root, err);
  cJSON_Delete(root);
  return s;
}

/* The appearance used (mgs_scene_render_dataset): the texture if it reads, else the
   colours, else procedural. A texture that does not read is a warning, not an error: the
   dataset is still a valid one, only with another look (recorded in scene.json). */
typedef struct {
  mgs_texture *tex;
  const char *name;          /* "texture", "vertex colors", "procedural" */
  char unusable[MGS_ERROR_MSG_MAX]; /* why the mesh's texture was not used ("" if it was or none) */
} scene_appearance;

static void choose_appearance(const mgs_mesh *m, const mgs_scene_options *o, scene_appearance *a) {
  memset(a, 0, sizeof *a);
  a->name = "procedural";
  if (o->procedural_texture) return;
  if (m->texture && m->uv) {
    mgs_error terr;
    mgs_error_clear(&terr);
    if (mgs_texture_read(m->texture, &a->tex, &terr) == MGS_OK) {
      a->name = "texture";
      return;
    }
    snprintf(a->unusable, sizeof a->unusable, "%s", terr.msg);
    mgs_warn("scene: %s: cannot use its texture %s (%s); rendering with %s instead (scene.json records it)", mesh_label(o),
             m->texture, terr.msg, m->rgb ? "its vertex colours" : "the procedural texture");
  }
  if (m->rgb) a->name = "vertex colors";
}

static mgs_status make_init_points(const mgs_mesh *m, const mgs_scene_options *o, const mgs_scene_look *look,
                                   mgs_point_cloud *pc, mgs_error *err) {
  size_t n = o->init_points ? o->init_points : (o->init == MGS_SCENE_INIT_RANDOM ? 100000 : 10000);
  pc->n = n;
  pc->xyz = malloc(n * 3 * sizeof(float));
  pc->rgb = malloc(n * 3 * sizeof(float));
  if (!pc->xyz || !pc->rgb) return mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory for %zu init points", n);
  mgs_rng rng;
  mgs_rng_init(&rng, o->seed, 0x1a17u);
  if (o->init == MGS_SCENE_INIT_RANDOM) {
    /* As the reference does for NeRF-synthetic: uniform in [-1.3, 1.3]^3, colour from a
       near-zero random SH DC (so ~0.5 grey). */
    for (size_t i = 0; i < n; i++) {
      for (int c = 0; c < 3; c++) pc->xyz[3 * i + c] = (float)(mgs_rng_uniform(&rng) * 2.6 - 1.3);
      for (int c = 0; c < 3; c++) pc->rgb[3 * i + c] = (float)(0.5 + 0.28209479177387814 * mgs_rng_uniform(&rng) / 255.0);
    }
    return MGS_OK;
  }
  /* Surface: area-weighted samples with Gaussian noise, coloured by the albedo (an SfM
     stand-in: points near the surface carrying roughly the right colour). */
  double *cdf = malloc(m->nt * sizeof(double));
  if (!cdf) return mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory for %zu triangles", m->nt);
  double total = 0;
  for (size_t t = 0; t < m->nt; t++) {
    const float *a = m->v + 3 * m->t[3 * t], *b = m->v + 3 * m->t[3 * t + 1], *c = m->v + 3 * m->t[3 * t + 2];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double x = e1[1] * e2[2] - e1[2] * e2[1], y = e1[2] * e2[0] - e1[0] * e2[2], z = e1[0] * e2[1] - e1[1] * e2[0];
    total += 0.5 * sqrt(x * x + y * y + z * z);
    cdf[t] = total;
  }
  if (!(total > 0)) { free(cdf); return mgs_error_set(err, MGS_ERR_FORMAT, "%s: mesh has zero area", mesh_label(o)); }
  double sigma = o->init_noise * 2.0;
  for (size_t i = 0; i < n; i++) {
    double u = mgs_rng_uniform(&rng) * total;
    size_t lo = 0, hi = m->nt - 1;
    while (lo < hi) { size_t mid = (lo + hi) / 2; if (cdf[mid] < u) lo = mid + 1; else hi = mid; }
    const float *a = m->v + 3 * m->t[3 * lo], *b = m->v + 3 * m->t[3 * lo + 1], *c = m->v + 3 * m->t[3 * lo + 2];
    double r1 = sqrt(mgs_rng_uniform(&rng)), r2 = mgs_rng_uniform(&rng);
    double wa = 1 - r1, wb = r1 * (1 - r2), wc = r1 * r2;
    float p[3];
    for (int k = 0; k < 3; k++) p[k] = (float)(wa * a[k] + wb * b[k] + wc * c[k]);
    mgs_scene_look_albedo(look, lo, (float)wb, (float)wc, p, pc->rgb + 3 * i);
    for (int k = 0; k < 3; k++) pc->xyz[3 * i + k] = (float)(p[k] + sigma * mgs_rng_normal(&rng));
  }
  free(cdf);
  return MGS_OK;
}

static mgs_status write_scene_record(const char *path, const mgs_mesh *m, const mgs_scene_options *o, double radius,
                                     double scale, const double center[3], const scene_appearance *a, mgs_error *err) {
  static const char *init_names[] = {"none", "random", "surface"};
  cJSON *root = cJSON_CreateObject();
  cJSON_AddStringToObject(root, "generator", "morsegs scene");
  cJSON_AddStringToObject(root, "mesh", mesh_label(o));
  cJSON_AddNumberToObject(root, "vertices", (double)m->nv);
  cJSON_AddNumberToObject(root, "triangles", (double)m->nt);
  cJSON_AddNumberToObject(root, "seed", (double)o->seed);
  cJSON_AddNumberToObject(root, "n_train", o->n_train);
  cJSON_AddNumberToObject(root, "n_test", o->n_test);
  cJSON_AddNumberToObject(root, "width", o->width);
  cJSON_AddNumberToObject(root, "height", o->height);
  cJSON_AddNumberToObject(root, "camera_angle_x", o->fovx);
  cJSON_AddNumberToObject(root, "camera_radius", radius);
  cJSON_AddBoolToObject(root, "hemisphere", o->hemisphere != 0);
  cJSON_AddBoolToObject(root, "specular", o->specular != 0);
  cJSON_AddNumberToObject(root, "texture_scale", o->texture_scale);
  cJSON_AddStringToObject(root, "appearance", a->name);
  if (a->tex) {
    cJSON_AddStringToObject(root, "texture", m->texture);
    int wh[2] = {mgs_texture_width(a->tex), mgs_texture_height(a->tex)};
    cJSON_AddItemToObject(root, "texture_size", cJSON_CreateIntArray(wh, 2));
  } else if (a->unusable[0]) {
    cJSON_AddStringToObject(root, "texture_unusable", a->unusable);
  }
  cJSON_AddNumberToObject(root, "spp", o->spp);
  cJSON_AddStringToObject(root, "background", o->white_background ? "white" : "black");
  cJSON_AddStringToObject(root, "init", init_names[o->init]);
  if (o->city_size > 0) cJSON_AddNumberToObject(root, "city_size", o->city_size);
  cJSON *norm = cJSON_AddObjectToObject(root, "normalization");
  cJSON_AddNumberToObject(norm, "scale", scale);
  cJSON_AddItemToObject(norm, "center", cJSON_CreateDoubleArray(center, 3));
  cJSON_AddStringToObject(norm, "note", "gt = (source - center) * scale");
  mgs_status s = write_json(path, root, err);
  cJSON_Delete(root);
  return s;
}

/* Renders and writes everything into `stage` (which exists and is empty). */
static mgs_status build_into(const char *stage, mgs_mesh *m, const mgs_scene_options *o, double scale,
                             const double center[3], mgs_scene_stats *st, mgs_error *err) {
  mgs_status s;
  double bound = 0;
  for (size_t i = 0; i < m->nv; i++) {
    const float *p = m->v + 3 * i;
    double r = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
    if (r > bound) bound = r;
  }
  double radius = mgs_scene_camera_radius(o, bound);
  scene_appearance look_used;
  choose_appearance(m, o, &look_used);
  st->appearance = look_used.name;
  const mgs_scene_look look = {o->procedural_texture ? NULL : m->uv, look_used.tex, o->procedural_texture ? NULL : m->rgb,
                               (float)o->texture_scale};
  mgs_scene_renderer *r = NULL;
  if ((s = mgs_scene_renderer_create(m, &r, err))) { mgs_texture_destroy(look_used.tex); return s; }
  mgs_image *img = NULL;
  mgs_camera *cams = NULL;
  if (!o->procedural_texture && (s = mgs_scene_renderer_set_appearance(r, m, look_used.tex, err))) goto done;
  int counts[2] = {o->n_train, o->n_test};
  const char *splits[2] = {"train", "test"};
  cams = malloc((size_t)(counts[0] > counts[1] ? counts[0] : counts[1]) * sizeof(mgs_camera));
  img = mgs_image_create(o->width, o->height, 4);
  if (!cams || !img) { s = mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory"); goto done; }
  mgs_progress *bar = o->quiet ? NULL : mgs_progress_create("scene", (size_t)(counts[0] + counts[1]));
  size_t done_views = 0;
  for (int sp = 0; sp < 2 && s == MGS_OK; sp++) {
    char *sub = mgs_path_join(stage, splits[sp]);
    if (!sub) { s = mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory"); break; }
    if (counts[sp] > 0) s = mgs_mkdir_p(sub, err);
    if (o->city_size > 0) mgs_scene_city_cameras(o, sp, counts[sp], cams);
    else mgs_scene_make_cameras(o, sp, counts[sp], radius, cams);
    for (int i = 0; i < counts[sp] && s == MGS_OK; i++) {
      double t0 = mgs_now();
      st->rays += mgs_scene_render_view(r, &cams[i], o, (uint32_t)(sp * 1000003 + i), img);
      st->render_seconds += mgs_now() - t0;
      char name[64];
      snprintf(name, sizeof name, "r_%d.png", i);
      char *path = mgs_path_join(sub, name);
      s = path ? mgs_image_write(path, img, err) : mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory");
      free(path);
      st->views++;
      if (bar) mgs_progress_update(bar, ++done_views, splits[sp]);
    }
    free(sub);
    if (s == MGS_OK) {
      char jname[64];
      snprintf(jname, sizeof jname, "transforms_%s.json", splits[sp]);
      char *jpath = mgs_path_join(stage, jname);
      s = jpath ? write_transforms(jpath, splits[sp], o, cams, counts[sp], err) : mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory");
      free(jpath);
    }
  }
  if (bar) mgs_progress_destroy(bar);
  if (s == MGS_OK) {
    char *p = mgs_path_join(stage, "gt_mesh.ply");
    s = p ? mgs_mesh_write(p, m, err) : mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory");
    free(p);
  }
  if (s == MGS_OK && o->init != MGS_SCENE_INIT_NONE) {
    mgs_point_cloud pc = {0, NULL, NULL, NULL};
    s = make_init_points(m, o, &look, &pc, err);
    if (s == MGS_OK) {
      char *p = mgs_path_join(stage, "points3d.ply");
      s = p ? mgs_ply_write_points(p, &pc, err) : mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory");
      free(p);
    }
    free(pc.xyz);
    free(pc.rgb);
  }
  if (s == MGS_OK) {
    char *p = mgs_path_join(stage, "scene.json");
    s = p ? write_scene_record(p, m, o, radius, scale, center, &look_used, err) : mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory");
    free(p);
  }
done:
  mgs_image_destroy(img);
  free(cams);
  mgs_scene_renderer_destroy(r);
  mgs_texture_destroy(look_used.tex);
  return s;
}

static mgs_status render_dataset(const mgs_mesh *mesh, const mgs_scene_options *o, const char *out_dir,
                                 mgs_scene_stats *st, mgs_error *err);

mgs_status mgs_scene_render_dataset_stats(const mgs_mesh *mesh, const mgs_scene_options *o, const char *out_dir,
                                          mgs_scene_stats *stats, mgs_error *err) {
  mgs_scene_stats local;
  mgs_scene_stats *st = stats ? stats : &local;
  memset(st, 0, sizeof *st);
  double t_start = mgs_now();
  mgs_status s;
  if (!o || !out_dir || !*out_dir) return mgs_error_set(err, MGS_ERR_ARG, "scene: no output directory given");
  if ((s = check_options(o, err))) return s;
  /* "DIR/" and "DIR" are the same folder: drop trailing slashes (keep "/"). */
  char *dir_copy = mgs_strdup(out_dir);
  if (!dir_copy) return mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory");
  for (size_t n = strlen(dir_copy); n > 1 && dir_copy[n - 1] == '/'; n--) dir_copy[n - 1] = 0;
  s = render_dataset(mesh, o, dir_copy, st, err);
  free(dir_copy);
  st->total_seconds = mgs_now() - t_start;
  return s;
}

static mgs_status render_dataset(const mgs_mesh *mesh, const mgs_scene_options *o, const char *out_dir,
                                 mgs_scene_stats *st, mgs_error *err) {
  mgs_status s;
  if ((s = mgs_scene_check_mesh(mesh, o, err))) return s;
  int state;
  if ((s = check_out_dir(out_dir, o->force, &state, err))) return s;

  mgs_mesh *m = mgs_mesh_clone(mesh);
  if (!m) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory copying the mesh", mesh_label(o));
  double center[3] = {0, 0, 0};
  /* the city keeps its world units (its blocks' size must not depend on its size) */
  double scale = o->city_size > 0 ? 1.0 : mgs_mesh_normalize(m, 2.0, center);
  st->triangles = m->nt;

  char *stage = sibling_path(out_dir, "staging");
  char *old = sibling_path(out_dir, "old");
  char *parent = mgs_path_dirname(out_dir);
  if (!stage || !old || !parent) { s = mgs_error_set(err, MGS_ERR_NOMEM, "scene: out of memory"); goto out; }
  if ((s = mgs_mkdir_p(parent, err))) goto out;
  if (mgs_path_exists(stage) && (s = mgs_remove_tree(stage, err))) goto out;
  if ((s = mgs_mkdir_p(stage, err))) goto out;

  s = build_into(stage, m, o, scale, center, st, err);
  if (s == MGS_OK) {
    /* The folder may have changed while we rendered: check again before replacing. */
    s = check_out_dir(out_dir, o->force, &state, err);
  }
  if (s == MGS_OK) {
    if (state == 2) {
      if (rename(out_dir, old) != 0) {
        s = mgs_error_set(err, MGS_ERR_IO, "%s: cannot move the old dataset aside", out_dir);
      } else if (rename(stage, out_dir) != 0) {
        s = mgs_error_set(err, MGS_ERR_IO, "%s: cannot move the new dataset into place", out_dir);
        if (rename(old, out_dir) != 0) mgs_warn("scene: the previous dataset is left at %s", old);
      } else {
        mgs_error tmp;
        if (mgs_remove_tree(old, &tmp) != MGS_OK) mgs_warn("scene: could not remove %s: %s", old, tmp.msg);
      }
    } else if (rename(stage, out_dir) != 0) {
      s = mgs_error_set(err, MGS_ERR_IO, "%s: cannot move the dataset into place", out_dir);
    }
  }
  if (s != MGS_OK && mgs_path_exists(stage)) {
    mgs_error tmp;
    mgs_remove_tree(stage, &tmp);
  }
out:
  free(stage);
  free(old);
  free(parent);
  mgs_mesh_destroy(m);
  return s;
}

mgs_status mgs_scene_render_dataset(const mgs_mesh *mesh, const mgs_scene_options *o, const char *out_dir, mgs_error *err) {
  return mgs_scene_render_dataset_stats(mesh, o, out_dir, NULL, err);
}
