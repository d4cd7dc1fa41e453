// Private to vdb/*.cpp (C++ only, never included from C): the handle behind mgs_vdb_grid.
#ifndef MGS_VDB_INTERNAL_HPP
#define MGS_VDB_INTERNAL_HPP
#include <openvdb/openvdb.h>
#include <openvdb/points/PointDataGrid.h>
#include <string>
#include "vdb/mgs_vdb.h"

struct mgs_vdb_grid {
  openvdb::FloatGrid::Ptr grid;
  std::string name;  // cached for the C accessor's lifetime
};

struct mgs_vdb_points {
  openvdb::points::PointDataGrid::Ptr grid;
  size_t count = 0;
};

namespace mgs_vdb_detail {
// openvdb::initialize() once per process (grid types, metadata, point attributes).
void init();
mgs_vdb_grid *wrap(openvdb::FloatGrid::Ptr g);
openvdb::math::Transform::Ptr make_transform(double voxel_size, const double t[3]);
// Runs f(b, e) over [begin, end) through mgs_parallel_for.
template <class F> void parallel_for(size_t begin, size_t end, size_t grain, const F &f);
}  // namespace mgs_vdb_detail

#include "core/mgs_parallel.h"
template <class F>
void mgs_vdb_detail::parallel_for(size_t begin, size_t end, size_t grain, const F &f) {
  struct Ctx { const F *f; } ctx{&f};
  mgs_parallel_for(begin, end, grain,
                   [](void *c, size_t b, size_t e) { (*static_cast<Ctx *>(c)->f)(b, e); }, &ctx);
}
#endif
