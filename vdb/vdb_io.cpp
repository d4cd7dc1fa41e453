// .vdb files: several grids + file metadata (tool, version, τ, voxel size, source),
// written atomically (temp file beside the target + rename); reading (validated first, see
// vdb_read.hpp) with one-line errors for a missing, truncated or corrupt file, a missing
// grid, a non-float grid and an unusable transform.
#include <openvdb/io/File.h>
#include <sys/stat.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include "core/mgs_fs.h"
#include "vdb/vdb_internal.hpp"
#include "vdb/vdb_read.hpp"

using namespace openvdb;

extern "C" void mgs_vdb_file_meta_default(mgs_vdb_file_meta *m) {
  std::memset(m, 0, sizeof *m);
  std::snprintf(m->tool, sizeof m->tool, "morsegs");
  std::snprintf(m->version, sizeof m->version, "0.1.0");
  m->tau = NAN;
  m->voxel_size = NAN;
}

extern "C" mgs_status mgs_vdb_write(const char *path, const mgs_vdb_grid *const *grids, size_t ngrids,
                                    const mgs_vdb_points *const *points, size_t npoints,
                                    const mgs_vdb_file_meta *meta, mgs_error *err) {
  mgs_vdb_detail::init();
  char *tmp = mgs_temp_path_for(path);
  if (!tmp) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
  try {
    GridCPtrVec vec;
    for (size_t i = 0; i < ngrids; i++) vec.push_back(grids[i]->grid);
    for (size_t i = 0; i < npoints; i++) vec.push_back(points[i]->grid);
    MetaMap mm;
    mgs_vdb_file_meta m;
    if (meta) m = *meta; else mgs_vdb_file_meta_default(&m);
    mm.insertMeta("tool", StringMetadata(m.tool));
    mm.insertMeta("version", StringMetadata(m.version));
    if (std::isfinite(m.tau)) mm.insertMeta("tau", DoubleMetadata(m.tau));
    if (std::isfinite(m.voxel_size)) mm.insertMeta("voxel_size", DoubleMetadata(m.voxel_size));
    if (m.source[0]) mm.insertMeta("source", StringMetadata(m.source));
    io::File f(tmp);
    f.write(vec, mm);
    f.close();
  } catch (const std::exception &e) {
    std::remove(tmp);
    std::free(tmp);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot write .vdb: %s", path, e.what());
  }
  if (std::rename(tmp, path) != 0) {
    int e = errno;
    std::remove(tmp);
    std::free(tmp);
    return mgs_error_set(err, MGS_ERR_IO, "%s: cannot rename the finished file into place: %s", path, std::strerror(e));
  }
  std::free(tmp);
  return MGS_OK;
}

extern "C" mgs_status mgs_vdb_read_grid(const char *path, const char *name, mgs_vdb_grid **out, mgs_error *err) {
  *out = nullptr;
  mgs_vdb_detail::vdb_index idx;
  mgs_status st = mgs_vdb_detail::check_vdb(path, &idx, err);
  if (st != MGS_OK) return st;
  const std::string float_type = FloatGrid::gridType();
  int which = -1;
  if (name) {
    for (size_t i = 0; i < idx.names.size() && which < 0; i++)
      if (idx.names[i] == name) which = (int)i;
    if (which < 0)
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: no grid named '%s' (grids: %s)", path, name, mgs_vdb_detail::grid_list(idx).c_str());
  } else {
    const std::string level_set = GridBase::gridClassToString(GRID_LEVEL_SET);
    for (size_t i = 0; i < idx.names.size() && which < 0; i++)
      if (idx.types[i] == float_type && idx.classes[i] == level_set) which = (int)i;
    for (size_t i = 0; i < idx.names.size() && which < 0; i++)
      if (idx.types[i] == float_type) which = (int)i;
    if (which < 0)
      return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: no float grid in the file (grids: %s)", path, mgs_vdb_detail::grid_list(idx).c_str());
  }
  const std::string &chosen = idx.names[(size_t)which];
  if (idx.types[(size_t)which] != float_type)  // refused before OpenVDB reads a tree of another type
    return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: grid '%s' holds %s values, not float (a scalar float grid is needed)",
                         path, chosen.c_str(), mgs_vdb_detail::value_type_of(idx.types[(size_t)which]).c_str());
  GridBase::Ptr base;
  if ((st = mgs_vdb_detail::load_vdb(idx, which, nullptr, &base, err)) != MGS_OK) return st;
  idx.bytes.clear();
  idx.bytes.shrink_to_fit();
  try {
    FloatGrid::Ptr g = gridPtrCast<FloatGrid>(base);
    if (!g)
      return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: grid '%s' holds %s values, not float (a scalar float grid is needed)",
                           path, chosen.c_str(), base->valueType().c_str());
    if (!g->transform().isLinear() || !g->hasUniformVoxels())
      return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: grid '%s' has a non-uniform or non-linear transform", path,
                           chosen.c_str());
    const Vec3d vs = g->voxelSize();
    const Vec3d t = g->transform().indexToWorld(Vec3d(0, 0, 0));
    if (!(vs[0] > 0) || !std::isfinite(vs[0]) || !std::isfinite(t[0]) || !std::isfinite(t[1]) || !std::isfinite(t[2]))
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: grid '%s' has voxel size %g and origin (%g, %g, %g): not a usable transform",
                           path, chosen.c_str(), vs[0], t[0], t[1], t[2]);
    if (!std::isfinite(g->background()))
      return mgs_error_set(err, MGS_ERR_FORMAT, "%s: grid '%s' has a non-finite background value", path, chosen.c_str());
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read grid: %s", path, e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
}

extern "C" mgs_status mgs_vdb_read_meta(const char *path, mgs_vdb_file_meta *meta, mgs_error *err) {
  mgs_vdb_file_meta_default(meta);
  meta->tool[0] = meta->version[0] = 0;
  mgs_vdb_detail::vdb_index idx;
  mgs_status st = mgs_vdb_detail::check_vdb(path, &idx, err);
  if (st != MGS_OK) return st;
  MetaMap::Ptr mm;
  if ((st = mgs_vdb_detail::load_vdb(idx, -1, &mm, nullptr, err)) != MGS_OK) return st;
  try {
    if (auto m = mm->getMetadata<StringMetadata>("tool")) std::snprintf(meta->tool, sizeof meta->tool, "%s", m->value().c_str());
    if (auto m = mm->getMetadata<StringMetadata>("version")) std::snprintf(meta->version, sizeof meta->version, "%s", m->value().c_str());
    if (auto m = mm->getMetadata<StringMetadata>("source")) std::snprintf(meta->source, sizeof meta->source, "%s", m->value().c_str());
    if (auto m = mm->getMetadata<DoubleMetadata>("tau")) meta->tau = m->value();
    if (auto m = mm->getMetadata<DoubleMetadata>("voxel_size")) meta->voxel_size = m->value();
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read metadata: %s", path, e.what());
  }
  return MGS_OK;
}
