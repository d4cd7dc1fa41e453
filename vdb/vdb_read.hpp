// Internal to vdb/: the one path by which .vdb files are read (vdb_read.cpp).
//
// OpenVDB's reader trusts the sizes a file claims and keeps reading after its stream has
// failed: on a truncated file it loops over counts it never read (uninitialized, so one run
// stops at once and the next allocates 22 GB), and a string or metadata length is
// allocated and filled before the bytes behind it are read. This reader therefore
//   1. reads the whole file into memory and walks its header itself: magic, version,
//      file metadata, grid descriptors (names, types, the offsets of each grid, which must
//      lie inside the file in order), each grid's metadata and transform type, checking
//      every length and count against the bytes that are left before OpenVDB sees them;
//   2. hands the bytes of the wanted grid to io::Stream through a std::istream that throws
//      on any short read, so OpenVDB never works on values it did not read; every
//      allocation it makes is then backed by bytes it consumed (node counts need their
//      masks in the file): memory stays within ~40x the file size (a node's in-memory size
//      over its smallest on-disk form);
//   3. does step 2 in a forked child under RLIMIT_AS (VM at fork + 64x the file + 512 MB),
//      because OpenVDB 10 can still write out of bounds on such bytes (bloscFromStream
//      copies a raw chunk of the size the file claims before comparing it with the node's);
//      the child writes the grid back with OpenVDB's writer and the parent parses that.
//      A crash or the cap in the child is an error message, never the caller's crash.
// Errors are one line naming the file.
#ifndef MGS_VDB_READ_HPP
#define MGS_VDB_READ_HPP
#include <openvdb/openvdb.h>
#include <string>
#include <vector>
#include "core/mgs_error.h"

namespace mgs_vdb_detail {
// A checked file (step 1): its bytes and what its header says.
struct vdb_index {
  std::string path;
  std::vector<char> bytes;
  size_t count_pos = 0;                       // offset of the grid count
  std::vector<std::string> names, types, classes;  // per grid, file order ("class" metadata)
  std::vector<size_t> begin, end;             // each grid's descriptor start and end offset
};
mgs_status check_vdb(const char *path, vdb_index *idx, mgs_error *err);
// Step 2: the file metadata and grid `which` (or none when which < 0) through OpenVDB.
mgs_status load_vdb(const vdb_index &idx, int which, openvdb::MetaMap::Ptr *meta, openvdb::GridBase::Ptr *grid,
                    mgs_error *err);
// "name (value type), ..." for messages.
std::string grid_list(const vdb_index &idx);
// A descriptor's tree type as OpenVDB's valueType() names it ("Tree_vec3s_5_4_3" -> "vec3s").
std::string value_type_of(const std::string &tree_type);
}  // namespace mgs_vdb_detail
#endif
