/* Training checkpoints: one binary file, written atomically (temp + rename), so a crash or
 * Ctrl-C never leaves a half-written checkpoint in place.
 *
 * Layout (little-endian, as the host): "MGSCKPT\0", u32 version, u32 byte-order mark,
 * then the header fields below, the view order, the model's six groups, Adam's first and
 * second moments, the strategy's name (32 bytes) and its blob (u64 size + bytes), and a
 * final u64 FNV-1a checksum of everything before it. */
#include <stdlib.h>
#include <string.h>
#include "train/trainer_internal.h"
#include "core/mgs_fs.h"

#define CKPT_VERSION 1u
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

typedef struct { FILE *f; uint64_t h; int ok; } hwriter;
static void hw(hwriter *w, const void *p, size_t n) {
  if (!w->ok || n == 0) return;
  w->h = fnv(w->h, p, n);
  w->ok = fwrite(p, 1, n, w->f) == n;
}

mgs_status mgs_trainer_save_checkpoint(const mgs_trainer *t, const char *path, mgs_error *err) {
  /* the strategy's state first, into memory */
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
  mgs_atomic_file *af = NULL;
  FILE *f = NULL;
  mgs_status st = mgs_atomic_open(path, &af, &f, err);
  if (st) { free(blob); return st; }
  hwriter w = {f, 1469598103934665603ull, 1};
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
    hw(&w, t->adam->v[k], bytes);
  }
  uint64_t bl = blob_len;
  hw(&w, sname, sizeof sname);
  hw(&w, &bl, sizeof bl);
  hw(&w, blob, blob_len);
  free(blob);
  uint64_t sum = w.h;
  if (w.ok) w.ok = fwrite(&sum, sizeof sum, 1, f) == 1;
  if (!w.ok) {
    mgs_atomic_abort(af);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write the checkpoint", path);
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
  if (ver != CKPT_VERSION) FAIL(MGS_ERR_UNSUPPORTED, "%s: checkpoint version %u, this build reads %u", path, ver, CKPT_VERSION);
  if (!rd(&r, &h, sizeof h)) FAIL(MGS_ERR_FORMAT, "%s: checkpoint header truncated", path);
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
    ok = ok && rd(&r, t->adam->m[k], bytes) && rd(&r, t->adam->v[k], bytes);
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
  memcpy(t->perm, perm, t->perm_len * sizeof(uint32_t));
  free(perm);
  t->perm_pos = (size_t)h.perm_pos;
  t->iteration = (int)h.iteration;
  t->active_sh = h.active_sh;
  t->rng.state = h.rng_state; t->rng.inc = h.rng_inc;
  t->seconds = h.seconds; t->ema_loss = h.ema_loss; t->ema_psnr = h.ema_psnr;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) t->adam->t[k] = h.adam_t[k];
  free(data);
  mgs_trainer_scale_invalidate(t); /* the tiles bound the old model */
  st = mgs_gaussians_check_finite(t->g, err);
  return st;
#undef FAIL
}
