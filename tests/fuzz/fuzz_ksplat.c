/* libFuzzer target: bytes as a GaussianSplats3D .ksplat, read as 3DGS Gaussians. */
#include "core/mgs_ply.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static char *path;
  if (!path) path = fuzz_path("input.ksplat");
  fuzz_write(path, data, size);
  fuzz_check_gaussians(path, "input.ksplat");
  return 0;
}
