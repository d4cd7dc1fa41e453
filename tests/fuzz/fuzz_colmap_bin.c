/* libFuzzer target: bytes as one of COLMAP's cameras.bin / images.bin / points3D.bin
 * (first byte selects which), the other two valid, loaded through mgs_dataset_load. */
#include "fuzz_colmap_common.h"

typedef struct { uint8_t b[1024]; size_t n; } buf;
static void put(buf *b, const void *p, size_t n) { memcpy(b->b + b->n, p, n); b->n += n; }
static void u32(buf *b, uint32_t v) { put(b, &v, 4); }
static void u64(buf *b, uint64_t v) { put(b, &v, 8); }
static void f64(buf *b, double v) { put(b, &v, 8); }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static buf cams, imgs, pts;
  if (!cams.n) { /* little-endian host: COLMAP's layout */
    u64(&cams, 1);
    u32(&cams, 1);
    u32(&cams, 1); /* PINHOLE */
    u64(&cams, 16);
    u64(&cams, 12);
    f64(&cams, 16); f64(&cams, 16); f64(&cams, 8); f64(&cams, 6);
    u64(&imgs, 2);
    for (int i = 0; i < 2; i++) {
      u32(&imgs, (uint32_t)i + 1);
      f64(&imgs, 1); f64(&imgs, 0); f64(&imgs, 0); f64(&imgs, 0);
      f64(&imgs, 0); f64(&imgs, 0); f64(&imgs, 4);
      u32(&imgs, 1);
      put(&imgs, i ? "a1.png" : "a0.png", 7);
      u64(&imgs, 1);
      f64(&imgs, 1); f64(&imgs, 2); u64(&imgs, 1);
    }
    u64(&pts, 1);
    u64(&pts, 1);
    f64(&pts, 0); f64(&pts, 0); f64(&pts, 0);
    put(&pts, "\x10\x20\x30", 3);
    f64(&pts, 0.5);
    u64(&pts, 1);
    u32(&pts, 1); u32(&pts, 0);
  }
  const uint8_t *valid[3] = {cams.b, imgs.b, pts.b};
  const size_t sizes[3] = {cams.n, imgs.n, pts.n};
  fuzz_colmap_run(data, size, "bin", valid, sizes);
  return 0;
}
