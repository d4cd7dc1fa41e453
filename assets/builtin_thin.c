/* Builtin "thin": thin structures and floaters. A base plate with four thin rods holding
 * a thin top plate, a thin vertical fin, a diagonal wire, a wire ring standing on the
 * top plate, and five small balls floating free (the disconnected, floater-like parts a
 * reconstruction should keep but a densifier tends to lose or invent). Each primitive
 * is its own closed part; parts that meet only touch or overlap in space. */
#include "assets/assets_internal.h"

mgs_status mgs_builtin_thin(int detail, mgs_mesh **out, mgs_error *err) {
  mgs_mesh_builder b = {0};
  int seg = 12 * detail, rings = 8 * detail;
  double base_lo[3] = {-0.8, -0.6, -0.9}, base_hi[3] = {0.8, 0.6, -0.84};
  mgs_mb_box(&b, base_lo, base_hi);
  const double top_z = 0.5;
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sy = -1; sy <= 1; sy += 2) {
      double a[3] = {0.6 * sx, 0.4 * sy, -0.84}, c[3] = {0.6 * sx, 0.4 * sy, top_z};
      mgs_mb_cylinder(&b, a, c, 0.025, seg);
    }
  double top_lo[3] = {-0.7, -0.5, top_z}, top_hi[3] = {0.7, 0.5, top_z + 0.015};
  mgs_mb_box(&b, top_lo, top_hi);
  double fin_lo[3] = {-0.006, -0.3, -0.84}, fin_hi[3] = {0.006, 0.3, -0.25};
  mgs_mb_box(&b, fin_lo, fin_hi);
  double w0[3] = {-0.55, 0.35, -0.84}, w1[3] = {0.55, -0.35, top_z};
  mgs_mb_cylinder(&b, w0, w1, 0.012, seg);
  double ring_c[3] = {0.0, 0.0, top_z + 0.015 + 0.3}, ring_axis[3] = {0, 1, 0};
  mgs_mb_torus(&b, ring_c, ring_axis, 0.3, 0.015, 48 * detail, seg);
  static const double balls[5][4] = {
      {0.30, -0.20, -0.35, 0.035}, {-0.40, 0.22, 0.05, 0.03}, {0.15, 0.38, -0.60, 0.025},
      {-0.25, -0.32, 0.30, 0.04}, {0.72, 0.55, 0.85, 0.03}};
  for (int i = 0; i < 5; i++) mgs_mb_sphere(&b, balls[i], balls[i][3], rings, 2 * rings);
  return mgs_mb_finish(&b, "thin", out, err);
}
