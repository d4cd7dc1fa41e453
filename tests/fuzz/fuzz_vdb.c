/* libFuzzer target: bytes as a .vdb file through the project's entry points
 * (mgs_vdb_read_meta, mgs_vdb_read_grid with and without a grid name: the path of
 * `morsegs persistence`). Failures return nothing and name the file; a grid that is read
 * has a positive finite voxel size. Run with -rss_limit_mb so a file that makes the
 * reader allocate without bound is a finding. */
#include <math.h>
#include "vdb/mgs_vdb.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static char *path;
  if (!path) path = fuzz_path("input.vdb");
  fuzz_write(path, data, size);
  mgs_error err;
  mgs_vdb_file_meta meta;
  if (mgs_vdb_read_meta(path, &meta, &err) != MGS_OK && !strstr(err.msg, "input.vdb")) abort();
  const char *names[2] = {NULL, "sdf"};
  for (int i = 0; i < 2; i++) {
    mgs_vdb_grid *g = NULL;
    if (mgs_vdb_read_grid(path, names[i], &g, &err) == MGS_OK) {
      if (!g) abort();
      const double vs = mgs_vdb_grid_voxel_size(g);
      if (!(vs > 0) || !isfinite(vs)) abort();
      (void)mgs_vdb_grid_active_voxel_count(g);
      mgs_vdb_grid_destroy(g);
    } else if (g || !strstr(err.msg, "input.vdb")) {
      abort();
    }
  }
  return 0;
}
