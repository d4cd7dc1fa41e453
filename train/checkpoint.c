/* Training checkpoints: one binary file, written atomically (temp + rename), so a crash or
 * Ctrl-C never leaves a half-written checkpoint in place.
 *
 * Layout (little-endian, as the host): "MGSCKPT\0", u32 version, u32 byte-order mark,
 * then the header fields below, the view order, the model's six groups, Adam's first and
 * second moments, the strategy's name (32 bytes) and its blob (u64 size + bytes), the
 * loss terms (version 2: u32 count, then per term its name (32 bytes) and blob), and a
 * scene origin (version 3: 3 f64, core/mgs_origin.h), the training CPU seconds (version 4:
 * one f64), and a final u64 FNV-1a checksum of everything before it. Version 1 files (no terms) are read by runs without loss terms;
 * versions 1 and 2 (no origin) by runs whose dataset has the origin (0,0,0). A resume
 * whose dataset gives another origin (the folder changed) is refused. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "train/trainer_internal.h"
#include "core/mgs_fs.h"
#include "core/mgs_origin.h"

#define CKPT_VERSION 4u
static const char CKPT_MAGIC[8] = {'M', 'G', 'S', 'C', 'K', 'P', 'T', 0};

typedef struct {
  int64_t iteration;
  int32_t active_sh, sh_degree;
  uint64_t n;
  uint64_t rng_state, rng_inc;
  uint64_t perm_len, perm_pos;
  double seconds, ema_loss, ema_psnr;
  int64_t adam_t[MGS_PARAM_COUNT];
} ckpt_header;

static uint64_t fnv(uint64_t h, const void *p, size_t n) {
  const unsigned char *b = p;
  for (size_t i = 0; i < n; i++) { h ^= b[i]; h *= 1099511628211ull; }
  return h;
}

typedef struct { FILE *f; uint64_t h; int ok, errnum; } hwriter;
static void hw(hwriter *w, const void *p, size_t n) {
  if (!w->ok || n == 0) return;
  w->h = fnv(w->h, p, n);
  w->ok = fwrite(p, 1, n, w->f) == n;
  if (!w->ok) w->errnum = errno; /* disk full, file size limit: said in the message */
}

/* The loss terms' states, serialized into one buffer: u32 count, then per term its name
 * (32 bytes), u64 size and bytes. */
static mgs_status terms_blob(const mgs_trainer *t, const char *path, char **out, size_t *out_len, mgs_error *err) {
  *out = NULL; *out_len = 0;
  FILE *mf = open_memstream(out, out_len);
  if (!mf) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot buffer the loss terms' state", path);
  uint32_t nt = (uint32_t)t->n_terms;
  int ok = fwrite(&nt, 4, 1, mf) == 1;
  mgs_status st = MGS_OK;
  for (size_t k = 0; k < t->n_terms && ok && st == MGS_OK; k++) {
    const mgs_term *tm = t->terms[k];
    char name[32] = {0};
    snprintf(name, sizeof name, "%s", tm->ops->name);
    char *b = NULL;
    size_t bl = 0;
    FILE *tf = open_memstream(&b, &bl);
    if (!tf) { st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot buffer the loss terms' state", path); break; }
    st = tm->ops->save ? tm->ops->save(tm->self, tf, err) : MGS_OK;
    fclose(tf);
    uint64_t l = bl;
    ok = st == MGS_OK && fwrite(name, 1, 32, mf) == 32 && fwrite(&l, 8, 1, mf) == 1 && (bl == 0 || fwrite(b, 1, bl, mf) == bl);
    free(b);
  }
  fclose(mf);
  if (st == MGS_OK && !ok) st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot buffer the loss terms' state", path);
  if (st) { free(*out); *out = NULL; }
  return st;
}

mgs_status mgs_trainer_save_checkpoint(const mgs_trainer *t, const char *path, mgs_error *err) {
  /* the strategy's and the terms' state first, into memory */
  char *blob = NULL;
  size_t blob_len = 0;
  char sname[32] = {0};
  if (t->strategy) {
    snprintf(sname, sizeof sname, "%s", t->strategy->ops->name);
    FILE *mf = open_memstream(&blob, &blob_len);
    if (!mf) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: cannot buffer the strategy state", path);
    mgs_status st = t->strategy->ops->save ? t->strategy->ops->save(t->strategy->self, mf, err) : MGS_OK;
    fclose(mf);
    if (st) { free(blob); return st; }
  }
  char *tblob = NULL;
  size_t tblob_len = 0;
  {
    mgs_status st = terms_blob(t, path, &tblob, &tblob_len, err);
    if (st) { free(blob); return st; }
  }
  mgs_atomic_file *af = NULL;
  FILE *f = NULL;
  mgs_status st = mgs_atomic_open(path, &af, &f, err);
  if (st) { free(blob); free(tblob); return st; }
  hwriter w = {f, 1469598103934665603ull, 1, 0};
  uint32_t ver = CKPT_VERSION, bom = 0x01020304u;
  ckpt_header h;
  memset(&h, 0, sizeof h);
  h.iteration = t->iteration; h.active_sh = t->active_sh; h.sh_degree = t->g->sh_degree;
  h.n = t->g->n; h.rng_state = t->rng.state; h.rng_inc = t->rng.inc;
  h.perm_len = t->perm_len; h.perm_pos = t->perm_pos;
  h.seconds = t->seconds; h.ema_loss = t->ema_loss; h.ema_psnr = t->ema_psnr;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) h.adam_t[k] = t->adam->t[k];
  hw(&w, CKPT_MAGIC, 8); hw(&w, &ver, 4); hw(&w, &bom, 4);
  hw(&w, &h, sizeof h);
  hw(&w, t->perm, t->perm_len * sizeof(uint32_t));
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t bytes = t->g->n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float);
    hw(&w, mgs_gaussians_group(t->g, (mgs_param_group)k), bytes);
  }
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t bytes = t->g->n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float);
    hw(&w, t->adam->m[k], bytes);
    if (t->adam->v[k]) hw(&w, t->adam->v[k], bytes);
    else /* packed SH-rest moments (v in m's words): zeros, the layout of every version */
      for (size_t z = 0; z < bytes;) {
        static const char zeros[4096];
        size_t c = bytes - z < sizeof zeros ? bytes - z : sizeof zeros;
        hw(&w, zeros, c);
        z += c;
      }
  }
  uint64_t bl = blob_len;
  hw(&w, sname, sizeof sname);
  hw(&w, &bl, sizeof bl);
  hw(&w, blob, blob_len);
  free(blob);
  hw(&w, tblob, tblob_len);
  free(tblob);
  hw(&w, t->ds->origin, 3 * sizeof(double));
  hw(&w, &t->cpu_seconds, sizeof(double));
  uint64_t sum = w.h;
  if (w.ok && !(w.ok = fwrite(&sum, sizeof sum, 1, f) == 1)) w.errnum = errno;
  if (!w.ok) {
    mgs_atomic_abort(af); /* the previous checkpoint stays in place */
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write the checkpoint (%s); the previous checkpoint is unchanged", path,
                         w.errnum ? strerror(w.errnum) : "write error");
  }
  return mgs_atomic_commit(af, err);
}

typedef struct { const char *p; size_t left; } reader;
static int rd(reader *r, void *dst, size_t n) {
  if (n > r->left) return 0;
  memcpy(dst, r->p, n);
  r->p += n; r->left -= n;
  return 1;
}

mgs_status mgs_trainer_load_checkpoint(mgs_trainer *t, const char *path, mgs_error *err) {
  char *data = NULL;
  size_t size = 0;
  mgs_status st = mgs_read_file(path, &data, &size, err);
  if (st) return st;
#define FAIL(code, ...) do { free(data); return mgs_error_set(err, code, __VA_ARGS__); } while (0)
  if (size < 16 + sizeof(ckpt_header) + 8 || memcmp(data, CKPT_MAGIC, 8) != 0)
    FAIL(MGS_ERR_FORMAT, "%s: not a MorseGS checkpoint", path);
  uint64_t sum;
  memcpy(&sum, data + size - 8, 8);
  if (fnv(1469598103934665603ull, data, size - 8) != sum)
    FAIL(MGS_ERR_FORMAT, "%s: checkpoint is truncated or corrupt (checksum mismatch)", path);
  reader r = {data + 8, size - 16};
  uint32_t ver = 0, bom = 0;
  ckpt_header h;
  if (!rd(&r, &ver, 4) || !rd(&r, &bom, 4)) FAIL(MGS_ERR_FORMAT, "%s: checkpoint header truncated", path);
  if (bom != 0x01020304u) FAIL(MGS_ERR_FORMAT, "%s: checkpoint written on a machine of another byte order", path);
  if (ver != CKPT_VERSION && ver != 3u && ver != 2u && !(ver == 1u && t->n_terms == 0)) FAIL(MGS_ERR_UNSUPPORTED, "%s: checkpoint version %u, this build reads %u", path, ver, CKPT_VERSION);
  if (!rd(&r, &h, sizeof h)) FAIL(MGS_ERR_FORMAT, "%s: checkpoint header truncated", path);
  /* the scene origin (the last record, before the checksum) first: nothing is replaced
     when the dataset now gives another one */
  double origin[3] = {0, 0, 0}, cpu = NAN;
  if (ver >= 4u) {
    if (r.left < sizeof cpu) FAIL(MGS_ERR_FORMAT, "%s: checkpoint truncated (CPU seconds)", path);
    memcpy(&cpu, r.p + r.left - sizeof cpu, sizeof cpu);
    r.left -= sizeof cpu;
  }
  if (ver >= 3u) {
    if (r.left < sizeof origin) FAIL(MGS_ERR_FORMAT, "%s: checkpoint truncated (scene origin)", path);
    memcpy(origin, r.p + r.left - sizeof origin, sizeof origin);
    r.left -= sizeof origin;
  }
  if (memcmp(origin, t->ds->origin, sizeof origin) != 0 && !(mgs_origin_is_zero(origin) && mgs_origin_is_zero(t->ds->origin)))
    FAIL(MGS_ERR_ARG, "%s: checkpoint was trained with the scene origin (%.17g, %.17g, %.17g), the dataset now gives (%.17g, %.17g, %.17g) (its cameras or points changed)",
         path, origin[0], origin[1], origin[2], t->ds->origin[0], t->ds->origin[1], t->ds->origin[2]);
  if (h.perm_len != t->perm_len || h.perm_pos > h.perm_len)
    FAIL(MGS_ERR_FORMAT, "%s: checkpoint has %llu training views, the dataset %zu", path, (unsigned long long)h.perm_len, t->perm_len);
  if (h.sh_degree != t->g->sh_degree || h.active_sh < 0 || h.active_sh > h.sh_degree)
    FAIL(MGS_ERR_FORMAT, "%s: checkpoint SH degree %d does not match the run's %d", path, (int)h.sh_degree, t->g->sh_degree);
  if (h.iteration < 0 || h.iteration > t->o.iterations)
    FAIL(MGS_ERR_ARG, "%s: checkpoint is at iteration %lld, beyond --iters %d", path, (long long)h.iteration, t->o.iterations);
  size_t per = 0;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) per += (size_t)mgs_param_dim((mgs_param_group)k);
  if (h.n == 0 || h.n > r.left / (3 * per * sizeof(float)))
    FAIL(MGS_ERR_FORMAT, "%s: checkpoint Gaussian count %llu does not fit its size", path, (unsigned long long)h.n);
  size_t n = (size_t)h.n;
  uint32_t *perm = malloc(t->perm_len * sizeof(uint32_t) + 1);
  if (!perm) FAIL(MGS_ERR_NOMEM, "%s: out of memory", path);
  if (!rd(&r, perm, t->perm_len * sizeof(uint32_t))) { free(perm); FAIL(MGS_ERR_FORMAT, "%s: checkpoint truncated", path); }
  for (size_t i = 0; i < t->perm_len; i++)
    if (perm[i] >= t->perm_len) { free(perm); FAIL(MGS_ERR_FORMAT, "%s: checkpoint view order is corrupt", path); }
  /* model and moments into the trainer's own arrays */
  if (t->g->capacity < n && (st = mgs_gaussians_reserve(t->g, n, err))) { free(perm); free(data); return st; }
  if (t->adam->n < n && (st = mgs_adam_append(t->adam, n - t->adam->n, err))) { free(perm); free(data); return st; }
  t->g->n = n;
  t->adam->n = n;
  int ok = 1;
  for (int k = 0; k < MGS_PARAM_COUNT; k++)
    ok = ok && rd(&r, mgs_gaussians_group(t->g, (mgs_param_group)k), n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float));
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t bytes = n * (size_t)mgs_param_dim((mgs_param_group)k) * sizeof(float);
    ok = ok && rd(&r, t->adam->m[k], bytes);
    if (t->adam->v[k]) ok = ok && rd(&r, t->adam->v[k], bytes);
    else if (ok && bytes <= r.left) { r.p += bytes; r.left -= bytes; } /* packed: v is in m's words */
    else ok = 0;
  }
  char sname[32];
  uint64_t bl = 0;
  ok = ok && rd(&r, sname, sizeof sname) && rd(&r, &bl, sizeof bl) && bl <= r.left;
  if (!ok) { free(perm); FAIL(MGS_ERR_FORMAT, "%s: checkpoint truncated", path); }
  sname[31] = 0;
  const char *want = t->strategy ? t->strategy->ops->name : "";
  if (strcmp(sname, want) != 0) { free(perm); FAIL(MGS_ERR_ARG, "%s: checkpoint was made with strategy '%s', this run uses '%s'", path, sname, want); }
  if (t->strategy && t->strategy->ops->load) {
    FILE *mf = bl ? fmemopen((void *)r.p, (size_t)bl, "rb") : NULL;
    st = mf ? t->strategy->ops->load(t->strategy->self, mf, n, err)
            : mgs_error_set(err, MGS_ERR_FORMAT, "%s: checkpoint has no strategy state", path);
    if (mf) fclose(mf);
    if (st) { free(perm); free(data); return st; }
  }
  r.p += bl; r.left -= (size_t)bl;
  if (ver >= 2u) {
    uint32_t nt = 0;
    if (!rd(&r, &nt, 4)) { free(perm); FAIL(MGS_ERR_FORMAT, "%s: checkpoint truncated (loss terms)", path); }
    if (nt != t->n_terms) { free(perm); FAIL(MGS_ERR_ARG, "%s: checkpoint was made with %u loss terms, this run has %zu", path, nt, t->n_terms); }
    for (size_t k = 0; k < t->n_terms; k++) {
      char name[32];
      uint64_t l = 0;
      if (!rd(&r, name, 32) || !rd(&r, &l, 8) || l > r.left) { free(perm); FAIL(MGS_ERR_FORMAT, "%s: checkpoint truncated (loss terms)", path); }
      name[31] = 0;
      mgs_term *tm = t->terms[k];
      if (strcmp(name, tm->ops->name)) { free(perm); FAIL(MGS_ERR_ARG, "%s: checkpoint loss term %zu is '%s', this run's is '%s'", path, k + 1, name, tm->ops->name); }
      if (tm->ops->load) {
        FILE *mf = l ? fmemopen((void *)r.p, (size_t)l, "rb") : NULL;
        st = mf ? tm->ops->load(tm->self, mf, err) : mgs_error_set(err, MGS_ERR_FORMAT, "%s: checkpoint has no state for loss term '%s'", path, name);
        if (mf) fclose(mf);
        if (st) { free(perm); free(data); return st; }
      }
      r.p += l; r.left -= (size_t)l;
    }
  }
  memcpy(t->perm, perm, t->perm_len * sizeof(uint32_t));
  free(perm);
  t->perm_pos = (size_t)h.perm_pos;
  t->iteration = (int)h.iteration;
  t->active_sh = h.active_sh;
  t->rng.state = h.rng_state; t->rng.inc = h.rng_inc;
  t->seconds = h.seconds; t->ema_loss = h.ema_loss; t->ema_psnr = h.ema_psnr;
  t->cpu_seconds = cpu;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) t->adam->t[k] = h.adam_t[k];
  free(data);
  mgs_trainer_large_invalidate(t); /* the tiles bound the old model */
  st = mgs_gaussians_check_finite(t->g, err);
  return st;
#undef FAIL
}
