/* The generic .ply container: header parsing and bounds-checked element walking. */
#include "core/ply_format.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#define PLY_HEADER_MAX (1u << 20) /* no sane header is larger; bounds the scan */
#define PLY_MAX_PROPS 4096

static const struct { const char *name; ply_type type; } ply_type_names[] = {
  {"char", PLY_INT8},    {"int8", PLY_INT8},       {"uchar", PLY_UINT8},  {"uint8", PLY_UINT8},
  {"short", PLY_INT16},  {"int16", PLY_INT16},     {"ushort", PLY_UINT16}, {"uint16", PLY_UINT16},
  {"int", PLY_INT32},    {"int32", PLY_INT32},     {"uint", PLY_UINT32},  {"uint32", PLY_UINT32},
  {"float", PLY_FLOAT32}, {"float32", PLY_FLOAT32}, {"double", PLY_FLOAT64}, {"float64", PLY_FLOAT64},
};

const char *ply_type_name(ply_type t) {
  static const char *names[] = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double"};
  return (unsigned)t < PLY_TYPE_COUNT ? names[t] : "?";
}

int ply_type_size(ply_type t) {
  static const int sizes[] = {1, 1, 2, 2, 4, 4, 4, 8};
  return (unsigned)t < PLY_TYPE_COUNT ? sizes[t] : 0;
}

static int parse_type(const char *s, ply_type *t) {
  for (size_t i = 0; i < sizeof ply_type_names / sizeof ply_type_names[0]; i++)
    if (strcmp(s, ply_type_names[i].name) == 0) { *t = ply_type_names[i].type; return 1; }
  return 0;
}

int ply_find_property(const ply_element *e, const char *name) {
  for (int i = 0; i < e->n_props; i++)
    if (strcmp(e->props[i].name, name) == 0) return i;
  return -1;
}

void ply_close(ply_file *pf) {
  if (!pf) return;
  for (int i = 0; i < pf->n_elems; i++) free(pf->elems[i].props);
  free(pf->elems);
  if (pf->data) {
    if (pf->mapped) munmap((void *)pf->data, pf->size);
    else free((void *)pf->data);
  }
  memset(pf, 0, sizeof *pf);
}

/* Splits one header line (NUL-terminated copy) into at most 8 whitespace tokens. */
static int split_tokens(char *line, char **tok, int max) {
  int n = 0;
  char *save = NULL;
  for (char *t = strtok_r(line, " \t\r", &save); t && n < max; t = strtok_r(NULL, " \t\r", &save))
    tok[n++] = t;
  return n;
}

static mgs_status parse_header(ply_file *pf, mgs_error *err) {
  const char *path = pf->path;
  const unsigned char *d = pf->data;
  size_t n = pf->size, pos = 0, line_no = 0;
  int have_format = 0;
  if (n < 4 || memcmp(d, "ply", 3) != 0 || (d[3] != '\n' && d[3] != '\r'))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a .ply file (missing 'ply' magic line)", path);
  char line[512];
  for (;;) {
    if (pos >= n || pos >= PLY_HEADER_MAX)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header has no end_header line", path);
    size_t end = pos;
    while (end < n && d[end] != '\n') end++;
    if (end >= n) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header has no end_header line", path);
    line_no++;
    size_t len = end - pos;
    if (len >= sizeof line)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu is too long", path, line_no);
    memcpy(line, d + pos, len);
    line[len] = 0;
    if (memchr(line, 0, len))
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu contains a NUL byte", path, line_no);
    pos = end + 1;
    char *tok[8];
    int nt = split_tokens(line, tok, 8);
    if (nt == 0) continue;
    if (line_no == 1) { if (strcmp(tok[0], "ply") != 0) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: missing 'ply' magic", path); continue; }
    if (strcmp(tok[0], "comment") == 0 || strcmp(tok[0], "obj_info") == 0) continue;
    if (strcmp(tok[0], "end_header") == 0) break;
    if (strcmp(tok[0], "format") == 0) {
      if (nt != 3) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: malformed format line", path, line_no);
      if (strcmp(tok[1], "ascii") == 0) pf->encoding = PLY_ASCII;
      else if (strcmp(tok[1], "binary_little_endian") == 0) pf->encoding = PLY_BINARY_LE;
      else if (strcmp(tok[1], "binary_big_endian") == 0) pf->encoding = PLY_BINARY_BE;
      else return mgs_error_set(err, MGS_ERR_FORMAT, "%s: unknown format '%s'", path, tok[1]);
      if (strcmp(tok[2], "1.0") != 0)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: unsupported format version '%s'", path, tok[2]);
      have_format = 1;
    } else if (strcmp(tok[0], "element") == 0) {
      if (nt != 3) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: malformed element line", path, line_no);
      char *e = NULL;
      errno = 0;
      if (tok[2][0] == '-' || tok[2][0] == '+') return mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' has invalid count '%s'", path, tok[1], tok[2]);
      unsigned long long c = strtoull(tok[2], &e, 10);
      if (errno || *e || e == tok[2])
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' has invalid count '%s'", path, tok[1], tok[2]);
      if (strlen(tok[1]) >= sizeof pf->elems[0].name)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: element name too long", path);
      if (pf->n_elems >= 64) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: too many elements", path);
      ply_element *ne = realloc(pf->elems, sizeof *ne * (size_t)(pf->n_elems + 1));
      if (!ne) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
      pf->elems = ne;
      ply_element *el = &pf->elems[pf->n_elems++];
      memset(el, 0, sizeof *el);
      strcpy(el->name, tok[1]);
      el->count = (size_t)c;
    } else if (strcmp(tok[0], "property") == 0) {
      if (pf->n_elems == 0) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: property before any element", path, line_no);
      ply_element *el = &pf->elems[pf->n_elems - 1];
      ply_property p;
      memset(&p, 0, sizeof p);
      const char *name;
      if (nt >= 2 && strcmp(tok[1], "list") == 0) {
        if (nt != 5) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: malformed list property", path, line_no);
        if (!parse_type(tok[2], &p.count_type) || !parse_type(tok[3], &p.type))
          return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: unknown property type", path, line_no);
        if (p.count_type == PLY_FLOAT32 || p.count_type == PLY_FLOAT64)
          return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: list count type must be an integer", path, line_no);
        p.is_list = 1;
        name = tok[4];
      } else {
        if (nt != 3) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: malformed property line", path, line_no);
        if (!parse_type(tok[1], &p.type))
          return mgs_error_set(err, MGS_ERR_FORMAT, "%s: property '%s' has unknown type '%s'", path, tok[2], tok[1]);
        name = tok[2];
      }
      if (strlen(name) >= sizeof p.name) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: property name too long", path);
      strcpy(p.name, name);
      if (ply_find_property(el, p.name) >= 0)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' declares property '%s' twice", path, el->name, p.name);
      if (el->n_props >= PLY_MAX_PROPS) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: too many properties", path);
      ply_property *np = realloc(el->props, sizeof *np * (size_t)(el->n_props + 1));
      if (!np) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
      el->props = np;
      el->props[el->n_props++] = p;
    } else {
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header line %zu: unknown keyword '%s'", path, line_no, tok[0]);
    }
  }
  if (!have_format) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header has no format line", path);
  pf->body = pos;
  return MGS_OK;
}

mgs_status ply_open(const char *path, ply_file *pf, mgs_error *err) {
  memset(pf, 0, sizeof *pf);
  pf->path = path;
  int fd = open(path, O_RDONLY);
  if (fd < 0) return mgs_error_set(err, MGS_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
  struct stat st;
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(fd);
    return mgs_error_set(err, MGS_ERR_IO, "%s: not a regular file", path);
  }
  if (st.st_size == 0) {
    close(fd);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: empty file", path);
  }
  pf->size = (size_t)st.st_size;
  void *m = mmap(NULL, pf->size, PROT_READ, MAP_PRIVATE, fd, 0);
  if (m == MAP_FAILED) {
    /* Fall back to reading (some file systems do not map). */
    unsigned char *buf = malloc(pf->size);
    size_t got = 0;
    while (buf && got < pf->size) {
      ssize_t r = read(fd, buf + got, pf->size - got);
      if (r <= 0) break;
      got += (size_t)r;
    }
    close(fd);
    if (!buf || got != pf->size) {
      free(buf);
      return mgs_error_set(err, MGS_ERR_IO, "%s: cannot read", path);
    }
    pf->data = buf;
  } else {
    close(fd);
    pf->data = m;
    pf->mapped = 1;
  }
  mgs_status s = parse_header(pf, err);
  if (s != MGS_OK) { ply_close(pf); pf->path = path; }
  return s;
}

/* ---- binary decoding ---- */

static double decode(const unsigned char *p, ply_type t, int big) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
  if (!big && t == PLY_FLOAT32) { /* the common case: 3DGS files */
    float f;
    memcpy(&f, p, 4);
    return (double)f;
  }
#endif
  unsigned char b[8];
  int sz = ply_type_size(t);
  for (int i = 0; i < sz; i++) b[i] = big ? p[sz - 1 - i] : p[i]; /* to little-endian */
  switch (t) {
    case PLY_INT8: return (double)(int8_t)b[0];
    case PLY_UINT8: return (double)b[0];
    case PLY_INT16: return (double)(int16_t)(uint16_t)(b[0] | (b[1] << 8));
    case PLY_UINT16: return (double)(uint16_t)(b[0] | (b[1] << 8));
    case PLY_INT32: { uint32_t u = b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24; return (double)(int32_t)u; }
    case PLY_UINT32: { uint32_t u = b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24; return (double)u; }
    case PLY_FLOAT32: { uint32_t u = b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24; float f; memcpy(&f, &u, 4); return (double)f; }
    case PLY_FLOAT64: { uint64_t u = 0; for (int i = 7; i >= 0; i--) u = (u << 8) | b[i]; double v; memcpy(&v, &u, 8); return v; }
    default: return 0.0;
  }
}

static int element_fixed_size(const ply_element *e, size_t *row) {
  size_t s = 0;
  for (int i = 0; i < e->n_props; i++) {
    if (e->props[i].is_list) return 0;
    s += (size_t)ply_type_size(e->props[i].type);
  }
  *row = s;
  return 1;
}

/* ---- ascii tokens ---- */

typedef struct { const unsigned char *d; size_t n, pos; } ascii_cursor;

static int next_token(ascii_cursor *c, double *v) {
  while (c->pos < c->n && (c->d[c->pos] == ' ' || c->d[c->pos] == '\t' || c->d[c->pos] == '\n' || c->d[c->pos] == '\r')) c->pos++;
  if (c->pos >= c->n) return -1; /* end of file */
  char buf[96];
  size_t len = 0;
  while (c->pos < c->n) {
    unsigned char ch = c->d[c->pos];
    if (ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r') break;
    if (len + 1 >= sizeof buf || ch == 0) return 0;
    buf[len++] = (char)ch;
    c->pos++;
  }
  buf[len] = 0;
  char *e = NULL;
  *v = strtod(buf, &e);
  return (e && *e == 0) ? 1 : 0;
}

static mgs_status walk(ply_file *pf, int upto, ply_row_fn fn, void *ctx, mgs_error *err) {
  const int big = pf->encoding == PLY_BINARY_BE;
  size_t pos = pf->body;
  ascii_cursor ac = {pf->data, pf->size, pf->body};
  double *vals = NULL;
  mgs_status st = MGS_OK;
  for (int ei = 0; ei <= upto && st == MGS_OK; ei++) {
    const ply_element *e = &pf->elems[ei];
    const int want = ei == upto;
    if (e->n_props == 0) { /* rows without data: nothing to read or skip */
      if (want) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' has no properties", pf->path, e->name);
      continue;
    }
    size_t row_size = 0;
    int fixed = element_fixed_size(e, &row_size);
    /* Counts past the end of the file are rejected before any allocation. */
    if (pf->encoding != PLY_ASCII) {
      size_t left = pf->size - pos;
      size_t min_row = fixed ? row_size : 0;
      if (!fixed)
        for (int i = 0; i < e->n_props; i++)
          min_row += (size_t)ply_type_size(e->props[i].is_list ? e->props[i].count_type : e->props[i].type);
      if (min_row > 0 && e->count > left / min_row)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' declares %zu rows but the file ends after %zu bytes of data (truncated?)",
                             pf->path, e->name, e->count, left);
    } else {
      size_t left = pf->size - ac.pos;
      size_t min_row = (size_t)e->n_props * 2; /* each value: at least one character and a separator */
      if (min_row > 0 && e->count > (left + 1) / min_row)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' declares %zu rows but the file holds fewer (truncated?)",
                             pf->path, e->name, e->count);
    }
    if (!want && fixed && pf->encoding != PLY_ASCII) { pos += e->count * row_size; continue; }
    if (want) {
      free(vals);
      vals = calloc((size_t)(e->n_props ? e->n_props : 1), sizeof *vals);
      if (!vals) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", pf->path);
    }
    for (size_t r = 0; r < e->count; r++) {
      if (want && fixed && pf->encoding != PLY_ASCII) {
        /* Fixed-size binary rows: one bounds check per row (the count was checked above). */
        if (row_size > pf->size - pos) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: file ends in element '%s' row %zu (truncated)", pf->path, e->name, r); goto out; }
        const unsigned char *q = pf->data + pos;
        for (int pi = 0; pi < e->n_props; pi++) {
          vals[pi] = decode(q, e->props[pi].type, big);
          q += ply_type_size(e->props[pi].type);
        }
        pos += row_size;
        st = fn(ctx, r, vals, err);
        if (st != MGS_OK) goto out;
        continue;
      }
      for (int pi = 0; pi < e->n_props; pi++) {
        const ply_property *p = &e->props[pi];
        if (pf->encoding == PLY_ASCII) {
          double v;
          int k = next_token(&ac, &v);
          if (k < 0) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: file ends in element '%s' row %zu (truncated)", pf->path, e->name, r); goto out; }
          if (k == 0) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' row %zu property '%s': not a number", pf->path, e->name, r, p->name); goto out; }
          if (p->is_list) {
            if (!(v >= 0 && v <= 1e9) || v != floor(v)) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' row %zu: invalid list length", pf->path, e->name, r); goto out; }
            for (size_t li = 0; li < (size_t)v; li++) {
              double dummy;
              int kk = next_token(&ac, &dummy);
              if (kk <= 0) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' row %zu: bad or missing list item", pf->path, e->name, r); goto out; }
            }
            if (want) vals[pi] = 0;
          } else if (want) {
            vals[pi] = v;
          }
        } else {
          int cs = ply_type_size(p->is_list ? p->count_type : p->type);
          if ((size_t)cs > pf->size - pos) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: file ends in element '%s' row %zu (truncated)", pf->path, e->name, r); goto out; }
          double v = decode(pf->data + pos, p->is_list ? p->count_type : p->type, big);
          pos += (size_t)cs;
          if (p->is_list) {
            if (v < 0) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: element '%s' row %zu: negative list length", pf->path, e->name, r); goto out; }
            size_t bytes = (size_t)v * (size_t)ply_type_size(p->type);
            if (bytes > pf->size - pos) { st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: file ends in element '%s' row %zu (truncated)", pf->path, e->name, r); goto out; }
            pos += bytes;
            if (want) vals[pi] = 0;
          } else if (want) {
            vals[pi] = v;
          }
        }
      }
      if (want) {
        st = fn(ctx, r, vals, err);
        if (st != MGS_OK) goto out;
      }
    }
  }
out:
  free(vals);
  return st;
}

mgs_status ply_read_element(ply_file *pf, int elem_index, ply_row_fn fn, void *ctx, mgs_error *err) {
  if (elem_index < 0 || elem_index >= pf->n_elems)
    return mgs_error_set(err, MGS_ERR_ARG, "%s: no such element", pf->path);
  return walk(pf, elem_index, fn, ctx, err);
}
