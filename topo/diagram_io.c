/* Diagram files: GUDHI-style text and JSON with cell positions (declared in
 * topo/mgs_diagram_tools.h). Writes are atomic (temp + rename via core/mgs_fs.h). */
#include <cjson/cJSON.h>
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_fs.h"
#include "topo/mgs_diagram_tools.h"

/* ------------------------------------------------------------------ text */

static void put_value(FILE *f, double v) {
  if (isinf(v)) fputs(v > 0 ? "inf" : "-inf", f);
  else fprintf(f, "%.17g", v);
}

mgs_status mgs_diagram_write_text(const char *path, const mgs_diagram *d, mgs_error *err) {
  if (!path || !d) return mgs_error_set(err, MGS_ERR_ARG, "diagram text: null argument");
  mgs_atomic_file *af;
  FILE *f;
  mgs_status st = mgs_atomic_open(path, &af, &f, err);
  if (st != MGS_OK) return st;
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    fprintf(f, "%d ", p->dim);
    put_value(f, p->birth);
    fputc(' ', f);
    put_value(f, p->death);
    fputc('\n', f);
  }
  if (ferror(f)) {
    mgs_atomic_abort(af);
    return mgs_error_set(err, MGS_ERR_IO, "%s: write failed", path);
  }
  return mgs_atomic_commit(af, err);
}

/* strtod, but the whole token must be a number (inf/-inf accepted, nan rejected). */
static int parse_double(const char *s, char **end, double *v) {
  errno = 0;
  *v = strtod(s, end);
  if (*end == s || isnan(*v)) return 0;
  if (**end && !isspace((unsigned char)**end)) return 0;
  return 1;
}

mgs_status mgs_diagram_read_text(const char *path, mgs_diagram **out, mgs_error *err) {
  *out = NULL;
  char *data;
  size_t size;
  mgs_status st = mgs_read_file(path, &data, &size, err);
  if (st != MGS_OK) return st;
  if (memchr(data, '\0', size)) {
    free(data);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a text diagram (contains NUL bytes)", path);
  }
  mgs_diagram *d = mgs_diagram_create();
  if (!d) { free(data); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); }
  size_t line = 0;
  char *s = data;
  while (*s) {
    line++;
    char *eol = strchr(s, '\n');
    char *next = eol ? eol + 1 : s + strlen(s);
    if (eol) *eol = '\0';
    char *c = s;
    while (isspace((unsigned char)*c)) c++;
    if (*c && *c != '#') {
      char *e;
      double dimv, b, dth;
      if (!parse_double(c, &e, &dimv) || !parse_double(e, &e, &b) || !parse_double(e, &e, &dth)) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%zu: expected 'dim birth death'", path, line);
        break;
      }
      while (isspace((unsigned char)*e)) e++;
      if (*e) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%zu: extra text after 'dim birth death'", path, line); break; }
      if (dimv != floor(dimv) || dimv < 0 || dimv > 2) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "%s:%zu: dimension %g is not 0, 1 or 2", path, line, dimv);
        break;
      }
      mgs_pair p;
      memset(&p, 0, sizeof p);
      p.dim = (int)dimv; p.birth = b; p.death = dth;
      if ((st = mgs_diagram_push(d, &p, err)) != MGS_OK) break;
    }
    s = next;
  }
  free(data);
  if (st != MGS_OK) { mgs_diagram_destroy(d); return st; }
  *out = d;
  return MGS_OK;
}

/* ------------------------------------------------------------------ JSON */

/* A finite double as the shortest text that reads back exactly (cJSON's own printer
 * accepts a 1-ulp error, which would break the round trip). */
static cJSON *json_number(double v) {
  char buf[40];
  if (!isfinite(v)) return cJSON_CreateNull(); /* never valid JSON as a number */
  for (int prec = 15; prec <= 17; prec++) {
    snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (strtod(buf, NULL) == v) break;
  }
  return cJSON_CreateRaw(buf);
}

static cJSON *json_value(double v) {
  if (isinf(v)) return cJSON_CreateString(v > 0 ? "inf" : "-inf");
  return json_number(v);
}

static cJSON *json_vec3(const double *x) {
  cJSON *a = cJSON_CreateArray();
  for (int k = 0; k < 3; k++) cJSON_AddItemToArray(a, json_number(x[k]));
  return a;
}

static cJSON *json_end(const mgs_pair_end *e) {
  cJSON *o = cJSON_CreateObject();
  cJSON_AddItemToObject(o, "voxel", cJSON_CreateIntArray(e->voxel, 3));
  cJSON_AddItemToObject(o, "pos", json_vec3(e->pos));
  if (e->cell < (1ull << 53)) cJSON_AddNumberToObject(o, "cell", (double)e->cell);
  else {
    char buf[32];
    snprintf(buf, sizeof buf, "%llu", (unsigned long long)e->cell);
    cJSON_AddStringToObject(o, "cell", buf);
  }
  return o;
}

mgs_status mgs_diagram_write_json(const char *path, const mgs_diagram *d,
                                  const char *meta_json, mgs_error *err) {
  if (!path || !d) return mgs_error_set(err, MGS_ERR_ARG, "diagram JSON: null argument");
  cJSON *root = cJSON_CreateObject();
  if (!root) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  cJSON_AddStringToObject(root, "format", "morsegs-diagram");
  cJSON_AddNumberToObject(root, "version", 1);
  if (meta_json) {
    cJSON *meta = cJSON_Parse(meta_json);
    if (!meta || !cJSON_IsObject(meta)) {
      cJSON_Delete(meta); cJSON_Delete(root);
      return mgs_error_set(err, MGS_ERR_ARG, "%s: metadata is not a JSON object", path);
    }
    cJSON_AddItemToObject(root, "meta", meta);
  }
  size_t per_dim[3], ess, trunc;
  mgs_diagram_counts(d, per_dim, &ess, &trunc);
  cJSON *stats = cJSON_AddObjectToObject(root, "stats");
  cJSON_AddNumberToObject(stats, "pairs", (double)d->n);
  cJSON_AddNumberToObject(stats, "pairs_dim0", (double)per_dim[0]);
  cJSON_AddNumberToObject(stats, "pairs_dim1", (double)per_dim[1]);
  cJSON_AddNumberToObject(stats, "pairs_dim2", (double)per_dim[2]);
  cJSON_AddNumberToObject(stats, "essential", (double)ess);
  cJSON_AddNumberToObject(stats, "truncated", (double)trunc);
  cJSON_AddNumberToObject(stats, "n_cells", (double)d->n_cells);
  cJSON_AddNumberToObject(stats, "n_critical", (double)d->n_critical);
  cJSON_AddNumberToObject(stats, "n_active_voxels", (double)d->n_active_voxels);
  cJSON_AddItemToObject(stats, "seconds", json_number(d->seconds));
  cJSON *arr = cJSON_AddArrayToObject(root, "pairs");
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *p = &d->pairs[i];
    cJSON *o = cJSON_CreateObject();
    cJSON_AddNumberToObject(o, "dim", p->dim);
    cJSON_AddItemToObject(o, "birth", json_value(p->birth));
    cJSON_AddItemToObject(o, "death", json_value(p->death));
    cJSON_AddItemToObject(o, "persistence", json_value(fabs(p->death - p->birth)));
    cJSON_AddBoolToObject(o, "truncated", p->truncated != 0);
    cJSON_AddItemToObject(o, "birth_cell", json_end(&p->b));
    if (!isinf(p->death)) cJSON_AddItemToObject(o, "death_cell", json_end(&p->d));
    cJSON_AddItemToArray(arr, o);
  }
  char *text = cJSON_Print(root);
  cJSON_Delete(root);
  if (!text) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory printing JSON", path);
  mgs_status st = mgs_write_file_atomic(path, text, strlen(text), err);
  cJSON_free(text);
  return st;
}

static int get_value(const cJSON *it, double *v) {
  if (cJSON_IsNumber(it)) { *v = it->valuedouble; return 1; }
  if (cJSON_IsString(it)) {
    if (!strcmp(it->valuestring, "inf") || !strcmp(it->valuestring, "+inf") || !strcmp(it->valuestring, "Infinity")) { *v = INFINITY; return 1; }
    if (!strcmp(it->valuestring, "-inf") || !strcmp(it->valuestring, "-Infinity")) { *v = -INFINITY; return 1; }
  }
  return 0;
}

static int get_end(const cJSON *o, mgs_pair_end *e) {
  memset(e, 0, sizeof *e);
  if (!o) return 1; /* optional */
  if (!cJSON_IsObject(o)) return 0;
  const cJSON *vx = cJSON_GetObjectItemCaseSensitive(o, "voxel");
  const cJSON *pos = cJSON_GetObjectItemCaseSensitive(o, "pos");
  const cJSON *cell = cJSON_GetObjectItemCaseSensitive(o, "cell");
  if (vx) {
    if (!cJSON_IsArray(vx) || cJSON_GetArraySize(vx) != 3) return 0;
    for (int k = 0; k < 3; k++) {
      const cJSON *c = cJSON_GetArrayItem(vx, k);
      if (!cJSON_IsNumber(c) || c->valuedouble != floor(c->valuedouble) || fabs(c->valuedouble) > 2147483647.0) return 0;
      e->voxel[k] = (int32_t)c->valuedouble;
    }
  }
  if (pos) {
    if (!cJSON_IsArray(pos) || cJSON_GetArraySize(pos) != 3) return 0;
    for (int k = 0; k < 3; k++) {
      const cJSON *c = cJSON_GetArrayItem(pos, k);
      if (!cJSON_IsNumber(c) || !isfinite(c->valuedouble)) return 0; /* 1e999 parses as inf */
      e->pos[k] = c->valuedouble;
    }
  }
  if (cell) {
    if (cJSON_IsNumber(cell) && cell->valuedouble >= 0 && cell->valuedouble < 18446744073709551616.0) e->cell = (uint64_t)cell->valuedouble;
    else if (cJSON_IsString(cell)) {
      char *end;
      errno = 0;
      unsigned long long v = strtoull(cell->valuestring, &end, 10);
      if (errno || *end || end == cell->valuestring) return 0;
      e->cell = (uint64_t)v;
    } else return 0;
  }
  return 1;
}

static double get_stat(const cJSON *stats, const char *key) {
  const cJSON *it = stats ? cJSON_GetObjectItemCaseSensitive(stats, key) : NULL;
  return cJSON_IsNumber(it) && it->valuedouble >= 0 ? it->valuedouble : 0.0;
}

mgs_status mgs_diagram_read_json(const char *path, mgs_diagram **out, mgs_error *err) {
  *out = NULL;
  char *data;
  size_t size;
  mgs_status st = mgs_read_file(path, &data, &size, err);
  if (st != MGS_OK) return st;
  cJSON *root = cJSON_ParseWithLength(data, size);
  free(data);
  if (!root) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not valid JSON", path);
  const cJSON *fmt = cJSON_GetObjectItemCaseSensitive(root, "format");
  const cJSON *pairs = cJSON_GetObjectItemCaseSensitive(root, "pairs");
  if (!cJSON_IsObject(root) || !cJSON_IsString(fmt) || strcmp(fmt->valuestring, "morsegs-diagram") || !cJSON_IsArray(pairs)) {
    cJSON_Delete(root);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a morsegs diagram (needs \"format\": \"morsegs-diagram\" and a \"pairs\" array)", path);
  }
  mgs_diagram *d = mgs_diagram_create();
  if (!d) { cJSON_Delete(root); return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path); }
  const cJSON *stats = cJSON_GetObjectItemCaseSensitive(root, "stats");
  d->n_cells = (size_t)get_stat(stats, "n_cells");
  d->n_critical = (size_t)get_stat(stats, "n_critical");
  d->n_active_voxels = (size_t)get_stat(stats, "n_active_voxels");
  d->seconds = get_stat(stats, "seconds");
  size_t i = 0;
  const cJSON *it;
  cJSON_ArrayForEach(it, pairs) {
    mgs_pair p;
    memset(&p, 0, sizeof p);
    const cJSON *dim = cJSON_GetObjectItemCaseSensitive(it, "dim");
    const cJSON *tr = cJSON_GetObjectItemCaseSensitive(it, "truncated");
    if (!cJSON_IsObject(it) || !cJSON_IsNumber(dim) || dim->valuedouble != floor(dim->valuedouble) ||
        dim->valuedouble < 0 || dim->valuedouble > 2) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: pair %zu: missing or invalid \"dim\" (0, 1 or 2)", path, i);
      break;
    }
    p.dim = (int)dim->valuedouble;
    if (!get_value(cJSON_GetObjectItemCaseSensitive(it, "birth"), &p.birth) ||
        !get_value(cJSON_GetObjectItemCaseSensitive(it, "death"), &p.death)) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: pair %zu: \"birth\"/\"death\" must be numbers or \"inf\"/\"-inf\"", path, i);
      break;
    }
    p.truncated = cJSON_IsTrue(tr);
    if (!get_end(cJSON_GetObjectItemCaseSensitive(it, "birth_cell"), &p.b) ||
        !get_end(cJSON_GetObjectItemCaseSensitive(it, "death_cell"), &p.d)) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: pair %zu: malformed birth_cell/death_cell (voxel: 3 integers, pos: 3 finite numbers, cell: id)", path, i);
      break;
    }
    if ((st = mgs_diagram_push(d, &p, err)) != MGS_OK) break;
    i++;
  }
  cJSON_Delete(root);
  if (st != MGS_OK) { mgs_diagram_destroy(d); return st; }
  *out = d;
  return MGS_OK;
}
