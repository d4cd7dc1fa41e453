/* Shading of the ground-truth renders: a diffuse albedo (the mesh's own texture or vertex
 * colours, else a procedural 3D texture: value-noise fBm plus soft stripes, so photometric
 * fitting has detail to learn), lit
 * by a headlight and a fixed directional light, with an optional Blinn-Phong highlight
 * (a view-dependent term, so the SH degree of a fit matters). No shadows: every lit
 * quantity is local, which keeps the renders cheap and exactly reproducible. */
#include <math.h>
#include "render/mgs_scene.h"
#include "render/scene_internal.h"

uint32_t mgs_scene_hash4(uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
  uint32_t h = 0x9e3779b9u;
  uint32_t v[4] = {a, b, c, d};
  for (int i = 0; i < 4; i++) {
    h ^= v[i] + 0x7f4a7c15u + (h << 6) + (h >> 2);
    h ^= h >> 16; h *= 0x85ebca6bu; h ^= h >> 13; h *= 0xc2b2ae35u; h ^= h >> 16;
  }
  return h;
}

/* Lattice values: one multiply-xorshift round is plenty for texture (and is the hot
   spot of shading, 32 lookups per sample). */
static float lattice(int x, int y, int z) {
  uint32_t h = (uint32_t)x * 0x8da6b343u ^ (uint32_t)y * 0xd8163841u ^ (uint32_t)z * 0xcb1ab31fu;
  h ^= h >> 15; h *= 0x2c1b3c6du; h ^= h >> 12; h *= 0x297a2d39u; h ^= h >> 15;
  return (float)(h >> 8) * (1.0f / 16777216.0f);
}

static float smooth(float t) { return t * t * (3.0f - 2.0f * t); }

/* Trilinear value noise in [0, 1). */
static float value_noise(float x, float y, float z) {
  float fx = floorf(x), fy = floorf(y), fz = floorf(z);
  int ix = (int)fx, iy = (int)fy, iz = (int)fz;
  float tx = smooth(x - fx), ty = smooth(y - fy), tz = smooth(z - fz);
  float c[2][2][2];
  for (int a = 0; a < 2; a++)
    for (int b = 0; b < 2; b++)
      for (int d = 0; d < 2; d++) c[a][b][d] = lattice(ix + a, iy + b, iz + d);
  float x00 = c[0][0][0] + (c[1][0][0] - c[0][0][0]) * tx, x10 = c[0][1][0] + (c[1][1][0] - c[0][1][0]) * tx;
  float x01 = c[0][0][1] + (c[1][0][1] - c[0][0][1]) * tx, x11 = c[0][1][1] + (c[1][1][1] - c[0][1][1]) * tx;
  float y0 = x00 + (x10 - x00) * ty, y1 = x01 + (x11 - x01) * ty;
  return y0 + (y1 - y0) * tz;
}

void mgs_scene_albedo(const float p[3], float rgb[3]) {
  /* Offsets keep the lattice away from the symmetric origin of normalized meshes. */
  float x = p[0] * 4.5f + 17.3f, y = p[1] * 4.5f + 5.1f, z = p[2] * 4.5f + 9.7f;
  float n = 0.0f, amp = 0.5f, f = 1.0f;
  for (int o = 0; o < 3; o++) { n += amp * value_noise(x * f, y * f, z * f); amp *= 0.5f; f *= 2.0f; }
  n /= 0.875f; /* in [0, 1) */
  float hue = value_noise(x * 0.3f + 3.0f, y * 0.3f, z * 0.3f);
  hue = hue < 0.3f ? 0.0f : (hue > 0.7f ? 1.0f : (hue - 0.3f) * 2.5f); /* patches of each colour */
  float stripe = 0.5f + 0.5f * sinf(18.0f * (p[0] + 0.6f * p[1] - 0.3f * p[2]) + 5.0f * n);
  static const float warm[3] = {0.90f, 0.42f, 0.15f}, cool[3] = {0.15f, 0.50f, 0.85f}, light[3] = {0.95f, 0.92f, 0.80f};
  for (int c = 0; c < 3; c++) {
    float base = warm[c] + (cool[c] - warm[c]) * hue;
    float v = base + (light[c] - base) * n * 0.6f;
    v *= 0.55f + 0.45f * stripe;
    rgb[c] = v < 0.05f ? 0.05f : (v > 0.95f ? 0.95f : v);
  }
}

void mgs_scene_look_albedo(const mgs_scene_look *look, size_t tri, float b1, float b2, const float p[3], float rgb[3]) {
  const float b0 = 1.0f - b1 - b2;
  if (look->tex && look->uv) {
    const float *uv = look->uv + 6 * tri;
    if (uv[0] == uv[0] && uv[2] == uv[2] && uv[4] == uv[4]) { /* not NaN */
      mgs_texture_sample(look->tex, b0 * uv[0] + b1 * uv[2] + b2 * uv[4], b0 * uv[1] + b1 * uv[3] + b2 * uv[5], rgb);
      return;
    }
  }
  if (look->rgb) {
    const float *c = look->rgb + 9 * tri;
    if (c[0] == c[0] && c[3] == c[3] && c[6] == c[6]) {
      for (int k = 0; k < 3; k++) rgb[k] = b0 * c[k] + b1 * c[3 + k] + b2 * c[6 + k];
      return;
    }
  }
  const float ts = look->texture_scale > 0 ? look->texture_scale : 1.0f, pt[3] = {p[0] * ts, p[1] * ts, p[2] * ts};
  mgs_scene_albedo(pt, rgb);
}

void mgs_scene_shade(const float p[3], const float n[3], const float v[3], int specular, float rgb[3]) {
  float albedo[3];
  mgs_scene_albedo(p, albedo);
  mgs_scene_shade_albedo(albedo, n, v, specular, rgb);
}

void mgs_scene_shade_albedo(const float albedo[3], const float n[3], const float v[3], int specular, float rgb[3]) {
  static const float sun[3] = {0.40f, 0.30f, 0.866f}; /* unit, from the upper right */
  const float ambient = 0.18f, k_head = 0.50f, k_sun = 0.55f, k_spec = 0.45f, shininess = 48.0f;
  float ndv = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
  float ndl = n[0] * sun[0] + n[1] * sun[1] + n[2] * sun[2];
  float diffuse = ambient + k_head * (ndv > 0 ? ndv : 0) + k_sun * (ndl > 0 ? ndl : 0);
  float spec = 0.0f;
  if (specular) {
    /* Headlight: half vector = v. Sun: half vector between v and sun. */
    if (ndv > 0) spec += 0.5f * powf(ndv, shininess);
    float h[3] = {v[0] + sun[0], v[1] + sun[1], v[2] + sun[2]};
    float hl = sqrtf(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    if (hl > 0 && ndl > 0) {
      float ndh = (n[0] * h[0] + n[1] * h[1] + n[2] * h[2]) / hl;
      if (ndh > 0) spec += powf(ndh, shininess);
    }
    spec *= k_spec;
  }
  for (int c = 0; c < 3; c++) {
    float val = albedo[c] * diffuse + spec;
    rgb[c] = val > 1.0f ? 1.0f : val;
  }
}
