/* libFuzzer target: bytes as a SOG meta.json beside the seven WebP textures of
 * tests/io/data/lever600.sog (unpacked once at start; run from the repository root, as
 * scripts/fuzz.sh does), read as 3DGS Gaussians: the fuzzer mutates counts, bounds,
 * codebooks, file names and the palette against real textures. */
#include <unzip.h>

#include "core/mgs_ply.h"
#include "fuzz_util.h"

static void unpack_textures(void) {
  unzFile z = unzOpen64("tests/io/data/lever600.sog");
  if (!z) abort(); /* run from the repository root */
  for (int r = unzGoToFirstFile(z); r == UNZ_OK; r = unzGoToNextFile(z)) {
    char name[256];
    unz_file_info64 info;
    if (unzGetCurrentFileInfo64(z, &info, name, sizeof name, NULL, 0, NULL, 0) != UNZ_OK) abort();
    if (!strcmp(name, "meta.json")) continue;
    uint8_t *buf = malloc(info.uncompressed_size + 1);
    if (!buf || unzOpenCurrentFile(z) != UNZ_OK) abort();
    if (unzReadCurrentFile(z, buf, (unsigned)info.uncompressed_size) != (int)info.uncompressed_size) abort();
    unzCloseCurrentFile(z);
    char *p = fuzz_path(name);
    fuzz_write(p, buf, info.uncompressed_size);
    free(p);
    free(buf);
  }
  unzClose(z);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static char *path;
  if (!path) {
    path = fuzz_path("meta.json");
    unpack_textures();
  }
  fuzz_write(path, data, size);
  fuzz_check_gaussians(path, "meta.json");
  return 0;
}
