/* The byte-budget LRU cache of 8-bit training images and its prefetch thread (see
 * core/mgs_image_cache.h). One mutex guards the entries; decoding runs outside it, an
 * entry being decoded is marked LOADING so nobody decodes it twice (get waits on the
 * condition variable instead). */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include "core/mgs_image_cache.h"

enum { ENTRY_EMPTY = 0, ENTRY_LOADING, ENTRY_READY };

typedef struct entry {
  int state;
  uint8_t *rgb;       /* width*height*3 when READY */
  size_t bytes;
  uint64_t last_use;
} entry;

struct mgs_image_cache {
  mgs_dataset *ds;
  mgs_split split;
  size_t n;
  entry *e;
  size_t budget, resident;
  uint64_t tick;
  pthread_mutex_t mu;
  pthread_cond_t cv;       /* an entry finished loading / the prefetch list changed */
  pthread_t thread;
  int have_thread, stop;
  uint32_t *want;          /* prefetch list */
  size_t n_want, cap_want, want_gen;
  mgs_image_cache_stats st;
};

static size_t view_bytes(const mgs_view *v) { return (size_t)v->cam.width * (size_t)v->cam.height * 3; }

/* Decodes view i into a new 8-bit buffer (no lock held). */
static mgs_status decode(mgs_image_cache *c, size_t i, uint8_t **out, mgs_error *err) {
  mgs_view *v = &c->ds->views[c->split][i];
  *out = NULL;
  mgs_status st = mgs_dataset_load_image(c->ds, v, err);
  if (st != MGS_OK) return st;
  const mgs_image *im = v->image;
  if (im->channels != 3 || im->width != v->cam.width || im->height != v->cam.height)
    st = mgs_error_set(err, MGS_ERR_FORMAT, "%s: image is %dx%dx%d, camera expects %dx%d RGB", v->image_path, im->width,
                       im->height, im->channels, v->cam.width, v->cam.height);
  uint8_t *b = st == MGS_OK ? malloc(view_bytes(v)) : NULL;
  if (st == MGS_OK && !b) st = mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for the image cache", v->image_path);
  if (b)
    for (size_t k = 0, m = view_bytes(v); k < m; k++) {
      float x = im->data[k];
      x = x < 0 ? 0 : (x > 1 ? 1 : x);
      b[k] = (uint8_t)lrintf(x * 255.0f);
    }
  /* the float image (and alpha) are not kept: that is the point */
  mgs_image_destroy(v->image);
  mgs_image_destroy(v->alpha);
  v->image = v->alpha = NULL;
  *out = b;
  return st;
}

/* Frees least recently used READY entries (never `keep`, nor those with last_use >=
 * protect_from) until `need` more bytes fit. Lock held. */
static void make_room(mgs_image_cache *c, size_t need, size_t keep, uint64_t protect_from) {
  while (c->resident + need > c->budget) {
    size_t victim = c->n;
    uint64_t oldest = UINT64_MAX;
    for (size_t i = 0; i < c->n; i++)
      if (i != keep && c->e[i].state == ENTRY_READY && c->e[i].last_use < protect_from && c->e[i].last_use < oldest) {
        oldest = c->e[i].last_use;
        victim = i;
      }
    if (victim == c->n) return;
    free(c->e[victim].rgb);
    c->e[victim].rgb = NULL;
    c->e[victim].state = ENTRY_EMPTY;
    c->resident -= c->e[victim].bytes;
    c->st.evictions++;
  }
}

static void insert(mgs_image_cache *c, size_t i, uint8_t *rgb, uint64_t use) {
  entry *e = &c->e[i];
  e->rgb = rgb;
  e->bytes = view_bytes(&c->ds->views[c->split][i]);
  e->state = ENTRY_READY;
  e->last_use = use;
  c->resident += e->bytes;
  if (c->resident > c->st.peak_bytes) c->st.peak_bytes = c->resident;
  c->st.decodes++;
}

/* Prefetched entries are stamped with ticks ahead of the present, in list order, so LRU
 * eviction takes them last and in reverse order of need. */
#define FUTURE (UINT64_C(1) << 62)

static void *prefetch_main(void *arg) {
  mgs_image_cache *c = arg;
  pthread_mutex_lock(&c->mu);
  while (!c->stop) {
    /* the first wanted view not resident, if it fits without evicting a wanted one */
    size_t pick = c->n, pos = 0;
    for (size_t k = 0; k < c->n_want; k++) {
      size_t i = c->want[k];
      if (c->e[i].state == ENTRY_EMPTY) { pick = i; pos = k; break; }
    }
    if (pick == c->n) { pthread_cond_wait(&c->cv, &c->mu); continue; }
    size_t need = view_bytes(&c->ds->views[c->split][pick]);
    make_room(c, need, pick, FUTURE);
    if (c->resident + need > c->budget) { pthread_cond_wait(&c->cv, &c->mu); continue; }
    c->e[pick].state = ENTRY_LOADING;
    size_t gen = c->want_gen;
    pthread_mutex_unlock(&c->mu);
    uint8_t *rgb = NULL;
    mgs_error err;
    mgs_status st = decode(c, pick, &rgb, &err);
    pthread_mutex_lock(&c->mu);
    if (st == MGS_OK && rgb) {
      make_room(c, need, pick, FUTURE);
      insert(c, pick, rgb, FUTURE + (gen == c->want_gen ? (uint64_t)(c->n_want - pos) : 0));
    } else {
      c->e[pick].state = ENTRY_EMPTY; /* get decodes it again and reports the error */
      free(rgb);
      /* drop it from the list so the thread does not spin on it */
      for (size_t k = 0; k < c->n_want; k++)
        if (c->want[k] == pick) { memmove(c->want + k, c->want + k + 1, (c->n_want - k - 1) * sizeof *c->want); c->n_want--; break; }
    }
    pthread_cond_broadcast(&c->cv);
  }
  pthread_mutex_unlock(&c->mu);
  return NULL;
}

mgs_status mgs_image_cache_create(mgs_dataset *ds, mgs_split split, size_t budget_bytes, int prefetch_thread,
                                  mgs_image_cache **out, mgs_error *err) {
  *out = NULL;
  if (!ds || split < 0 || split >= MGS_SPLIT_COUNT) return mgs_error_set(err, MGS_ERR_ARG, "image cache: bad arguments");
  mgs_image_cache *c = calloc(1, sizeof *c);
  if (!c) return mgs_error_set(err, MGS_ERR_NOMEM, "image cache: out of memory");
  c->ds = ds;
  c->split = split;
  c->n = ds->n_views[split];
  c->budget = budget_bytes;
  c->st.budget_bytes = budget_bytes;
  c->e = calloc(c->n ? c->n : 1, sizeof *c->e);
  if (!c->e) { free(c); return mgs_error_set(err, MGS_ERR_NOMEM, "image cache: out of memory"); }
  pthread_mutex_init(&c->mu, NULL);
  pthread_cond_init(&c->cv, NULL);
  if (prefetch_thread) {
    if (pthread_create(&c->thread, NULL, prefetch_main, c) != 0) {
      mgs_image_cache_destroy(c);
      return mgs_error_set(err, MGS_ERR_IO, "image cache: cannot start the prefetch thread");
    }
    c->have_thread = 1;
  }
  *out = c;
  return MGS_OK;
}

void mgs_image_cache_destroy(mgs_image_cache *c) {
  if (!c) return;
  if (c->have_thread) {
    pthread_mutex_lock(&c->mu);
    c->stop = 1;
    pthread_cond_broadcast(&c->cv);
    pthread_mutex_unlock(&c->mu);
    pthread_join(c->thread, NULL);
  }
  for (size_t i = 0; i < c->n; i++) free(c->e[i].rgb);
  free(c->e);
  free(c->want);
  pthread_mutex_destroy(&c->mu);
  pthread_cond_destroy(&c->cv);
  free(c);
}

mgs_status mgs_image_cache_get(mgs_image_cache *c, size_t i, float *out, mgs_error *err) {
  if (i >= c->n) return mgs_error_set(err, MGS_ERR_ARG, "image cache: view %zu of %zu", i, c->n);
  pthread_mutex_lock(&c->mu);
  entry *e = &c->e[i];
  int waited = 0;
  while (e->state == ENTRY_LOADING) { waited = 1; pthread_cond_wait(&c->cv, &c->mu); }
  if (e->state == ENTRY_READY && !waited) c->st.hits++;
  else c->st.misses++;
  if (e->state == ENTRY_EMPTY) {
    e->state = ENTRY_LOADING;
    pthread_mutex_unlock(&c->mu);
    uint8_t *rgb = NULL;
    mgs_status st = decode(c, i, &rgb, err);
    pthread_mutex_lock(&c->mu);
    if (st != MGS_OK) {
      e->state = ENTRY_EMPTY;
      pthread_cond_broadcast(&c->cv);
      pthread_mutex_unlock(&c->mu);
      return st;
    }
    make_room(c, view_bytes(&c->ds->views[c->split][i]), i, UINT64_MAX);
    insert(c, i, rgb, 0);
    pthread_cond_broadcast(&c->cv);
  }
  e->last_use = ++c->tick; /* now the most recently used of the present */
  size_t m = e->bytes;
  const uint8_t *b = e->rgb;
  /* converting under the lock keeps the entry from being evicted meanwhile; it is a
     fraction of an iteration */
  const float s = 1.0f / 255.0f;
  for (size_t k = 0; k < m; k++) out[k] = (float)b[k] * s;
  /* an image used now leaves the prefetch list */
  for (size_t k = 0; k < c->n_want; k++)
    if (c->want[k] == i) { memmove(c->want + k, c->want + k + 1, (c->n_want - k - 1) * sizeof *c->want); c->n_want--; break; }
  pthread_mutex_unlock(&c->mu);
  return MGS_OK;
}

void mgs_image_cache_prefetch(mgs_image_cache *c, const uint32_t *views, size_t n) {
  pthread_mutex_lock(&c->mu);
  if (n > c->cap_want) {
    uint32_t *w = realloc(c->want, n * sizeof *w);
    if (!w) { pthread_mutex_unlock(&c->mu); return; } /* a hint: dropping it is harmless */
    c->want = w;
    c->cap_want = n;
  }
  size_t k = 0;
  for (size_t j = 0; j < n; j++)
    if (views[j] < c->n) c->want[k++] = views[j];
  c->n_want = k;
  c->want_gen++;
  /* entries stamped for a previous list fall back to the present (evictable) */
  for (size_t i = 0; i < c->n; i++)
    if (c->e[i].state == ENTRY_READY && c->e[i].last_use >= FUTURE) c->e[i].last_use = c->tick;
  for (size_t j = 0; j < k; j++)
    if (c->e[c->want[j]].state == ENTRY_READY) c->e[c->want[j]].last_use = FUTURE + (uint64_t)(k - j);
  pthread_cond_broadcast(&c->cv);
  pthread_mutex_unlock(&c->mu);
}

void mgs_image_cache_get_stats(mgs_image_cache *c, mgs_image_cache_stats *st) {
  pthread_mutex_lock(&c->mu);
  *st = c->st;
  st->resident_bytes = c->resident;
  pthread_mutex_unlock(&c->mu);
}
