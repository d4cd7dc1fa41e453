/* Scene origins (core/mgs_origin.h). */
#include "core/mgs_origin.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

void mgs_origin_choose(const double c[3], double extent, double o[3]) {
  o[0] = o[1] = o[2] = 0;
  double e = extent > 0 && isfinite(extent) ? extent : 1.0;
  double m = 0;
  for (int k = 0; k < 3; k++) {
    if (!isfinite(c[k])) return;
    if (fabs(c[k]) > m) m = fabs(c[k]);
  }
  if (!(m > MGS_ORIGIN_FAR * e)) return;
  double s = exp2(ceil(log2(e)));
  for (int k = 0; k < 3; k++) o[k] = s * nearbyint(c[k] / s);
}

int mgs_origin_is_zero(const double o[3]) { return o[0] == 0 && o[1] == 0 && o[2] == 0; }

void mgs_origin_format(const double o[3], char *buf, size_t len) {
  /* +0.0 for a zero so that "-0" never appears in a record */
  snprintf(buf, len, "%.17g %.17g %.17g", o[0] + 0.0, o[1] + 0.0, o[2] + 0.0);
}

int mgs_origin_parse(const char *text, double o[3]) {
  if (!text) return 0;
  const char *p = text;
  for (int k = 0; k < 3; k++) {
    char *end = NULL;
    double v = strtod(p, &end);
    if (end == p || !isfinite(v)) return 0;
    o[k] = v;
    p = end;
  }
  while (*p == ' ') p++;
  return *p == 0;
}
