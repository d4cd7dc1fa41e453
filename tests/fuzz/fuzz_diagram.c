/* libFuzzer target: bytes as a persistence diagram file, read both as GUDHI-style text
 * (mgs_diagram_read_text) and as JSON (mgs_diagram_read_json); whatever is accepted is
 * written back and must read back to the same pairs.
 * The fuzz build links mgs_core only, so the diagram sources (which need nothing beyond
 * core and cJSON) are compiled into this target directly. */
#include <math.h>
#include "fuzz_util.h"
#include "../../topo/diagram.c"
#include "../../topo/diagram_io.c"
#include "../../topo/diagram_query.c"

static void same_or_abort(const mgs_diagram *a, const mgs_diagram *b) {
  if (a->n != b->n) abort();
  for (size_t i = 0; i < a->n; i++) {
    const mgs_pair *p = &a->pairs[i], *q = &b->pairs[i];
    if (p->dim != q->dim) abort();
    if (!(p->birth == q->birth || (isnan(p->birth) && isnan(q->birth)))) abort();
    if (!(p->death == q->death || (isnan(p->death) && isnan(q->death)))) abort();
  }
}

static void round_trip(const mgs_diagram *d, int json) {
  char *p = fuzz_path(json ? "back.json" : "back.txt");
  mgs_error err;
  mgs_diagram *r = NULL;
  mgs_status st = json ? mgs_diagram_write_json(p, d, NULL, &err) : mgs_diagram_write_text(p, d, &err);
  if (st != MGS_OK) abort();
  st = json ? mgs_diagram_read_json(p, &r, &err) : mgs_diagram_read_text(p, &r, &err);
  if (st != MGS_OK || !r) abort();
  same_or_abort(d, r);
  mgs_diagram_destroy(r);
  free(p);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  char *path = fuzz_path("in.txt");
  fuzz_write(path, data, size);
  mgs_error err;
  mgs_diagram *d = NULL;
  if (mgs_diagram_read_text(path, &d, &err) == MGS_OK) {
    if (!d) abort();
    round_trip(d, 0);
    mgs_diagram_destroy(d);
  } else if (d || !err.msg[0] || strchr(err.msg, '\n')) abort();
  d = NULL;
  if (mgs_diagram_read_json(path, &d, &err) == MGS_OK) {
    if (!d) abort();
    /* JSON holds NaN-free finite/infinite values only when written by us; pairs read from
     * arbitrary JSON round-trip as long as they are not NaN (numbers cannot be NaN) */
    round_trip(d, 1);
    mgs_diagram_destroy(d);
  } else if (d || !err.msg[0] || strchr(err.msg, '\n')) abort();
  free(path);
  return 0;
}
