/* libFuzzer target: bytes as one of COLMAP's cameras.txt / images.txt / points3D.txt
 * (first byte selects which), the other two valid, loaded through mgs_dataset_load. */
#include "fuzz_colmap_common.h"

static const char cams[] = "# Camera list\n1 PINHOLE 16 12 16 16 8 6\n";
static const char imgs[] = "# Image list\n1 1 0 0 0 0 0 4 1 a0.png\n1 2 1\n2 1 0 0 0 0 0 4 1 a1.png\n\n";
static const char pts[] = "# 3D point list\n1 0 0 0 16 32 48 0.5 1 0\n";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  const uint8_t *valid[3] = {(const uint8_t *)cams, (const uint8_t *)imgs, (const uint8_t *)pts};
  const size_t sizes[3] = {sizeof cams - 1, sizeof imgs - 1, sizeof pts - 1};
  fuzz_colmap_run(data, size, "txt", valid, sizes);
  return 0;
}
