/* Niantic's .spz -> a 3DGS model (core/spz_format.h). Decoded as nianticlabs/spz's
 * load-spz.cc decodes (facts of the format, not its code): scale byte / 16 - 10 is the log
 * scale, alpha byte / 255 the opacity after the sigmoid, colour (byte / 255 - 0.5) / 0.15 the
 * DC coefficient, SH (byte - 128) / 128, interleaved [coefficient][channel] like our sh_rest. */
#include "core/spz_format.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <zstd.h>

#include "core/mgs_fs.h"
#include "core/mgs_log.h"

#define NGSP_MAGIC 0x5053474eu
#define LEGACY_HEADER 16
#define NGSP_HEADER 32
#define COLOR_SCALE 0.15
#define EXT_COORDINATE_SYSTEM 0xADBE0003u /* SPZ_ADOBE_coordinate_system: one u32 */
#define COORDS_RUB 4 /* the format's default frame (CoordinateSystem enum, 1..16) */
#define COORDS_RDF 6 /* the .ply's */
#define LEGACY_EXT_MAX (1u << 20) /* extension bytes read after a legacy stream's data */

static const char *const coord_names[17] = {"unspecified", "LDB", "RDB", "LUB", "RUB", "LDF", "RDF", "LUF", "RUF",
                                            "LFD",         "RFD", "LFU", "RFU", "LBD", "RBD", "LBU", "RBU"};

int spz_is_path(const char *path) {
  const size_t n = strlen(path);
  return n > 4 && !strcmp(path + n - 4, ".spz");
}

static uint32_t u32le(const uint8_t *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static uint64_t u64le(const uint8_t *p) { return (uint64_t)u32le(p) | (uint64_t)u32le(p + 4) << 32; }

static int sh_dim(int degree) { return degree <= 0 ? 0 : (degree + 1) * (degree + 1) - 1; } /* 3, 8, 15, 24 */

/* What the header says and where each attribute's bytes are. */
typedef struct spz_data {
  const char *path;
  uint32_t version, n;
  int degree, fbits, flags, coords;
  size_t bytes[6]; /* per attribute, in stream order: positions, alphas, colours, scales, rotations, SH */
  const uint8_t *at[6];
} spz_data;

static mgs_status read_header(spz_data *d, const uint8_t *h, int ngsp, mgs_error *err) {
  if (u32le(h) != NGSP_MAGIC)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: no 'NGSP' magic after decompression; not an .spz file", d->path);
  d->version = u32le(h + 4);
  d->n = u32le(h + 8);
  d->degree = h[12];
  d->fbits = h[13];
  d->flags = h[14];
  if (ngsp ? d->version != 4 : (d->version < 1 || d->version > 3))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: .spz version %u in a %s file; this reader knows 1-3 (gzip) and 4 (NGSP)", d->path,
                         d->version, ngsp ? "NGSP" : "gzip");
  if (d->n == 0 || d->n > 0x7fffffffu)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header claims %u Gaussians", d->path, d->n);
  if (d->degree > 4)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: SH degree %d; the format goes to 4", d->path, d->degree);
  const size_t n = d->n;
  d->bytes[0] = n * (d->version == 1 ? 6 : 9);
  d->bytes[1] = n;
  d->bytes[2] = d->bytes[3] = 3 * n;
  d->bytes[4] = n * (d->version >= 3 ? 4 : 3);
  d->bytes[5] = n * 3 * (size_t)sh_dim(d->degree);
  return MGS_OK;
}

static size_t data_bytes(const spz_data *d) {
  size_t s = 0;
  for (int a = 0; a < 6; a++) s += d->bytes[a];
  return s;
}

/* Extension records [u32 type][u32 length][payload]: only the coordinate system matters here. */
static mgs_status read_extensions(spz_data *d, const uint8_t *p, size_t len, mgs_error *err) {
  size_t o = 0;
  while (o + 8 <= len) {
    const uint32_t type = u32le(p + o), n = u32le(p + o + 4);
    if (n > len - o - 8) {
      mgs_warn("%s: extension record 0x%08x runs past its area; the rest are ignored", d->path, type);
      return MGS_OK;
    }
    if (type == EXT_COORDINATE_SYSTEM && n >= 4) {
      const uint32_t c = u32le(p + o + 8);
      if (c >= 9 && c <= 16)
        return mgs_error_set(err, MGS_ERR_FORMAT,
                             "%s: stored in coordinate system %s (SPZ_ADOBE_coordinate_system), a frame rotated about x; "
                             "this reader converts only RUB-family frames (convert the file to RUB first)",
                             d->path, coord_names[c]);
      if (c >= 1 && c <= 8) d->coords = (int)c;
      else mgs_warn("%s: coordinate-system extension with value %u ignored; RUB assumed", d->path, c);
    }
    o += 8 + (size_t)n;
  }
  return MGS_OK;
}

/* Versions 1-3: one gzip stream. Inflates only what the header says is there (plus the
 * extension records when flagged), so a small file cannot claim gigabytes. */
static mgs_status gunzip(spz_data *d, const uint8_t *in, size_t n_in, uint8_t **out, mgs_error *err) {
  z_stream z;
  memset(&z, 0, sizeof z);
  if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot start zlib", d->path);
  z.next_in = (Bytef *)in;
  z.avail_in = (uInt)(n_in > 0xffffffffu ? 0xffffffffu : n_in);
  mgs_status st = MGS_OK;
  size_t cap = LEGACY_HEADER, len = 0, need = 0;
  uint8_t *buf = malloc(cap);
  int ended = 0, have_header = 0;
  if (!buf) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", d->path); goto done; }
  for (;;) {
    if (len == cap && !have_header) {
      if ((st = read_header(d, buf, 0, err)) != MGS_OK) goto done;
      have_header = 1;
      need = LEGACY_HEADER + data_bytes(d);
      /* deflate cannot expand data more than ~1032 times */
      if ((need - LEGACY_HEADER) / 1100 > n_in) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: header claims %u Gaussians (%zu bytes); a %zu-byte gzip stream cannot hold them",
                           d->path, d->n, need, n_in);
        goto done;
      }
      cap = need + ((d->flags & 2) ? LEGACY_EXT_MAX : 0);
      uint8_t *nb = realloc(buf, cap);
      if (!nb) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %u Gaussians", d->path, d->n); goto done; }
      buf = nb;
    }
    if (len == cap || ended) break;
    z.next_out = buf + len;
    z.avail_out = (uInt)(cap - len > 0x40000000u ? 0x40000000u : cap - len);
    const uInt before = z.avail_out;
    const int r = inflate(&z, Z_NO_FLUSH);
    len += before - z.avail_out;
    if (r == Z_STREAM_END) ended = 1;
    else if (r == Z_BUF_ERROR && z.avail_in == 0) ended = 1; /* input used up: checked below */
    else if (r != Z_OK) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: corrupt gzip data (%s)", d->path, z.msg ? z.msg : "inflate failed");
      goto done;
    }
  }
  if (!have_header) {
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: gzip data of %zu bytes ends inside the 16-byte .spz header", d->path, len);
    goto done;
  }
  if (len < need) {
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: truncated: %u Gaussians of version %u need %zu bytes after decompression, the file holds %zu",
                       d->path, d->n, d->version, need, len);
    goto done;
  }
  size_t o = LEGACY_HEADER;
  for (int a = 0; a < 6; a++) {
    d->at[a] = buf + o;
    o += d->bytes[a];
  }
  if (d->flags & 2) st = read_extensions(d, buf + need, len - need, err);
done:
  inflateEnd(&z);
  if (st != MGS_OK) {
    free(buf);
    buf = NULL;
  }
  *out = buf;
  return st;
}

/* Version 4: a 32-byte header, extension records, a table of contents and one zstd
 * stream per non-empty attribute, in stream order. */
static mgs_status unzstd(spz_data *d, const uint8_t *in, size_t n_in, uint8_t **out, mgs_error *err) {
  *out = NULL;
  if (n_in < NGSP_HEADER) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %zu bytes; an NGSP header is 32", d->path, n_in);
  mgs_status st = read_header(d, in, 1, err);
  if (st != MGS_OK) return st;
  const int n_streams = in[15];
  const uint32_t toc = u32le(in + 16);
  /* the official bound: at most 1024:1 compression of the 9 position bytes per point */
  if ((uint64_t)d->n > (uint64_t)n_in * 1024 / 9)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: header claims %u Gaussians; a %zu-byte file cannot hold them", d->path, d->n, n_in);
  int expect = 0;
  for (int a = 0; a < 6; a++) expect += d->bytes[a] > 0;
  if (n_streams != expect)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: %d streams; SH degree %d needs %d", d->path, n_streams, d->degree, expect);
  if (toc < NGSP_HEADER || (uint64_t)toc + 16u * (uint64_t)n_streams > n_in)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: table of contents at byte %u (%d entries) lies outside the %zu-byte file", d->path, toc,
                         n_streams, n_in);
  if ((d->flags & 2) && (st = read_extensions(d, in + NGSP_HEADER, toc - NGSP_HEADER, err)) != MGS_OK) return st;
  uint8_t *buf = malloc(data_bytes(d));
  if (!buf) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %u Gaussians", d->path, d->n);
  size_t src = (size_t)toc + 16u * (size_t)n_streams, dst = 0;
  int entry = 0;
  for (int a = 0; a < 6; a++) {
    if (!d->bytes[a]) continue;
    const uint8_t *e = in + toc + 16 * entry++;
    const uint64_t zn = u64le(e), un = u64le(e + 8);
    if (un != d->bytes[a]) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: stream %d holds %llu bytes; %u Gaussians need %zu", d->path, entry - 1,
                         (unsigned long long)un, d->n, d->bytes[a]);
      goto fail;
    }
    if (zn > n_in - src) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: truncated: stream %d (%llu bytes) runs past the end of the file", d->path, entry - 1,
                         (unsigned long long)zn);
      goto fail;
    }
    const size_t r = ZSTD_decompress(buf + dst, d->bytes[a], in + src, (size_t)zn);
    if (ZSTD_isError(r) || r != d->bytes[a]) {
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: stream %d: corrupt zstd data (%s)", d->path, entry - 1,
                         ZSTD_isError(r) ? ZSTD_getErrorName(r) : "short");
      goto fail;
    }
    d->at[a] = buf + dst;
    dst += d->bytes[a];
    src += (size_t)zn;
  }
  if (src != n_in) mgs_warn("%s: %zu bytes after the last stream ignored", d->path, n_in - src);
  *out = buf;
  return MGS_OK;
fail:
  free(buf);
  return st;
}

static float half_to_float(uint16_t h) {
  const int e = (h >> 10) & 31, m = h & 1023;
  const double v = e == 0 ? ldexp(m, -24) : e == 31 ? (m ? NAN : INFINITY) : ldexp(1024 + m, e - 25);
  return (float)((h & 0x8000) ? -v : v);
}

/* Fills g and xyz from the attribute bytes, converting from d->coords to RDF. */
static mgs_status decode(const spz_data *d, mgs_gaussians *g, double *xyz, mgs_error *err) {
  const int a = d->coords - 1, b = COORDS_RDF - 1;
  const double fx = ((a ^ b) & 1) ? -1 : 1, fy = ((a ^ b) & 2) ? -1 : 1, fz = ((a ^ b) & 4) ? -1 : 1;
  const double fp[3] = {fx, fy, fz}, fq[3] = {fy * fz, fx * fz, fx * fy};
  /* sign of each SH basis function of degrees 1-3 under the axis flips (3DGS order) */
  const double fsh[15] = {fy, fz, fx, fx * fy, fy * fz, 1, fx * fz, 1, fy, fx * fy * fz, fy, fz, fx, fz, fx};
  const int dim = sh_dim(d->degree), keep = dim < 15 ? dim : 15;
  const double unit = ldexp(1.0, -d->fbits);
  for (size_t i = 0; i < d->n; i++) {
    for (int k = 0; k < 3; k++) {
      double x;
      if (d->version == 1) {
        const uint8_t *p = d->at[0] + 6 * i + 2 * (size_t)k;
        x = half_to_float((uint16_t)(p[0] | p[1] << 8));
        if (!isfinite(x))
          return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: Gaussian %zu: position %d is not finite (float16 %g)", d->path, i, k, x);
      } else {
        const uint8_t *p = d->at[0] + 9 * i + 3 * (size_t)k;
        int32_t v = (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16);
        if (v & 0x800000) v -= 0x1000000;
        x = v * unit;
      }
      xyz[3 * i + (size_t)k] = fp[k] * x;
      g->log_scale[3 * i + (size_t)k] = (float)(d->at[3][3 * i + (size_t)k] / 16.0 - 10.0);
      g->sh_dc[3 * i + (size_t)k] = (float)((d->at[2][3 * i + (size_t)k] / 255.0 - 0.5) / COLOR_SCALE);
    }
    /* 8 bits cannot say 0 or 1: the ends stay half a quantum inside, the logit finite */
    const double al = fmin(fmax(d->at[1][i] / 255.0, 0.5 / 255.0), 1.0 - 0.5 / 255.0);
    g->opacity[i] = (float)log(al / (1.0 - al));
    double q[4]; /* x y z w */
    if (d->version >= 3) {
      uint32_t c = u32le(d->at[4] + 4 * i);
      const int big = (int)(c >> 30);
      double ss = 0;
      for (int k = 3; k >= 0; k--) {
        if (k == big) continue;
        const double m = 0.70710678118654752 * (double)(c & 511u) / 511.0;
        q[k] = (c >> 9) & 1u ? -m : m;
        ss += q[k] * q[k];
        c >>= 10;
      }
      q[big] = sqrt(fmax(0.0, 1.0 - ss));
    } else {
      const uint8_t *r = d->at[4] + 3 * i;
      double ss = 0;
      for (int k = 0; k < 3; k++) {
        q[k] = r[k] / 127.5 - 1.0;
        ss += q[k] * q[k];
      }
      q[3] = sqrt(fmax(0.0, 1.0 - ss));
    }
    double len = 0;
    for (int k = 0; k < 4; k++) len += q[k] * q[k];
    len = sqrt(len);
    float *rot = g->rot + 4 * i; /* w x y z */
    rot[0] = (float)(q[3] / len);
    for (int k = 0; k < 3; k++) rot[1 + k] = (float)(fq[k] * q[k] / len);
    float *rest = g->sh_rest + i * MGS_SH_REST_MAX;
    memset(rest, 0, sizeof(float) * MGS_SH_REST_MAX);
    const uint8_t *s = d->at[5] ? d->at[5] + i * 3 * (size_t)dim : NULL;
    for (int k = 0; k < keep; k++)
      for (int c = 0; c < 3; c++) rest[3 * k + c] = (float)(fsh[k] * (s[3 * k + c] - 128.0) / 128.0);
  }
  return MGS_OK;
}

mgs_status spz_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err) {
  *g = NULL;
  *xyz64 = NULL;
  char *text = NULL;
  uint8_t *data = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &text, &size, err);
  uint8_t *file = (uint8_t *)text;
  if (st != MGS_OK) return st;
  spz_data d;
  memset(&d, 0, sizeof d);
  d.path = path;
  d.coords = COORDS_RUB;
  if (size >= 2 && file[0] == 0x1f && file[1] == 0x8b) st = gunzip(&d, file, size, &data, err);
  else if (size >= 4 && u32le(file) == NGSP_MAGIC) st = unzstd(&d, file, size, &data, err);
  else st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: neither gzip (.spz versions 1-3) nor an 'NGSP' header (version 4); not an .spz file", path);
  free(file);
  if (st != MGS_OK) return st;
  if (d.degree > 3) mgs_warn("%s: SH degree %d; degrees 0-3 are kept, degree 4 is dropped", path, d.degree);
  if (d.flags & 1)
    mgs_warn("%s: trained with antialiasing (Mip-Splatting's filter); rendered here without its opacity compensation", path);
  mgs_gaussians *m = mgs_gaussians_create(d.n, d.degree < 3 ? d.degree : 3);
  double *xyz = malloc((size_t)d.n * 3 * sizeof(double));
  size_t first = 0;
  if (!m || !xyz || mgs_gaussians_append(m, d.n, &first, err) != MGS_OK)
    st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %u Gaussians", path, d.n);
  else st = decode(&d, m, xyz, err);
  free(data);
  if (st != MGS_OK) {
    free(xyz);
    mgs_gaussians_destroy(m);
    return st;
  }
  *g = m;
  *xyz64 = xyz;
  return MGS_OK;
}
