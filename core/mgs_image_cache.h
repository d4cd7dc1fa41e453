/* Training images streamed from disk (core/image_cache.c): each view's image is decoded
 * on demand (mgs_dataset_load_image: compositing, downscaling), kept as 8-bit RGB (a
 * quarter of the float image) in a cache with a byte budget, least recently used first
 * out, and handed out as floats one view at a time. A background thread decodes the
 * views the caller says come next (mgs_image_cache_prefetch), so decoding overlaps
 * training. Resident memory is then the budget, not the dataset.
 *
 * Difference from keeping float images: the loss sees each pixel rounded to 1/255
 * (exact for 8-bit sources without alpha and downscaling; within 1/510 otherwise).
 * A budget below one image still works (one image resident at a time). */
#ifndef MGS_IMAGE_CACHE_H
#define MGS_IMAGE_CACHE_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_dataset.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_image_cache mgs_image_cache;

/* A cache over the views of one split of ds (borrowed; its views' images must not be
 * loaded by others meanwhile). prefetch_thread: 1 starts the decoding thread. */
mgs_status mgs_image_cache_create(mgs_dataset *ds, mgs_split split, size_t budget_bytes, int prefetch_thread,
                                  mgs_image_cache **out, mgs_error *err);
void mgs_image_cache_destroy(mgs_image_cache *c);

/* View i's RGB image as floats in [0,1] into out (width*height*3 of its camera). Errors
 * name the image file (missing, unreadable, wrong size). */
mgs_status mgs_image_cache_get(mgs_image_cache *c, size_t i, float *out, mgs_error *err);
/* The views wanted next, in order (replaces the previous list); the thread decodes those
 * not resident, as far as the budget allows without evicting earlier ones. */
void mgs_image_cache_prefetch(mgs_image_cache *c, const uint32_t *views, size_t n);

typedef struct mgs_image_cache_stats {
  size_t hits;          /* get found the image resident */
  size_t misses;        /* get had to decode it (or wait for the thread) */
  size_t decodes;       /* images decoded, by get or by the thread */
  size_t evictions;
  size_t resident_bytes, peak_bytes, budget_bytes;
} mgs_image_cache_stats;
void mgs_image_cache_get_stats(mgs_image_cache *c, mgs_image_cache_stats *st);

#ifdef __cplusplus
}
#endif
#endif
