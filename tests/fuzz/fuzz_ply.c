/* libFuzzer target: bytes as a .ply file, read as 3DGS Gaussians and as a point cloud. */
#include "core/mgs_ply.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static char *path;
  if (!path) path = fuzz_path("input.ply");
  fuzz_write(path, data, size);
  fuzz_check_gaussians(path, "input.ply");
  mgs_error err;
  mgs_point_cloud *pc = NULL;
  if (mgs_ply_read_points(path, &pc, &err) == MGS_OK) mgs_point_cloud_destroy(pc);
  else if (pc || !strstr(err.msg, "input.ply")) abort();
  return 0;
}
