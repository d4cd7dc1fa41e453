/* libFuzzer target: bytes as a GaussianSplats3D .ksplat, read as 3DGS Gaussians. */
#include "core/mgs_ply.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static char *path;
  if (!path) path = fuzz_path("input.ksplat");
  fuzz_write(path, data, size);
  mgs_error err;
  mgs_gaussians *g = NULL;
  if (mgs_ply_read_gaussians(path, &g, &err) == MGS_OK) {
    if (!g) abort();
    mgs_gaussians_destroy(g);
  } else if (g || !strstr(err.msg, "input.ksplat")) {
    abort(); /* failures return nothing and name the file */
  }
  return 0;
}
