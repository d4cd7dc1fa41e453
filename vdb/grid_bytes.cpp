// A FloatGrid as bytes and back (mgs_vdb_grid_to_bytes / _from_bytes): checkpoints keep the
// grids their terms read between analyses. OpenVDB's stream format, in memory; bytes that
// are a whole .vdb file (what checkpoints held before) are read through a temporary file.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <unistd.h>
#include <openvdb/io/Stream.h>
#include "vdb/vdb_internal.hpp"
#include "core/mgs_fs.h"

extern "C" mgs_status mgs_vdb_grid_to_bytes(const mgs_vdb_grid *g, char **bytes, size_t *len, mgs_error *err) {
  *bytes = nullptr;
  *len = 0;
  try {
    mgs_vdb_detail::init();
    std::ostringstream os(std::ios_base::binary);
    openvdb::GridPtrVec grids{g->grid};
    openvdb::io::Stream(os).write(grids);
    const std::string s = os.str();
    char *b = static_cast<char *>(malloc(s.size() ? s.size() : 1));
    if (!b) return mgs_error_set(err, MGS_ERR_NOMEM, "vdb: out of memory (%zu bytes of grid)", s.size());
    memcpy(b, s.data(), s.size());
    *bytes = b;
    *len = s.size();
    return MGS_OK;
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_IO, "vdb: cannot serialize grid '%s': %s", g->grid->getName().c_str(), e.what());
  }
}

static mgs_status from_file_bytes(const char *bytes, size_t len, const char *name, mgs_vdb_grid **out, mgs_error *err) {
  const char *dir = getenv("TMPDIR");
  char path[4096];
  snprintf(path, sizeof path, "%s/mgs_grid_XXXXXX", dir && *dir ? dir : "/tmp");
  int fd = mkstemp(path);
  if (fd < 0) return mgs_error_set(err, MGS_ERR_IO, "vdb: cannot create a temporary file for a grid");
  close(fd);
  mgs_status st = mgs_write_file_atomic(path, bytes, len, err);
  if (st == MGS_OK) st = mgs_vdb_read_grid(path, name, out, err);
  remove(path);
  return st;
}

extern "C" mgs_status mgs_vdb_grid_from_bytes(const char *bytes, size_t len, const char *name, mgs_vdb_grid **out,
                                             mgs_error *err) {
  *out = nullptr;
  try {
    mgs_vdb_detail::init();
    std::istringstream is(std::string(bytes, len), std::ios_base::binary);
    openvdb::io::Stream strm(is);
    openvdb::GridPtrVecPtr grids = strm.getGrids();
    for (const auto &base : *grids) {
      auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
      if (fg && (!name || fg->getName() == name)) {
        *out = mgs_vdb_detail::wrap(fg);
        return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "vdb: out of memory");
      }
    }
    return mgs_error_set(err, MGS_ERR_FORMAT, "vdb: no float grid%s%s in the serialized bytes", name ? " named " : "",
                         name ? name : "");
  } catch (const std::exception &) {
    return from_file_bytes(bytes, len, name, out, err); /* a whole .vdb file */
  }
}
