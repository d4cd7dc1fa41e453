/* The run folder in the reference 3DGS layout: cameras.json, cfg_args and
 * point_cloud/iteration_N/point_cloud.ply. */
#include <dirent.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <cjson/cJSON.h>
#include "train/mgs_train.h"
#include "core/mgs_fs.h"
#include "core/mgs_origin.h"
#include "core/mgs_ply.h"

mgs_status mgs_run_write_cameras(const char *run_dir, const mgs_dataset *ds, mgs_error *err) {
  cJSON *arr = cJSON_CreateArray();
  if (!arr) return mgs_error_set(err, MGS_ERR_NOMEM, "cameras.json: out of memory");
  int id = 0;
  const mgs_split order[2] = {MGS_SPLIT_TEST, MGS_SPLIT_TRAIN}; /* as the reference */
  for (int s = 0; s < 2; s++)
    for (size_t i = 0; i < ds->n_views[order[s]]; i++) {
      const mgs_view *v = &ds->views[order[s]][i];
      cJSON *c = cJSON_CreateObject();
      cJSON_AddNumberToObject(c, "id", id++);
      cJSON_AddStringToObject(c, "img_name", v->name ? v->name : "");
      cJSON_AddNumberToObject(c, "width", v->cam.width);
      cJSON_AddNumberToObject(c, "height", v->cam.height);
      /* world coordinates: the dataset's origin added back in double */
      double pos[3] = {ds->origin[0] + v->cam.c2w[3], ds->origin[1] + v->cam.c2w[7], ds->origin[2] + v->cam.c2w[11]};
      cJSON_AddItemToObject(c, "position", cJSON_CreateDoubleArray(pos, 3));
      cJSON *rot = cJSON_CreateArray();
      for (int r = 0; r < 3; r++) cJSON_AddItemToArray(rot, cJSON_CreateDoubleArray(v->cam.c2w + 4 * r, 3));
      cJSON_AddItemToObject(c, "rotation", rot);
      cJSON_AddNumberToObject(c, "fy", v->cam.fy);
      cJSON_AddNumberToObject(c, "fx", v->cam.fx);
      cJSON_AddItemToArray(arr, c);
    }
  char *text = cJSON_Print(arr);
  cJSON_Delete(arr);
  if (!text) return mgs_error_set(err, MGS_ERR_NOMEM, "cameras.json: out of memory");
  char *path = mgs_path_join(run_dir, "cameras.json");
  mgs_status st = mgs_write_file_atomic(path, text, strlen(text), err);
  free(path);
  free(text);
  return st;
}

mgs_status mgs_run_write_ply(const char *run_dir, int iteration, const mgs_gaussians *g, mgs_error *err) {
  char sub[64];
  snprintf(sub, sizeof sub, "point_cloud/iteration_%d", iteration);
  char *dir = mgs_path_join(run_dir, sub);
  char *path = dir ? mgs_path_join(dir, "point_cloud.ply") : NULL;
  mgs_status st = path ? mgs_mkdir_p(dir, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  if (st == MGS_OK) st = mgs_ply_write_gaussians(path, g, err);
  free(dir);
  free(path);
  return st;
}

mgs_status mgs_run_record_save(const char *run_dir, int iteration, double train_seconds, size_t gaussians,
                               double train_cpu_seconds, mgs_error *err) {
  char *path = mgs_path_join(run_dir, "saves.csv"), *old = NULL;
  if (!path) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  size_t n = 0;
  if (mgs_read_file(path, &old, &n, NULL) != MGS_OK) { old = NULL; n = 0; }
  static const char header[] = "iteration,train_seconds,gaussians,train_cpu_seconds\n";
  char line[160];
  int l = snprintf(line, sizeof line, "%d,%.6f,%zu,%.6f\n", iteration, train_seconds, gaussians, train_cpu_seconds);
  size_t h = n ? 0 : strlen(header);
  char *text = malloc(n + h + (size_t)l + 1);
  mgs_status st;
  if (!text) st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  else {
    if (n) memcpy(text, old, n);
    else memcpy(text, header, h);
    memcpy(text + n + h, line, (size_t)l);
    st = mgs_write_file_atomic(path, text, n + h + (size_t)l, err);
  }
  free(text); free(old); free(path);
  return st;
}

double mgs_run_saved_seconds(const char *run_dir, int iteration) {
  char *path = mgs_path_join(run_dir, "saves.csv"), *text = NULL;
  size_t n = 0;
  double s = NAN;
  if (path && mgs_read_file(path, &text, &n, NULL) == MGS_OK) {
    for (char *p = text; p && *p;) {
      int it;
      double sec;
      if (sscanf(p, "%d,%lf", &it, &sec) == 2 && it == iteration && isfinite(sec)) s = sec;
      p = strchr(p, '\n');
      if (p) p++;
    }
  }
  free(text); free(path);
  return s;
}

int mgs_run_latest_iteration(const char *run_dir) {
  char *pc = mgs_path_join(run_dir, "point_cloud");
  DIR *d = pc ? opendir(pc) : NULL;
  int best = -1;
  if (d) {
    struct dirent *e;
    while ((e = readdir(d))) {
      int it;
      char tail;
      if (sscanf(e->d_name, "iteration_%d%c", &it, &tail) != 1 || it < 0) continue;
      char sub[300];
      snprintf(sub, sizeof sub, "%s/point_cloud.ply", e->d_name);
      char *p = mgs_path_join(pc, sub);
      if (p && mgs_path_exists(p) && it > best) best = it;
      free(p);
    }
    closedir(d);
  }
  free(pc);
  return best;
}

/* ---- the settings record ------------------------------------------------------------ */

void mgs_settings_init(mgs_settings *s) { memset(s, 0, sizeof *s); }

void mgs_settings_free(mgs_settings *s) {
  for (size_t i = 0; i < s->n; i++) { free(s->key[i]); free(s->value[i]); }
  free(s->key); free(s->value); free(s->quoted);
  memset(s, 0, sizeof *s);
}

void mgs_settings_set(mgs_settings *s, const char *key, const char *value, int quoted) {
  for (size_t i = 0; i < s->n; i++)
    if (!strcmp(s->key[i], key)) {
      char *v = mgs_strdup(value);
      if (!v) return;
      free(s->value[i]);
      s->value[i] = v;
      s->quoted[i] = quoted;
      return;
    }
  char **k = realloc(s->key, (s->n + 1) * sizeof(char *));
  if (k) s->key = k;
  char **v = realloc(s->value, (s->n + 1) * sizeof(char *));
  if (v) s->value = v;
  int *q = realloc(s->quoted, (s->n + 1) * sizeof(int));
  if (q) s->quoted = q;
  if (!k || !v || !q) return;
  s->key[s->n] = mgs_strdup(key);
  s->value[s->n] = mgs_strdup(value);
  s->quoted[s->n] = quoted;
  if (s->key[s->n] && s->value[s->n]) s->n++;
  else { free(s->key[s->n]); free(s->value[s->n]); }
}

void mgs_settings_setf(mgs_settings *s, const char *key, double value) {
  char b[64];
  snprintf(b, sizeof b, "%.7g", value); /* readable; float settings round-trip */
  mgs_settings_set(s, key, b, 0);
}

void mgs_settings_seti(mgs_settings *s, const char *key, long long value) {
  char b[64];
  snprintf(b, sizeof b, "%lld", value);
  mgs_settings_set(s, key, b, 0);
}

const char *mgs_settings_get(const mgs_settings *s, const char *key) {
  for (size_t i = 0; i < s->n; i++)
    if (!strcmp(s->key[i], key)) return s->value[i];
  return NULL;
}

mgs_status mgs_settings_write(const char *path, const mgs_settings *s, mgs_error *err) {
  mgs_atomic_file *af;
  FILE *f;
  mgs_status st = mgs_atomic_open(path, &af, &f, err);
  if (st) return st;
  fputs("Namespace(", f);
  for (size_t i = 0; i < s->n; i++) {
    fprintf(f, "%s%s=", i ? ", " : "", s->key[i]);
    if (s->quoted[i]) {
      fputc('\'', f);
      for (const char *c = s->value[i]; *c; c++) {
        if (*c == '\'' || *c == '\\') fputc('\\', f);
        fputc(*c, f);
      }
      fputc('\'', f);
    } else fputs(s->value[i], f);
  }
  fputs(")", f);
  if (ferror(f)) { mgs_atomic_abort(af); return mgs_error_set(err, MGS_ERR_IO, "%s: write failed", path); }
  return mgs_atomic_commit(af, err);
}

mgs_status mgs_settings_read(const char *path, mgs_settings *s, mgs_error *err) {
  char *data = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &data, &size, err);
  if (st) return st;
  mgs_settings_init(s);
  const char *p = data;
  while (*p == ' ' || *p == '\n') p++;
  if (strncmp(p, "Namespace(", 10) != 0) {
    free(data);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a settings record (expected Namespace(...))", path);
  }
  p += 10;
  char *val = malloc(size + 1), *key = malloc(size + 1);
  if (!val || !key) { free(val); free(key); free(data); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); }
  for (;;) {
    while (*p == ' ' || *p == ',' || *p == '\n') p++;
    if (*p == ')' || *p == 0) break;
    size_t kl = 0;
    while (*p && *p != '=' && *p != ',' && *p != ')') key[kl++] = *p++;
    key[kl] = 0;
    if (*p != '=') { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: setting '%s' has no value", path, key); break; }
    p++;
    size_t vl = 0;
    int quoted = 0;
    if (*p == '\'' || *p == '"') {
      char q = *p++;
      quoted = 1;
      while (*p && *p != q) {
        if (*p == '\\' && p[1]) p++;
        val[vl++] = *p++;
      }
      if (*p != q) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: unterminated string for '%s'", path, key); break; }
      p++;
    } else {
      while (*p && *p != ',' && *p != ')') val[vl++] = *p++;
    }
    val[vl] = 0;
    mgs_settings_set(s, key, val, quoted);
  }
  free(val); free(key); free(data);
  if (st) mgs_settings_free(s);
  return st;
}

void mgs_run_record_origin(mgs_settings *s, const mgs_dataset *ds) {
  char b[96];
  mgs_origin_format(ds->origin, b, sizeof b);
  mgs_settings_set(s, "scene_origin", b, 1);
}

/* ---- a model trained elsewhere ------------------------------------------------------- */

/* Whether `path` (which need not exist yet; its parent must) lies in the folder `dir_abs`
   (an absolute, resolved path). */
static int path_within(const char *path, const char *dir_abs) {
  char *abs = realpath(path, NULL);
  if (!abs) {
    char *parent = mgs_path_dirname(path), *pabs = parent ? realpath(parent, NULL) : NULL;
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    abs = pabs ? mgs_path_join(pabs, base) : NULL;
    free(parent);
    free(pabs);
  }
  if (!abs) return 0;
  const size_t n = strlen(dir_abs);
  const int in = !strncmp(abs, dir_abs, n) && (abs[n] == 0 || abs[n] == '/');
  free(abs);
  return in;
}

mgs_status mgs_run_import(const char *model_path, const char *dataset_dir, int white_background, int downscale,
                          const char *images, const char *out_dir, mgs_error *err) {
  if (downscale < 1) return mgs_error_set(err, MGS_ERR_ARG, "%s: downscale %d; it is a factor >= 1", out_dir, downscale);
  if (mgs_path_exists(out_dir)) {
    int empty = 0;
    DIR *d = mgs_is_dir(out_dir) ? opendir(out_dir) : NULL;
    if (d) {
      struct dirent *e;
      empty = 1;
      while ((e = readdir(d))) if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) empty = 0;
      closedir(d);
    }
    if (!empty) return mgs_error_set(err, MGS_ERR_IO, "%s exists and is not an empty folder; nothing is written into it", out_dir);
  }
  /* a folder in the reference's output layout: its latest point_cloud/iteration_N */
  char *model_file = NULL;
  if (mgs_is_dir(model_path)) {
    const int it = mgs_run_latest_iteration(model_path);
    if (it < 0) return mgs_error_set(err, MGS_ERR_IO, "%s: a folder without point_cloud/iteration_N/point_cloud.ply", model_path);
    char sub[96];
    snprintf(sub, sizeof sub, "point_cloud/iteration_%d/point_cloud.ply", it);
    if (!(model_file = mgs_path_join(model_path, sub))) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    model_path = model_file;
  }
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = 0;
  o.white_background = white_background;
  o.downscale = downscale;
  o.images = images;
  mgs_dataset *ds = NULL;
  mgs_gaussians *g = NULL;
  mgs_status st = mgs_dataset_load(dataset_dir, &o, &ds, err);
  /* the model's world coordinates into the dataset's local frame, as mgs_run_open does */
  if (st == MGS_OK) st = mgs_ply_read_gaussians_local(model_path, ds->origin, &g, err);
  char *src = st == MGS_OK ? realpath(dataset_dir, NULL) : NULL, *from = st == MGS_OK ? realpath(model_path, NULL) : NULL;
  if (st == MGS_OK && (!src || !from)) st = mgs_error_set(err, MGS_ERR_IO, "%s: cannot resolve the dataset's or the model's path", out_dir);
  if (st == MGS_OK && path_within(out_dir, src))
    st = mgs_error_set(err, MGS_ERR_ARG, "%s: the run folder is inside the dataset folder %s; choose another (the dataset is never written to)",
                       out_dir, src);
  if (st == MGS_OK) st = mgs_mkdir_p(out_dir, err);
  if (st == MGS_OK) st = mgs_run_write_ply(out_dir, 0, g, err);
  if (st == MGS_OK) st = mgs_run_write_cameras(out_dir, ds, err);
  if (st == MGS_OK) {
    mgs_settings s;
    mgs_settings_init(&s);
    mgs_settings_set(&s, "source_path", src, 1);
    mgs_settings_set(&s, "model_path", out_dir, 1);
    mgs_settings_set(&s, "imported_from", from, 1);
    mgs_settings_set(&s, "white_background", ds->background[0] > 0.5f ? "True" : "False", 0);
    mgs_settings_set(&s, "background", ds->background[0] > 0.5f ? "white" : "black", 1);
    mgs_settings_seti(&s, "downscale", o.downscale);
    mgs_settings_seti(&s, "max_width", o.max_width);
    mgs_settings_seti(&s, "test_every", o.test_every);
    mgs_settings_set(&s, "images", images && *images ? images : "images", 1);
    mgs_settings_seti(&s, "sh_degree", g->sh_degree);
    mgs_settings_set(&s, "model", mgs_model_kind_name(g->kind), 1);
    mgs_run_record_origin(&s, ds);
    char *cfg = mgs_path_join(out_dir, "cfg_args");
    st = cfg ? mgs_settings_write(cfg, &s, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
    free(cfg);
    mgs_settings_free(&s);
  }
  free(src);
  free(from);
  free(model_file);
  mgs_gaussians_destroy(g);
  mgs_dataset_destroy(ds);
  return st;
}

/* ---- opening a finished run ----------------------------------------------------------- */

mgs_status mgs_run_open(const char *run_dir, int iteration, int load_images, mgs_dataset **ds_out,
                        mgs_gaussians **g_out, int *iteration_out, mgs_error *err) {
  *ds_out = NULL; *g_out = NULL;
  char *cfg = mgs_path_join(run_dir, "cfg_args");
  mgs_settings s;
  mgs_status st = mgs_settings_read(cfg, &s, err);
  free(cfg);
  if (st) return st;
  const char *src = mgs_settings_get(&s, "source_path");
  const char *ds_s = mgs_settings_get(&s, "downscale");
  const char *wb = mgs_settings_get(&s, "white_background");
  const char *te = mgs_settings_get(&s, "test_every");
  if (!src) {
    mgs_settings_free(&s);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s/cfg_args: no source_path (the dataset of the run)", run_dir);
  }
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.downscale = ds_s ? atoi(ds_s) : 1;
  if (o.downscale < 1) o.downscale = 1;
  if (wb) o.white_background = !strcmp(wb, "True");
  /* runs recorded before the 1600 px cap existed trained at full size */
  const char *mw = mgs_settings_get(&s, "max_width");
  o.max_width = mw && atoi(mw) > 0 ? atoi(mw) : 0;
  if (te && atoi(te) >= 0) o.test_every = atoi(te); /* 0: no test views */
  const char *res = mgs_settings_get(&s, "resolution");
  if (!ds_s && res) { /* the reference's own cfg_args (no downscale key): its -r, as it applies it */
    const int r = atoi(res);
    if (r == 1 || r == 2 || r == 4 || r == 8) o.downscale = r, o.max_width = 0;
    else if (r == -1) o.max_width = 1600; /* its cap */
    else if (r > 0) o.max_width = r;     /* a target width (exact where the images are wider) */
  }
  o.images = mgs_settings_get(&s, "images"); /* the folder it trained on (images_4, ...) */
  o.load_images = load_images;
  int it = iteration >= 0 ? iteration : mgs_run_latest_iteration(run_dir);
  if (it < 0) {
    mgs_settings_free(&s);
    return mgs_error_set(err, MGS_ERR_IO, "%s: no point_cloud/iteration_N/point_cloud.ply in the run", run_dir);
  }
  char sub[96];
  snprintf(sub, sizeof sub, "point_cloud/iteration_%d/point_cloud.ply", it);
  char *ply = mgs_path_join(run_dir, sub);
  /* the dataset first: its origin (the same as in training: chosen from the same files)
     places the model's world coordinates back in the local frame */
  const char *rec = mgs_settings_get(&s, "scene_origin");
  double origin[3];
  st = mgs_dataset_load(src, &o, ds_out, err);
  if (st == MGS_OK && rec && !mgs_origin_parse(rec, origin))
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s/cfg_args: scene_origin '%s' is not three numbers", run_dir, rec);
  else if (st == MGS_OK && rec && memcmp(origin, (*ds_out)->origin, sizeof origin) != 0 &&
           !(mgs_origin_is_zero(origin) && mgs_origin_is_zero((*ds_out)->origin)))
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: trained with the scene origin %s, the dataset %s now gives another (its cameras or points changed)",
                       run_dir, rec, src);
  if (st == MGS_OK) st = mgs_ply_read_gaussians_local(ply, (*ds_out)->origin, g_out, err);
  free(ply);
  mgs_settings_free(&s);
  if (st) {
    mgs_gaussians_destroy(*g_out); *g_out = NULL;
    mgs_dataset_destroy(*ds_out); *ds_out = NULL;
    return st;
  }
  if (iteration_out) *iteration_out = it;
  return MGS_OK;
}
