/* Internal to core/: the generic .ply container (header + element data) shared by the
 * Gaussian and point-cloud readers. Not a public header: other modules use mgs_ply.h.
 *
 * The whole file is mapped read-only; every access is bounds-checked against its size,
 * and element counts are checked against the bytes left before anything is allocated. */
#ifndef MGS_PLY_FORMAT_H
#define MGS_PLY_FORMAT_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"

typedef enum { PLY_ASCII = 0, PLY_BINARY_LE, PLY_BINARY_BE } ply_encoding;
typedef enum { PLY_INT8 = 0, PLY_UINT8, PLY_INT16, PLY_UINT16, PLY_INT32, PLY_UINT32,
               PLY_FLOAT32, PLY_FLOAT64, PLY_TYPE_COUNT } ply_type;

typedef struct ply_property {
  char name[64];
  ply_type type;       /* value type (of the items, for a list) */
  int is_list;
  ply_type count_type; /* list length type */
} ply_property;

typedef struct ply_element {
  char name[64];
  size_t count;
  int n_props;
  ply_property *props;
} ply_element;

typedef struct ply_file {
  const char *path;       /* for messages (not owned) */
  const unsigned char *data;
  size_t size;
  size_t body;            /* offset of the first byte after end_header\n */
  ply_encoding encoding;
  int n_elems;
  ply_element *elems;
  int mapped;
} ply_file;

/* Maps and parses the header. Errors name the file. */
mgs_status ply_open(const char *path, ply_file *pf, mgs_error *err);
void ply_close(ply_file *pf);

const char *ply_type_name(ply_type t);
int ply_type_size(ply_type t);
int ply_find_property(const ply_element *e, const char *name); /* index or -1 */

/* Called once per row of the wanted element with all its (non-list) property values
 * decoded to double in property order (list properties are skipped, value 0). */
typedef mgs_status (*ply_row_fn)(void *ctx, size_t row, const double *values, mgs_error *err);

/* Walks the body up to and through element `elem_index`, skipping earlier elements,
 * calling fn for each row of that element. A count larger than the bytes left can hold
 * is rejected before fn sees row 0, so callers allocate lazily at row 0 and never
 * allocate for a count the file cannot back. */
mgs_status ply_read_element(ply_file *pf, int elem_index, ply_row_fn fn, void *ctx, mgs_error *err);

/* Writes a 32-bit float / uint8 in little-endian order into buf. */
static inline void ply_put_f32le(unsigned char *buf, float v) {
  uint32_t u; __builtin_memcpy(&u, &v, 4);
  buf[0] = (unsigned char)u; buf[1] = (unsigned char)(u >> 8);
  buf[2] = (unsigned char)(u >> 16); buf[3] = (unsigned char)(u >> 24);
}
/* Writes a 64-bit double in little-endian order into buf. */
static inline void ply_put_f64le(unsigned char *buf, double v) {
  uint64_t u; __builtin_memcpy(&u, &v, 8);
  for (int k = 0; k < 8; k++) buf[k] = (unsigned char)(u >> (8 * k));
}
#endif
