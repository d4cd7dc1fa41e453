/* Private to render/scene_*.c: the shading model shared by the renderer and the
 * dataset writer. */
#ifndef MGS_SCENE_INTERNAL_H
#define MGS_SCENE_INTERNAL_H
#include <stdint.h>

/* Colour of a surface point: p position, n unit normal facing the viewer, v unit
 * direction from p towards the viewer. */
void mgs_scene_shade(const float p[3], const float n[3], const float v[3], int specular, float rgb[3]);
/* A well-mixed 32-bit hash of up to four integers (deterministic jitter). */
uint32_t mgs_scene_hash4(uint32_t a, uint32_t b, uint32_t c, uint32_t d);
#endif
