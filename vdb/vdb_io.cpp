// .vdb files: several grids + file metadata (tool, version, τ, voxel size, source),
// written atomically (temp file beside the target + rename); reading with one-line errors
// for a missing file, a non-.vdb file, a missing grid and a non-float grid.
#include <openvdb/io/File.h>
#include <sys/stat.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include "core/mgs_fs.h"
#include "vdb/vdb_internal.hpp"

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

namespace {
mgs_status open_file(const char *path, io::File &f, mgs_error *err) {
  struct stat st;
  if (stat(path, &st) != 0) return mgs_error_set(err, MGS_ERR_IO, "%s: no such file", path);
  if (S_ISDIR(st.st_mode)) return mgs_error_set(err, MGS_ERR_IO, "%s: is a directory, not a .vdb file", path);
  try {
    f.open(false);  // read everything now: leaf views need in-core buffers
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not a readable .vdb file (%s)", path, e.what());
  }
  return MGS_OK;
}
}  // namespace

extern "C" mgs_status mgs_vdb_read_grid(const char *path, const char *name, mgs_vdb_grid **out, mgs_error *err) {
  *out = nullptr;
  mgs_vdb_detail::init();
  io::File f(path);
  mgs_status st = open_file(path, f, err);
  if (st != MGS_OK) return st;
  try {
    std::string chosen, names;
    auto metas = f.readAllGridMetadata();
    for (auto &g : *metas) {
      names += (names.empty() ? "" : ", ") + g->getName() + " (" + g->valueType() + ")";
    }
    if (name) {
      if (!f.hasGrid(name)) {
        f.close();
        return mgs_error_set(err, MGS_ERR_FORMAT, "%s: no grid named '%s' (grids: %s)", path, name,
                             names.empty() ? "none" : names.c_str());
      }
      chosen = name;
    } else {
      for (auto &g : *metas)
        if (g->isType<FloatGrid>() && g->getGridClass() == GRID_LEVEL_SET) { chosen = g->getName(); break; }
      if (chosen.empty())
        for (auto &g : *metas)
          if (g->isType<FloatGrid>()) { chosen = g->getName(); break; }
      if (chosen.empty()) {
        f.close();
        return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: no float grid in the file (grids: %s)", path,
                             names.empty() ? "none" : names.c_str());
      }
    }
    GridBase::Ptr base = f.readGrid(chosen);
    f.close();
    FloatGrid::Ptr g = gridPtrCast<FloatGrid>(base);
    if (!g)
      return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: grid '%s' holds %s values, not float (a scalar float grid is needed)",
                           path, chosen.c_str(), base->valueType().c_str());
    if (!g->transform().isLinear() || !g->hasUniformVoxels())
      return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "%s: grid '%s' has a non-uniform or non-linear transform", path,
                           chosen.c_str());
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: cannot read grid: %s", path, e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory", path);
}

extern "C" mgs_status mgs_vdb_read_meta(const char *path, mgs_vdb_file_meta *meta, mgs_error *err) {
  mgs_vdb_file_meta_default(meta);
  meta->tool[0] = meta->version[0] = 0;
  mgs_vdb_detail::init();
  io::File f(path);
  mgs_status st = open_file(path, f, err);
  if (st != MGS_OK) return st;
  try {
    MetaMap::Ptr mm = f.getMetadata();
    f.close();
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
