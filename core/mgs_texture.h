/* Colour textures for shading: an RGB image read through OpenImageIO (mgs_image_read:
 * TGA, PNG, JPEG, anything OIIO reads), kept as stored (sRGB values, no conversion, as
 * the renders are stored), looked up bilinearly with wrap-around at texture coordinates
 * (u right, v up: v = 0 is the image's bottom row, the OpenGL/assimp convention).
 * Grey images are replicated to RGB; an alpha channel is ignored. Immutable once made,
 * so lookups from parallel loops need no locking. */
#ifndef MGS_TEXTURE_H
#define MGS_TEXTURE_H
#include "core/mgs_error.h"
#include "core/mgs_image.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_texture mgs_texture;

/* Errors name the file: missing (MGS_ERR_IO), unreadable or empty (MGS_ERR_FORMAT). */
mgs_status mgs_texture_read(const char *path, mgs_texture **out, mgs_error *err);
/* A texture from an image in memory (1 to 4 channels); NULL on bad input or no memory. */
mgs_texture *mgs_texture_from_image(const mgs_image *img);
void mgs_texture_destroy(mgs_texture *t);
int mgs_texture_width(const mgs_texture *t);
int mgs_texture_height(const mgs_texture *t);
/* Bilinear lookup with wrap (texel centres at (i + 0.5) / size); u, v finite. */
void mgs_texture_sample(const mgs_texture *t, float u, float v, float rgb[3]);

#ifdef __cplusplus
}
#endif
#endif
