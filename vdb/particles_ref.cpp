// OpenVDB's tools::ParticlesToLevelSet, wrapped for the side-by-side benchmark.
#include <openvdb/tools/ParticlesToLevelSet.h>
#include <cmath>
#include "vdb/vdb_internal.hpp"

using namespace openvdb;

namespace {
struct Particles {
  using PosType = Vec3R;
  using value_type = Vec3R;
  size_t n;
  const float *xyz, *radius;
  size_t size() const { return n; }
  void getPos(size_t i, Vec3R &p) const { p = Vec3R(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]); }
  void getPosRad(size_t i, Vec3R &p, Real &r) const {
    getPos(i, p);
    r = radius[i];
  }
};
}  // namespace

extern "C" mgs_status mgs_vdb_particles_to_level_set(size_t n, const float *xyz, const float *radius,
                                                     double voxel_size, int half_width, mgs_vdb_grid **out,
                                                     size_t *ignored, mgs_error *err) {
  *out = nullptr;
  if (!(voxel_size > 0) || half_width < 1)
    return mgs_error_set(err, MGS_ERR_ARG, "particles to level set: voxel size %g / band %d invalid", voxel_size, half_width);
  mgs_vdb_detail::init();
  try {
    auto g = createLevelSet<FloatGrid>(voxel_size, half_width);
    tools::ParticlesToLevelSet<FloatGrid> raster(*g);
    Particles p{n, xyz, radius};
    raster.rasterizeSpheres(p);
    raster.finalize(true);
    if (ignored) *ignored = raster.getMinCount() + raster.getMaxCount();
    g->setName("sdf");
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "particles to level set: %s", e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "particles to level set: out of memory");
}
