// Ground-truth SDF of a triangle mesh (vdb/mgs_vdb_mesh_sdf.h): OpenVDB's meshToLevelSet,
// the library made for the job (exact distances to the triangles in the band, sign by
// flood fill from outside).
#include "vdb/mgs_vdb_mesh_sdf.h"
#include <openvdb/tools/MeshToVolume.h>
#include <cmath>
#include <vector>
#include "vdb/vdb_internal.hpp"

using namespace openvdb;

extern "C" mgs_status mgs_vdb_sdf_from_mesh(const mgs_mesh *m, double h, int half_width, mgs_vdb_grid **out,
                                            mgs_error *err) {
  *out = nullptr;
  if (!(h > 0) || !std::isfinite(h)) return mgs_error_set(err, MGS_ERR_ARG, "mesh sdf: voxel size %g must be positive", h);
  if (half_width < 1 || half_width > 1000)
    return mgs_error_set(err, MGS_ERR_ARG, "mesh sdf: band half-width %d outside [1, 1000] voxels", half_width);
  if (!m || m->nv == 0 || m->nt == 0) return mgs_error_set(err, MGS_ERR_ARG, "mesh sdf: empty mesh");
  mgs_vdb_detail::init();
  try {
    auto xf = mgs_vdb_detail::make_transform(h, nullptr);
    std::vector<Vec3s> pts(m->nv);
    for (size_t i = 0; i < m->nv; i++) {
      pts[i] = Vec3s(m->v[3 * i], m->v[3 * i + 1], m->v[3 * i + 2]); // world space
    }
    std::vector<Vec3I> tris(m->nt);
    for (size_t i = 0; i < m->nt; i++) {
      if (m->t[3 * i] >= m->nv || m->t[3 * i + 1] >= m->nv || m->t[3 * i + 2] >= m->nv)
        return mgs_error_set(err, MGS_ERR_FORMAT, "mesh sdf: triangle %zu has a vertex index out of range", i);
      tris[i] = Vec3I(m->t[3 * i], m->t[3 * i + 1], m->t[3 * i + 2]);
    }
    std::vector<Vec4I> quads;
    auto g = tools::meshToLevelSet<FloatGrid>(*xf, pts, tris, quads, (float)half_width);
    g->setName("sdf");
    g->setGridClass(GRID_LEVEL_SET);
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "mesh sdf: %s", e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "mesh sdf: out of memory");
}
