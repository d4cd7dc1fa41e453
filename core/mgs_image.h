/* Float images (values as stored, 0..1 for 8-bit files; no colour-space conversion, as
 * the reference 3DGS trains on the stored sRGB values) and their I/O through OpenImageIO
 * (PNG, JPEG, EXR, anything OIIO reads). Pixels are interleaved, row-major, top row
 * first: data[(y*width + x)*channels + c]. */
#ifndef MGS_IMAGE_H
#define MGS_IMAGE_H
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_image {
  int width, height, channels;
  float *data;
} mgs_image;

mgs_image *mgs_image_create(int width, int height, int channels); /* zero-filled */
void mgs_image_destroy(mgs_image *img);
mgs_image *mgs_image_clone(const mgs_image *img);

/* Reads any format OIIO knows. Errors name the file. */
mgs_status mgs_image_read(const char *path, mgs_image **out, mgs_error *err);
/* Reads only the header: size and channel count. Errors name the file. */
mgs_status mgs_image_read_size(const char *path, int *width, int *height, int *channels, mgs_error *err);
/* Writes by extension (.png/.jpg: 8-bit, clamped and rounded; .exr/.tif/.hdr: 32-bit
 * float, exact). Alpha (4th channel) is straight, never premultiplied, on read and write,
 * as PIL gives the reference. Atomic: writes a temporary file beside `path` (keeping its
 * extension) and renames it; thread-safe. */
mgs_status mgs_image_write(const char *path, const mgs_image *img, mgs_error *err);
/* The same with 16 bits per channel for formats that have them (.png: values in [0,1]
 * scaled to 0..65535, clamped and rounded); float formats as mgs_image_write. */
mgs_status mgs_image_write_u16(const char *path, const mgs_image *img, mgs_error *err);

/* RGBA -> RGB composited over background bg (straight alpha). */
mgs_image *mgs_image_composite(const mgs_image *rgba, const float bg[3]);
/* Box-filter downscale by an integer factor (area average). */
mgs_image *mgs_image_downscale(const mgs_image *img, int factor);
/* Resize to w x h as PIL's Image.resize(..., BICUBIC) does (what the reference 3DGS uses
 * for every training image): Keys cubic with a = -0.5, the kernel widened by the scale
 * when shrinking (antialiased), the full image extent mapped onto the new one, values
 * clamped to [0, 1] as PIL's 8-bit output is. NULL if w or h < 1 or out of memory. */
mgs_image *mgs_image_resize_bicubic(const mgs_image *img, int w, int h);

#ifdef __cplusplus
}
#endif
#endif
