/* PlayCanvas's SOG version 2 -> a 3DGS model (core/sog_format.h). Decoded as splat-transform
 * decodes it (its readSog; facts of the format): position = invlog(min + (max - min) q / 65535)
 * with invlog(v) = sign(v)(e^|v| - 1), a zero range taken as 1; rotation components
 * (byte / 255 * 2 - 1) / sqrt 2 around the largest (index alpha - 252, w x y z order), which
 * the unit norm gives; log-scales and DC colours from their codebooks; opacity the sh0
 * texel's alpha / 255; SH rest: the label (R + 256 G) picks a palette entry, texel
 * (label % 64) * coefficients + k, row label / 64, whose R G B index the codebook. */
#include "core/sog_format.h"
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unzip.h>
#include <webp/decode.h>

#include "core/mgs_fs.h"

#define SOG_MAX_ENTRY (1u << 30) /* bytes of one file in a bundle */

int sog_is_path(const char *path) {
  const size_t n = strlen(path);
  const char *base = strrchr(path, '/');
  base = base ? base + 1 : path;
  return (n > 4 && !strcmp(path + n - 4, ".sog")) || !strcmp(base, "meta.json");
}

/* Where the files are: a folder, or a zip bundle. */
typedef struct sog_src {
  const char *path;
  char *dir;   /* folder of meta.json (NULL for a bundle) */
  unzFile zip; /* the bundle, or NULL */
} sog_src;

static mgs_status zip_read(sog_src *s, const char *name, char **data, size_t *size, mgs_error *err) {
  *data = NULL;
  if (unzLocateFile(s->zip, name, 1) != UNZ_OK)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: the bundle has no '%s'", s->path, name);
  unz_file_info64 info;
  if (unzGetCurrentFileInfo64(s->zip, &info, NULL, 0, NULL, 0, NULL, 0) != UNZ_OK || info.uncompressed_size > SOG_MAX_ENTRY)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: '%s' in the bundle is unreadable or larger than 1 GiB", s->path, name);
  const size_t n = (size_t)info.uncompressed_size;
  char *buf = malloc(n + 1);
  if (!buf) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for '%s'", s->path, name);
  int r = unzOpenCurrentFile(s->zip);
  size_t got = 0;
  while (r == UNZ_OK && got < n) {
    const int k = unzReadCurrentFile(s->zip, buf + got, (unsigned)(n - got > (1u << 30) ? (1u << 30) : n - got));
    if (k <= 0) { r = k < 0 ? k : UNZ_EOF; break; }
    got += (size_t)k;
  }
  const int c = unzCloseCurrentFile(s->zip); /* UNZ_CRCERROR on a corrupt entry */
  if (r != UNZ_OK || got != n || c != UNZ_OK) {
    free(buf);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: '%s' in the bundle is corrupt or truncated", s->path, name);
  }
  buf[n] = 0;
  *data = buf;
  *size = n;
  return MGS_OK;
}

/* A texture as straight RGBA bytes, decoded by libwebp (OIIO's WebP reader premultiplies
 * colour by alpha, and SOG's alpha channels hold data). File names stay inside the folder. */
static mgs_status texture(sog_src *s, const cJSON *files, int k, size_t count, uint8_t **out, int *width, int *height,
                          mgs_error *err) {
  *out = NULL;
  const cJSON *f = cJSON_GetArrayItem(files, k);
  if (!cJSON_IsString(f) || !f->valuestring[0] || strchr(f->valuestring, '/') || strchr(f->valuestring, '\\') ||
      !strcmp(f->valuestring, "..") || !strcmp(f->valuestring, "."))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: file %d of a 'files' list is not a plain file name", s->path, k);
  const char *name = f->valuestring;
  char *data = NULL;
  size_t n = 0;
  mgs_status st = MGS_OK;
  if (s->zip) st = zip_read(s, name, &data, &n, err);
  else {
    char *p = mgs_path_join(s->dir, name);
    if (!p) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", s->path);
    st = mgs_path_exists(p) ? mgs_read_file(p, &data, &n, err) : mgs_error_set(err, MGS_ERR_IO, "%s: '%s' is missing beside it", s->path, name);
    free(p);
  }
  if (st) return st;
  int w = 0, h = 0;
  /* a tiny lossless WebP can claim 16383² texels: never decode far more than the count needs */
  if (!WebPGetInfo((const uint8_t *)data, n, &w, &h)) {
    free(data);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: '%s' is not a WebP image libwebp can decode", s->path, name);
  }
  if ((uint64_t)w * (uint64_t)h > 4 * (uint64_t)count + 65536) {
    free(data);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: '%s' is %dx%d, far more texels than %zu Gaussians need", s->path, name, w, h, count);
  }
  uint8_t *rgba = WebPDecodeRGBA((const uint8_t *)data, n, &w, &h);
  free(data);
  if (!rgba) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: '%s' is not a WebP image libwebp can decode", s->path, name);
  if ((size_t)w * (size_t)h < count) {
    WebPFree(rgba);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: '%s' is %dx%d; %zu Gaussians need that many texels", s->path, name, w, h, count);
  }
  const size_t bytes = (size_t)w * (size_t)h * 4;
  uint8_t *b = malloc(bytes);
  if (b) memcpy(b, rgba, bytes);
  WebPFree(rgba);
  if (!b) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for '%s'", s->path, name);
  *out = b;
  *width = w;
  *height = h;
  return MGS_OK;
}

static int numbers(const cJSON *a, int n, double *out) {
  if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != n) return 0;
  for (int i = 0; i < n; i++) {
    const cJSON *v = cJSON_GetArrayItem(a, i);
    if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble)) return 0;
    out[i] = v->valuedouble;
  }
  return 1;
}

/* Field `key` of `obj` as an object with a "files" list of at least nfiles names. */
static const cJSON *part(const sog_src *s, const cJSON *obj, const char *key, int nfiles, mgs_error *err) {
  const cJSON *o = cJSON_GetObjectItemCaseSensitive(obj, key);
  const cJSON *f = cJSON_GetObjectItemCaseSensitive(o, "files");
  if (!cJSON_IsObject(o) || !cJSON_IsArray(f) || cJSON_GetArraySize(f) < nfiles) {
    mgs_error_set(err, MGS_ERR_FORMAT, "%s: meta.json has no '%s' with %d file name%s", s->path, key, nfiles, nfiles > 1 ? "s" : "");
    return NULL;
  }
  return o;
}

static double inv_log(double v) { return v < 0 ? -(exp(-v) - 1) : exp(v) - 1; }

static mgs_status decode(sog_src *s, const cJSON *meta, mgs_gaussians **g, double **xyz64, mgs_error *err) {
  const cJSON *ver = cJSON_GetObjectItemCaseSensitive(meta, "version");
  if (!ver)
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: SOG version 1 (meta.json without 'version'); re-save it with splat-transform "
                         "(version 2) to read it here", s->path);
  if (!cJSON_IsNumber(ver) || ver->valuedouble != 2)
    return cJSON_IsNumber(ver) ? mgs_error_set(err, MGS_ERR_FORMAT, "%s: SOG version %g; this reader knows version 2", s->path, ver->valuedouble)
                               : mgs_error_set(err, MGS_ERR_FORMAT, "%s: SOG 'version' is not a number", s->path);
  const cJSON *cnt = cJSON_GetObjectItemCaseSensitive(meta, "count");
  if (!cJSON_IsNumber(cnt) || !(cnt->valuedouble >= 1) || cnt->valuedouble > 2e9 || cnt->valuedouble != floor(cnt->valuedouble))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: 'count' is not a positive integer", s->path);
  const size_t n = (size_t)cnt->valuedouble;
  const cJSON *means = part(s, meta, "means", 2, err), *scales = means ? part(s, meta, "scales", 1, err) : NULL;
  const cJSON *quats = scales ? part(s, meta, "quats", 1, err) : NULL, *sh0 = quats ? part(s, meta, "sh0", 1, err) : NULL;
  if (!sh0) return MGS_ERR_FORMAT;
  double lo[3], hi[3], scode[256], ccode[256], rcode[256];
  if (!numbers(cJSON_GetObjectItemCaseSensitive(means, "mins"), 3, lo) || !numbers(cJSON_GetObjectItemCaseSensitive(means, "maxs"), 3, hi))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: 'means' needs 'mins' and 'maxs' of 3 finite numbers", s->path);
  if (!numbers(cJSON_GetObjectItemCaseSensitive(scales, "codebook"), 256, scode) ||
      !numbers(cJSON_GetObjectItemCaseSensitive(sh0, "codebook"), 256, ccode))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: 'scales' and 'sh0' need a 'codebook' of 256 finite numbers", s->path);
  const cJSON *shn = cJSON_GetObjectItemCaseSensitive(meta, "shN");
  int bands = 0, palette = 0;
  if (shn) {
    const cJSON *b = cJSON_GetObjectItemCaseSensitive(shn, "bands"), *c = cJSON_GetObjectItemCaseSensitive(shn, "count");
    if (!part(s, meta, "shN", 2, err)) return MGS_ERR_FORMAT;
    if (!cJSON_IsNumber(b) || b->valuedouble < 0 || b->valuedouble > 3 || b->valuedouble != floor(b->valuedouble) || !cJSON_IsNumber(c) ||
        !(c->valuedouble >= 1) || c->valuedouble > 65536 || !numbers(cJSON_GetObjectItemCaseSensitive(shn, "codebook"), 256, rcode))
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: 'shN' needs 'bands' 0..3, a 'count' of 1..65536 and a 'codebook' of 256 numbers",
                           s->path);
    bands = (int)b->valuedouble;
    palette = (int)c->valuedouble;
  }
  const int coeffs = bands ? (bands + 1) * (bands + 1) - 1 : 0;
  uint8_t *tl = NULL, *tu = NULL, *tq = NULL, *ts = NULL, *tc = NULL, *tcent = NULL, *tlab = NULL;
  int w = 0, h = 0, wcent = 0, hcent = 0;
  mgs_status st = texture(s, cJSON_GetObjectItemCaseSensitive(means, "files"), 0, n, &tl, &w, &h, err);
  if (!st) st = texture(s, cJSON_GetObjectItemCaseSensitive(means, "files"), 1, n, &tu, &w, &h, err);
  if (!st) st = texture(s, cJSON_GetObjectItemCaseSensitive(quats, "files"), 0, n, &tq, &w, &h, err);
  if (!st) st = texture(s, cJSON_GetObjectItemCaseSensitive(scales, "files"), 0, n, &ts, &w, &h, err);
  if (!st) st = texture(s, cJSON_GetObjectItemCaseSensitive(sh0, "files"), 0, n, &tc, &w, &h, err);
  if (!st && coeffs) {
    const cJSON *files = cJSON_GetObjectItemCaseSensitive(shn, "files");
    st = texture(s, files, 0, (size_t)palette * (size_t)coeffs, &tcent, &wcent, &hcent, err);
    /* the palette: 64 entries a row, `coeffs` texels each */
    if (!st && (wcent != 64 * coeffs || (size_t)hcent * 64 < (size_t)palette))
      st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: the SH palette texture is %dx%d; %d entries of %d bands need %d texels wide and %d rows",
                         s->path, wcent, hcent, palette, bands, 64 * coeffs, (palette + 63) / 64);
    if (!st) st = texture(s, files, 1, n, &tlab, &w, &h, err);
  }
  mgs_gaussians *m = NULL;
  double *xyz = NULL;
  size_t first = 0;
  if (!st) {
    m = mgs_gaussians_create(n, bands);
    xyz = malloc(n * 3 * sizeof(double));
    if (!m || !xyz || mgs_gaussians_append(m, n, &first, err) != MGS_OK)
      st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %zu Gaussians", s->path, n);
  }
  for (size_t i = 0; !st && i < n; i++) {
    const uint8_t *a = tl + 4 * i, *b = tu + 4 * i;
    for (int k = 0; k < 3; k++) {
      const double range = hi[k] - lo[k] != 0 ? hi[k] - lo[k] : 1.0;
      xyz[3 * i + (size_t)k] = inv_log(lo[k] + range * (double)(a[k] | b[k] << 8) / 65535.0);
      m->log_scale[3 * i + (size_t)k] = (float)scode[ts[4 * i + (size_t)k]];
      m->sh_dc[3 * i + (size_t)k] = (float)ccode[tc[4 * i + (size_t)k]];
    }
    /* 8 bits cannot say 0 or 1: the ends stay half a quantum inside, the logit finite */
    const double al = fmin(fmax(tc[4 * i + 3] / 255.0, 0.5 / 255.0), 1.0 - 0.5 / 255.0);
    m->opacity[i] = (float)log(al / (1.0 - al));
    const uint8_t *q = tq + 4 * i;
    float *rot = m->rot + 4 * i;
    if (q[3] < 252) { /* no largest-component tag: the writer's identity */
      rot[0] = 1;
      rot[1] = rot[2] = rot[3] = 0;
    } else {
      const int big = q[3] - 252;
      double c[4], ss = 0;
      for (int k = 0, j = 0; k < 4; k++) {
        if (k == big) continue;
        c[k] = (q[j++] / 255.0 * 2.0 - 1.0) / sqrt(2.0);
        ss += c[k] * c[k];
      }
      c[big] = sqrt(fmax(0.0, 1.0 - ss));
      for (int k = 0; k < 4; k++) rot[k] = (float)c[k];
    }
    float *rest = m->sh_rest + i * MGS_SH_REST_MAX;
    memset(rest, 0, sizeof(float) * MGS_SH_REST_MAX);
    if (coeffs) {
      const int label = tlab[4 * i] | tlab[4 * i + 1] << 8;
      if (label >= palette) {
        st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: Gaussian %zu: SH palette label %d; the palette has %d entries", s->path, i, label,
                           palette);
        break;
      }
      for (int k = 0; k < coeffs; k++) {
        const uint8_t *t = tcent + 4 * ((size_t)(label / 64) * (size_t)wcent + (size_t)(label % 64) * (size_t)coeffs + (size_t)k);
        for (int ch = 0; ch < 3; ch++) rest[3 * k + ch] = (float)rcode[t[ch]];
      }
    }
  }
  free(tl);
  free(tu);
  free(tq);
  free(ts);
  free(tc);
  free(tcent);
  free(tlab);
  if (st) {
    mgs_gaussians_destroy(m);
    free(xyz);
    return st;
  }
  *g = m;
  *xyz64 = xyz;
  return MGS_OK;
}

mgs_status sog_read_gaussians(const char *path, mgs_gaussians **g, double **xyz64, mgs_error *err) {
  *g = NULL;
  *xyz64 = NULL;
  sog_src s = {path, NULL, NULL};
  char *text = NULL;
  size_t size = 0;
  mgs_status st = MGS_OK;
  const size_t n = strlen(path);
  if (n > 4 && !strcmp(path + n - 4, ".sog")) {
    if (!(s.zip = unzOpen64(path))) {
      return mgs_path_exists(path) ? mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a zip bundle (a .sog is one)", path)
                                   : mgs_error_set(err, MGS_ERR_IO, "%s: cannot open: %s", path, strerror(ENOENT));
    }
    st = zip_read(&s, "meta.json", &text, &size, err);
  } else {
    s.dir = mgs_path_dirname(path);
    st = mgs_read_file(path, &text, &size, err);
  }
  cJSON *meta = NULL;
  if (!st && !(meta = cJSON_ParseWithLength(text, size)))
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: meta.json is not valid JSON", path);
  if (!st && !cJSON_IsObject(meta)) st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: meta.json is not a JSON object", path);
  if (!st) st = decode(&s, meta, g, xyz64, err);
  cJSON_Delete(meta);
  free(text);
  if (s.zip) unzClose(s.zip);
  free(s.dir);
  return st;
}
