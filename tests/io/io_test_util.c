#include "io_test_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/mgs_image.h"

void io_write_bytes(const char *path, const void *data, size_t n) {
  FILE *f = fopen(path, "wb");
  if (!f) { perror(path); exit(2); }
  if (n && fwrite(data, 1, n, f) != n) exit(2);
  fclose(f);
}

void io_write_text(const char *path, const char *text) { io_write_bytes(path, text, strlen(text)); }

void io_mkdir(const char *path) {
  char cmd[4200];
  snprintf(cmd, sizeof cmd, "mkdir -p '%s'", path);
  if (system(cmd) != 0) exit(2);
}

float io_png_value(int x, int y, int c) {
  switch (c) {
    case 0: return (float)(x % 256) / 255.0f;
    case 1: return (float)(y % 256) / 255.0f;
    case 2: return 64.0f / 255.0f;
    default: return (x % 2) ? 128.0f / 255.0f : 1.0f;
  }
}

void io_write_png(const char *path, int w, int h, int channels) {
  mgs_image *img = mgs_image_create(w, h, channels);
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++)
      for (int c = 0; c < channels; c++) img->data[((size_t)y * w + x) * channels + c] = io_png_value(x, y, c);
  mgs_error err;
  if (mgs_image_write(path, img, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); exit(2); }
  mgs_image_destroy(img);
}

void io_put(io_buf *b, const void *data, size_t n) {
  if (b->n + n > b->cap) {
    b->cap = (b->n + n) * 2 + 64;
    b->p = realloc(b->p, b->cap);
    if (!b->p) exit(2);
  }
  memcpy(b->p + b->n, data, n);
  b->n += n;
}
static void put_le(io_buf *b, uint64_t v, int bytes) {
  unsigned char t[8];
  for (int i = 0; i < bytes; i++) t[i] = (unsigned char)(v >> (8 * i));
  io_put(b, t, (size_t)bytes);
}
void io_u32(io_buf *b, uint32_t v) { put_le(b, v, 4); }
void io_i32(io_buf *b, int32_t v) { put_le(b, (uint32_t)v, 4); }
void io_u64(io_buf *b, uint64_t v) { put_le(b, v, 8); }
void io_f64(io_buf *b, double v) {
  uint64_t u;
  memcpy(&u, &v, 8);
  put_le(b, u, 8);
}
void io_str(io_buf *b, const char *s) { io_put(b, s, strlen(s) + 1); }
