/* Builtin "city": a large scene to measure scale on. N x N blocks of 2 x 2 world units
 * on one ground slab (top at z = 0), each block holding four small copies of the other
 * builtins and a box tower (sphere, genus2, thin, tower: a different order and rotation
 * per block, so no two blocks look alike; the procedural texture of the renderer varies
 * with the world position, so each block also carries its own colours). The builtins
 * are polygonized once and instanced (copied with a transform), so N = 4 costs little
 * more than N = 1 to build. Unlike the other builtins the city is NOT normalized to
 * [-1,1]^3: its blocks keep their size whatever N, so a camera that sees one block sees
 * the same amount of content at every N. Streets (0.2 wide) run along the block edges
 * and through the block centres, free of objects, for street-level cameras. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "assets/assets_internal.h"
#include "assets/mgs_assets.h"
#include "core/mgs_math.h"

/* Object scale inside a block: the largest builtin (genus2, 2.6 wide) becomes 0.73 wide,
 * inside its 0.8 x 0.8 quadrant between the streets. */
#define CITY_OBJ_SCALE 0.28

static uint32_t mix32(uint32_t h) {
  h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15; h *= 0x846ca68bu; h ^= h >> 16;
  return h;
}

/* Appends m transformed: scaled by s, rotated by Rz(yaw) Rx(pitch), moved so its lowest
 * point sits at z = 0 above (cx, cy). */
static void instance(mgs_mesh_builder *b, const mgs_mesh *m, double s, double yaw, double pitch, double cx, double cy) {
  double cyw = cos(yaw), syw = sin(yaw), cp = cos(pitch), sp = sin(pitch);
  double zmin = INFINITY;
  for (size_t i = 0; i < m->nv; i++) {
    const float *p = m->v + 3 * i;
    double z = sp * p[1] + cp * p[2];
    if (z < zmin) zmin = z;
  }
  uint32_t base = (uint32_t)b->nv;
  for (size_t i = 0; i < m->nv; i++) {
    const float *p = m->v + 3 * i;
    double x = p[0], y = cp * p[1] - sp * p[2], z = sp * p[1] + cp * p[2] - zmin;
    mgs_mb_vertex(b, cx + s * (cyw * x - syw * y), cy + s * (syw * x + cyw * y), s * z);
  }
  for (size_t t = 0; t < m->nt; t++)
    mgs_mb_triangle(b, base + m->t[3 * t], base + m->t[3 * t + 1], base + m->t[3 * t + 2]);
}

mgs_status mgs_assets_city(int size, int detail, mgs_mesh **out, mgs_error *err) {
  *out = NULL;
  if (size < 1 || size > 64) return mgs_error_set(err, MGS_ERR_ARG, "builtin city: --size %d out of range (1..64)", size);
  if (detail < 1 || detail > 16) return mgs_error_set(err, MGS_ERR_ARG, "builtin city: detail %d out of range (1..16)", detail);
  mgs_mesh *parts[3] = {NULL, NULL, NULL};
  mgs_status s = mgs_builtin_sphere(detail, &parts[0], err);
  if (s == MGS_OK) s = mgs_builtin_genus2(detail, &parts[1], err);
  if (s == MGS_OK) s = mgs_builtin_thin(detail, &parts[2], err);
  if (s != MGS_OK) {
    for (int k = 0; k < 3; k++) mgs_mesh_destroy(parts[k]);
    return s;
  }
  mgs_mesh_builder b = {0};
  double half = size; /* blocks of 2 x 2: the city spans [-size, size]^2 */
  double g_lo[3] = {-half, -half, -0.1}, g_hi[3] = {half, half, 0.0};
  mgs_mb_box(&b, g_lo, g_hi);
  for (int by = 0; by < size; by++)
    for (int bx = 0; bx < size; bx++) {
      double cx = -half + 1.0 + 2.0 * bx, cy = -half + 1.0 + 2.0 * by;
      uint32_t h = mix32((uint32_t)(bx * 7919 + by * 104729 + 17));
      for (int q = 0; q < 4; q++) {
        double ox = cx + ((q & 1) ? 0.5 : -0.5), oy = cy + ((q & 2) ? 0.5 : -0.5);
        int kind = (int)((q + h) % 4);
        double yaw = 2.0 * MGS_PI * (double)(mix32(h + (uint32_t)q * 0x9e3779b9u) >> 8) / 16777216.0;
        if (kind == 3) { /* a tower: a box, height from the hash */
          double hgt = 0.3 + 0.4 * (double)((h >> (8 * q)) & 0xff) / 255.0, w = 0.14 + 0.06 * (double)(q & 1);
          double lo[3] = {ox - w, oy - w, 0.0}, hi[3] = {ox + w, oy + w, hgt};
          mgs_mb_box(&b, lo, hi);
        } else {
          /* genus2 stands up (pitched 90 degrees) so street cameras see its holes */
          instance(&b, parts[kind], CITY_OBJ_SCALE, yaw, kind == 1 ? 0.5 * MGS_PI : 0.0, ox, oy);
        }
      }
    }
  for (int k = 0; k < 3; k++) mgs_mesh_destroy(parts[k]);
  return mgs_mb_finish(&b, "city", out, err);
}
