// Surface extraction: {grid = iso} via OpenVDB volumeToMesh with adaptivity, quads split
// into triangles, orientation fixed by the sign of the enclosed volume (so level sets and
// fog volumes both come out counter-clockwise seen from outside).
#include <openvdb/tools/VolumeToMesh.h>
#include <cmath>
#include <vector>
#include "vdb/vdb_internal.hpp"

using namespace openvdb;

extern "C" mgs_status mgs_vdb_extract_mesh(const mgs_vdb_grid *g, double iso, double adaptivity, mgs_mesh **out,
                                           mgs_error *err) {
  *out = nullptr;
  if (!(adaptivity >= 0 && adaptivity <= 1))
    return mgs_error_set(err, MGS_ERR_ARG, "mesh extraction: adaptivity %g outside [0, 1]", adaptivity);
  if (!std::isfinite(iso)) return mgs_error_set(err, MGS_ERR_ARG, "mesh extraction: iso value not finite");
  std::vector<Vec3s> pts;
  std::vector<Vec3I> tris;
  std::vector<Vec4I> quads;
  // Meshed without the grid's translation (float vertices keep precision far from the
  // origin), which is added back in double below.
  const Vec3d shift = g->grid->transform().indexToWorld(Vec3d(0.0));
  try {
    FloatGrid::Ptr local = FloatGrid::create(std::const_pointer_cast<FloatTree>(g->grid->constTreePtr()));
    local->setTransform(math::Transform::createLinearTransform(g->grid->voxelSize()[0]));
    tools::volumeToMesh(*local, pts, tris, quads, iso, adaptivity, true);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "mesh extraction: %s", e.what());
  }
  if (pts.empty() || (tris.empty() && quads.empty()))
    return mgs_error_set(err, MGS_ERR_FORMAT, "mesh extraction: grid '%s' has no surface at iso value %g",
                         g->grid->getName().c_str(), iso);
  const size_t nt = tris.size() + 2 * quads.size();
  mgs_mesh *m = mgs_mesh_create(pts.size(), nt);
  if (!m) return mgs_error_set(err, MGS_ERR_NOMEM, "mesh extraction: out of memory for %zu triangles", nt);
  for (size_t i = 0; i < pts.size(); i++)
    for (int k = 0; k < 3; k++) m->v[3 * i + k] = (float)((double)pts[i][k] + shift[k]);
  size_t t = 0;
  for (const Vec3I &tr : tris) { m->t[3 * t] = tr[0]; m->t[3 * t + 1] = tr[1]; m->t[3 * t + 2] = tr[2]; t++; }
  for (const Vec4I &q : quads) {
    m->t[3 * t] = q[0]; m->t[3 * t + 1] = q[1]; m->t[3 * t + 2] = q[2]; t++;
    m->t[3 * t] = q[0]; m->t[3 * t + 1] = q[2]; m->t[3 * t + 2] = q[3]; t++;
  }
  // Signed volume (divergence theorem); flip if the mesh is inside out.
  double vol = 0;
  for (size_t i = 0; i < nt; i++) {
    const float *a = m->v + 3 * m->t[3 * i], *b = m->v + 3 * m->t[3 * i + 1], *c = m->v + 3 * m->t[3 * i + 2];
    vol += (double)a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) - (double)a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
           (double)a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0]);
  }
  if (vol < 0)
    for (size_t i = 0; i < nt; i++) { uint32_t tmp = m->t[3 * i + 1]; m->t[3 * i + 1] = m->t[3 * i + 2]; m->t[3 * i + 2] = tmp; }
  *out = m;
  return MGS_OK;
}
