/* Private to render/scene_*.c: the shading model shared by the renderer and the
 * dataset writer. */
#ifndef MGS_SCENE_INTERNAL_H
#define MGS_SCENE_INTERNAL_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_texture.h"

/* Where a surface point's albedo comes from (render/mgs_scene.h: the mesh's texture, else
   its colours, else the procedural texture), per triangle. */
typedef struct mgs_scene_look {
  const float *uv;          /* nt*6 per-corner UVs (NaN: none) or NULL; used with tex */
  const mgs_texture *tex;   /* the diffuse texture or NULL */
  const float *rgb;         /* nt*9 per-corner colours (NaN: none) or NULL */
  float texture_scale;      /* the procedural texture's (mgs_scene_options) */
} mgs_scene_look;

/* Albedo at barycentric (b1, b2) of triangle `tri` (corner weights 1-b1-b2, b1, b2) at
   world position p. */
void mgs_scene_look_albedo(const mgs_scene_look *look, size_t tri, float b1, float b2, const float p[3], float rgb[3]);
/* The shading of mgs_scene_shade with a given albedo. */
void mgs_scene_shade_albedo(const float albedo[3], const float n[3], const float v[3], int specular, float rgb[3]);

/* Colour of a surface point: p position, n unit normal facing the viewer, v unit
 * direction from p towards the viewer. */
void mgs_scene_shade(const float p[3], const float n[3], const float v[3], int specular, float rgb[3]);
/* A well-mixed 32-bit hash of up to four integers (deterministic jitter). */
uint32_t mgs_scene_hash4(uint32_t a, uint32_t b, uint32_t c, uint32_t d);
#endif
