// Critical points as an OpenVDB PointDataGrid named "critical" (SPEC §4): world positions
// plus attributes index (int32), birth, death, persistence (float). Houdini reads it as
// VDB points; python3-openvdb / vdb_print list it.
#include <openvdb/points/PointConversion.h>
#include <openvdb/io/File.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/tools/PointIndexGrid.h>
#include <cstdlib>
#include <cmath>
#include <vector>
#include "vdb/vdb_internal.hpp"
#include "vdb/vdb_read.hpp"

using namespace openvdb;

namespace {
template <class T>
void add_attribute(points::PointDataGrid &grid, const tools::PointIndexGrid &idx, const char *name,
                   const std::vector<T> &data) {
  points::appendAttribute<T>(grid.tree(), name);
  points::PointAttributeVector<T> wrap(data);
  points::populateAttribute(grid.tree(), idx.tree(), name, wrap);
}
}  // namespace

extern "C" mgs_status mgs_vdb_points_create_critical(size_t n, const float *xyz, const int32_t *index,
                                                     const float *birth, const float *death,
                                                     const float *persistence, double voxel_size,
                                                     mgs_vdb_points **out, mgs_error *err) {
  *out = nullptr;
  if (!(voxel_size > 0) || !std::isfinite(voxel_size))
    return mgs_error_set(err, MGS_ERR_ARG, "critical points: voxel size %g invalid", voxel_size);
  for (size_t i = 0; i < n; i++)
    for (int k = 0; k < 3; k++)
      if (!std::isfinite(xyz[3 * i + k]))
        return mgs_error_set(err, MGS_ERR_NUMERIC, "critical points: point %zu has a non-finite position", i);
  mgs_vdb_detail::init();
  try {
    std::vector<Vec3f> pos(n);
    for (size_t i = 0; i < n; i++) pos[i] = Vec3f(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    auto xf = math::Transform::createLinearTransform(voxel_size);
    points::PointAttributeVector<Vec3f> pwrap(pos);
    auto idx = tools::createPointIndexGrid<tools::PointIndexGrid>(pwrap, *xf);
    auto grid = points::createPointDataGrid<points::NullCodec, points::PointDataGrid>(*idx, pwrap, *xf);
    add_attribute(*grid, *idx, "index", std::vector<int32_t>(index, index + n));
    add_attribute(*grid, *idx, "birth", std::vector<float>(birth, birth + n));
    add_attribute(*grid, *idx, "death", std::vector<float>(death, death + n));
    add_attribute(*grid, *idx, "persistence", std::vector<float>(persistence, persistence + n));
    grid->setName("critical");
    auto *p = new mgs_vdb_points;
    p->grid = grid;
    p->count = n;
    *out = p;
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "critical points: %s", e.what());
  }
  return MGS_OK;
}

extern "C" void mgs_vdb_points_translate(mgs_vdb_points *p, const double offset[3]) {
  if (!p || !offset || (offset[0] == 0 && offset[1] == 0 && offset[2] == 0)) return;
  auto xf = p->grid->transform().copy();
  xf->postTranslate(Vec3d(offset[0], offset[1], offset[2]));
  p->grid->setTransform(xf);
}

extern "C" void mgs_vdb_points_destroy(mgs_vdb_points *p) { delete p; }
extern "C" size_t mgs_vdb_points_count(const mgs_vdb_points *p) { return p ? p->count : 0; }

extern "C" mgs_status mgs_vdb_read_critical(const char *path, const char *name, size_t *n, float **xyz,
                                            int32_t **index, float **birth, float **death, float **persistence,
                                            mgs_error *err) {
  *n = 0;
  *xyz = *birth = *death = *persistence = nullptr;
  *index = nullptr;
  const std::string gname = name ? name : "critical";
  mgs_vdb_detail::init();
  points::PointDataGrid::Ptr grid;
  {
    mgs_vdb_detail::vdb_index idx;
    mgs_status st = mgs_vdb_detail::check_vdb(path, &idx, err);
    if (st != MGS_OK) return st;
    int which = -1;
    for (size_t i = 0; i < idx.names.size() && which < 0; i++)
      if (idx.names[i] == gname) which = (int)i;
    if (which < 0) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: no grid named '%s'", path, gname.c_str());
    GridBase::Ptr base;
    if ((st = mgs_vdb_detail::load_vdb(idx, which, nullptr, &base, err)) != MGS_OK) return st;
    grid = gridPtrCast<points::PointDataGrid>(base);
  }
  if (!grid) return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: grid '%s' is not a point grid", path, gname.c_str());
  const Index64 count = points::pointCount(grid->tree());
  auto leaf0 = grid->tree().cbeginLeaf();
  if (count > 0 && leaf0) {
    const auto &desc = leaf0->attributeSet().descriptor();
    for (const char *attr : {"index", "birth", "death", "persistence"})
      if (desc.find(attr) == points::AttributeSet::INVALID_POS)
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: point grid '%s' has no attribute '%s'", path, gname.c_str(), attr);
  }
  float *P = (float *)std::malloc(3 * count * sizeof(float) + 1), *B = (float *)std::malloc(count * sizeof(float) + 1);
  float *D = (float *)std::malloc(count * sizeof(float) + 1), *Q = (float *)std::malloc(count * sizeof(float) + 1);
  int32_t *I = (int32_t *)std::malloc(count * sizeof(int32_t) + 1);
  if (!P || !B || !D || !Q || !I) {
    std::free(P); std::free(B); std::free(D); std::free(Q); std::free(I);
    return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory for %llu points", path, (unsigned long long)count);
  }
  size_t k = 0;
  try {
    for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
      points::AttributeHandle<Vec3f> ph(leaf->constAttributeArray("P"));
      points::AttributeHandle<int32_t> ih(leaf->constAttributeArray("index"));
      points::AttributeHandle<float> bh(leaf->constAttributeArray("birth")), dh(leaf->constAttributeArray("death")),
          qh(leaf->constAttributeArray("persistence"));
      for (auto vox = leaf->cbeginValueOn(); vox; ++vox) {
        const Vec3d ijk = vox.getCoord().asVec3d();
        for (auto it = leaf->beginIndexVoxel(vox.getCoord()); it; ++it) {
          if (k >= count) break;
          const Vec3d w = grid->transform().indexToWorld(ijk + Vec3d(ph.get(*it)));
          for (int a = 0; a < 3; a++) P[3 * k + a] = (float)w[a];
          I[k] = ih.get(*it);
          B[k] = bh.get(*it);
          D[k] = dh.get(*it);
          Q[k] = qh.get(*it);
          k++;
        }
      }
    }
  } catch (const std::exception &e) {
    std::free(P); std::free(B); std::free(D); std::free(Q); std::free(I);
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: point grid '%s': %s", path, gname.c_str(), e.what());
  }
  *n = k;
  *xyz = P; *index = I; *birth = B; *death = D; *persistence = Q;
  return MGS_OK;
}
