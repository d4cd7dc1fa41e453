/* libFuzzer target: a .spz file read as 3DGS Gaussians. The first byte chooses how the rest
 * reaches the reader: odd, gzip-compressed by the harness (so the fuzzer mutates the
 * decompressed layout of versions 1-3 directly); even, as the file's bytes (the NGSP
 * header and table of contents of version 4, or any container). */
#include <zlib.h>

#include "core/mgs_ply.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static char *path;
  if (!path) path = fuzz_path("input.spz");
  if (size == 0) return 0;
  if (data[0] & 1) {
    uLongf n = compressBound(size) + 32;
    uint8_t *gz = malloc(n);
    z_stream z;
    memset(&z, 0, sizeof z);
    if (!gz || deflateInit2(&z, 1, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK) abort();
    z.next_in = (Bytef *)data + 1;
    z.avail_in = (uInt)(size - 1);
    z.next_out = gz;
    z.avail_out = (uInt)n;
    if (deflate(&z, Z_FINISH) != Z_STREAM_END) abort();
    fuzz_write(path, gz, z.total_out);
    deflateEnd(&z);
    free(gz);
  } else {
    fuzz_write(path, data + 1, size - 1);
  }
  fuzz_check_gaussians(path, "input.spz");
  return 0;
}
