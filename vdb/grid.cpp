// The mgs_vdb_grid handle: creation, accessors, small edits, grids from dense blocks.
#include <openvdb/tools/Prune.h>
#include <cmath>
#include <cstring>
#include <mutex>
#include "vdb/vdb_internal.hpp"

using namespace openvdb;

void mgs_vdb_detail::init() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

mgs_vdb_grid *mgs_vdb_detail::wrap(FloatGrid::Ptr g) {
  if (!g) return nullptr;
  auto *h = new (std::nothrow) mgs_vdb_grid;
  if (h) h->grid = g;
  return h;
}

math::Transform::Ptr mgs_vdb_detail::make_transform(double h, const double t[3]) {
  auto xf = math::Transform::createLinearTransform(h);
  if (t) xf->postTranslate(Vec3d(t[0], t[1], t[2]));
  return xf;
}

static void set_class(FloatGrid &g, mgs_vdb_class cls) {
  g.setGridClass(cls == MGS_VDB_CLASS_LEVEL_SET ? GRID_LEVEL_SET
                 : cls == MGS_VDB_CLASS_FOG     ? GRID_FOG_VOLUME
                                                : GRID_UNKNOWN);
}

extern "C" mgs_status mgs_vdb_grid_create(const char *name, mgs_vdb_class cls, double voxel_size,
                                          const double translation[3], float background,
                                          mgs_vdb_grid **out, mgs_error *err) {
  *out = nullptr;
  if (!(voxel_size > 0) || !std::isfinite(voxel_size) || !std::isfinite(background))
    return mgs_error_set(err, MGS_ERR_ARG, "vdb grid: voxel size %g / background %g invalid",
                         voxel_size, (double)background);
  mgs_vdb_detail::init();
  try {
    auto g = FloatGrid::create(background);
    g->setTransform(mgs_vdb_detail::make_transform(voxel_size, translation));
    g->setName(name ? name : "");
    set_class(*g, cls);
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "vdb grid: %s", e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "vdb grid: out of memory");
}

extern "C" void mgs_vdb_grid_destroy(mgs_vdb_grid *g) { delete g; }

extern "C" mgs_vdb_grid *mgs_vdb_grid_copy(const mgs_vdb_grid *g) {
  try {
    return mgs_vdb_detail::wrap(g->grid->deepCopy());
  } catch (...) {
    return nullptr;
  }
}

extern "C" const char *mgs_vdb_grid_name(const mgs_vdb_grid *g) {
  auto *h = const_cast<mgs_vdb_grid *>(g);
  h->name = g->grid->getName();
  return h->name.c_str();
}
extern "C" void mgs_vdb_grid_set_name(mgs_vdb_grid *g, const char *name) { g->grid->setName(name ? name : ""); }

extern "C" mgs_vdb_class mgs_vdb_grid_class(const mgs_vdb_grid *g) {
  switch (g->grid->getGridClass()) {
    case GRID_LEVEL_SET: return MGS_VDB_CLASS_LEVEL_SET;
    case GRID_FOG_VOLUME: return MGS_VDB_CLASS_FOG;
    default: return MGS_VDB_CLASS_UNKNOWN;
  }
}
extern "C" void mgs_vdb_grid_set_class(mgs_vdb_grid *g, mgs_vdb_class cls) { set_class(*g->grid, cls); }
extern "C" double mgs_vdb_grid_voxel_size(const mgs_vdb_grid *g) { return g->grid->voxelSize()[0]; }
extern "C" void mgs_vdb_grid_translation(const mgs_vdb_grid *g, double t[3]) {
  Vec3d o = g->grid->transform().indexToWorld(Vec3d(0.0));
  t[0] = o[0]; t[1] = o[1]; t[2] = o[2];
}
extern "C" void mgs_vdb_grid_translate(mgs_vdb_grid *g, const double offset[3]) {
  if (!offset || (offset[0] == 0 && offset[1] == 0 && offset[2] == 0)) return;
  // a copy: grids made from one another may share their transform
  auto xf = g->grid->transform().copy();
  xf->postTranslate(Vec3d(offset[0], offset[1], offset[2]));
  g->grid->setTransform(xf);
}
extern "C" float mgs_vdb_grid_background(const mgs_vdb_grid *g) { return g->grid->background(); }
extern "C" size_t mgs_vdb_grid_active_voxel_count(const mgs_vdb_grid *g) { return (size_t)g->grid->activeVoxelCount(); }
extern "C" size_t mgs_vdb_grid_leaf_count(const mgs_vdb_grid *g) { return (size_t)g->grid->tree().leafCount(); }
extern "C" size_t mgs_vdb_grid_memory_bytes(const mgs_vdb_grid *g) { return (size_t)g->grid->memUsage(); }

extern "C" int mgs_vdb_grid_active_bbox(const mgs_vdb_grid *g, int32_t lo[3], int32_t hi[3]) {
  CoordBBox bb;
  if (!g->grid->tree().evalActiveVoxelBoundingBox(bb)) return 0;
  for (int a = 0; a < 3; a++) { lo[a] = bb.min()[a]; hi[a] = bb.max()[a]; }
  return 1;
}

extern "C" void mgs_vdb_set_value(mgs_vdb_grid *g, const int32_t ijk[3], float value, int active) {
  auto acc = g->grid->getAccessor();
  Coord c(ijk[0], ijk[1], ijk[2]);
  if (active) acc.setValueOn(c, value);
  else acc.setValueOff(c, value);
}

extern "C" mgs_status mgs_vdb_grid_from_dense(const char *name, mgs_vdb_class cls, double voxel_size,
                                              const double translation[3], float background,
                                              const int32_t origin[3], const int32_t dims[3],
                                              const float *values, mgs_vdb_grid **out, mgs_error *err) {
  *out = nullptr;
  if (dims[0] < 0 || dims[1] < 0 || dims[2] < 0)
    return mgs_error_set(err, MGS_ERR_ARG, "vdb grid from dense: negative dimensions");
  mgs_vdb_grid *h = nullptr;
  mgs_status st = mgs_vdb_grid_create(name, cls, voxel_size, translation, background, &h, err);
  if (st != MGS_OK) return st;
  try {
    auto acc = h->grid->getAccessor();
    const float bg = std::fabs(background);
    for (int32_t i = 0; i < dims[0]; i++)
      for (int32_t j = 0; j < dims[1]; j++)
        for (int32_t k = 0; k < dims[2]; k++) {
          const float v = values[((size_t)i * dims[1] + j) * dims[2] + k];
          Coord c(origin[0] + i, origin[1] + j, origin[2] + k);
          if (cls == MGS_VDB_CLASS_LEVEL_SET) {
            if (std::fabs(v) < bg) acc.setValueOn(c, v);
            else if (v < 0) acc.setValueOff(c, -bg);
            // outside: background already
          } else if (cls == MGS_VDB_CLASS_FOG) {
            if (v > 0) acc.setValueOn(c, v);
          } else if (v != background) {
            acc.setValueOn(c, v);
          }
        }
    if (cls == MGS_VDB_CLASS_LEVEL_SET) tools::pruneLevelSet(h->grid->tree());
    else tools::prune(h->grid->tree());
  } catch (const std::exception &e) {
    mgs_vdb_grid_destroy(h);
    return mgs_error_set(err, MGS_ERR_NOMEM, "vdb grid from dense: %s", e.what());
  }
  *out = h;
  return MGS_OK;
}
