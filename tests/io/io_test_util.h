/* Small helpers for the io tests: writing files, PNGs and little-endian binaries. */
#ifndef IO_TEST_UTIL_H
#define IO_TEST_UTIL_H
#include <stddef.h>
#include <stdint.h>

void io_write_text(const char *path, const char *text);
void io_write_bytes(const char *path, const void *data, size_t n);
void io_mkdir(const char *path);
/* RGBA (or RGB when channels == 3) PNG whose pixel (x, y) is
 * ((x % 256)/255, (y % 256)/255, 64/255, alpha) with alpha = 1 on even x, 128/255 on odd x. */
void io_write_png(const char *path, int w, int h, int channels);
float io_png_value(int x, int y, int c);

/* A growing little-endian byte buffer. */
typedef struct { unsigned char *p; size_t n, cap; } io_buf;
void io_put(io_buf *b, const void *data, size_t n);
void io_u32(io_buf *b, uint32_t v);
void io_i32(io_buf *b, int32_t v);
void io_u64(io_buf *b, uint64_t v);
void io_f64(io_buf *b, double v);
void io_str(io_buf *b, const char *s); /* with its NUL */
#endif
