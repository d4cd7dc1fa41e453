/* Reading a run's results.json (what `morsegs eval` writes) in the CLI tests. */
#ifndef MGS_TEST_RUN_RESULTS_H
#define MGS_TEST_RUN_RESULTS_H
#include <stdio.h>
#include <stdlib.h>
#include <cjson/cJSON.h>
#include "core/mgs_fs.h"

/* The PSNR of RUN/results.json's ours_IT, -1 when the file, the entry or the figure is
   missing; *has_geometry (may be NULL): the entry holds geometry figures. */
static inline double mgs_test_results_psnr(const char *run, int it, int *has_geometry) {
  char path[4200], *text = NULL, key[64];
  size_t n;
  if (has_geometry) *has_geometry = 0;
  snprintf(path, sizeof path, "%s/results.json", run);
  if (mgs_read_file(path, &text, &n, NULL) != MGS_OK) return -1;
  cJSON *j = cJSON_Parse(text);
  snprintf(key, sizeof key, "ours_%d", it);
  cJSON *r = cJSON_GetObjectItem(j, key), *p = cJSON_GetObjectItem(r, "PSNR");
  double v = cJSON_IsNumber(p) ? p->valuedouble : -1;
  if (has_geometry) *has_geometry = cJSON_GetObjectItem(r, "geometry") != NULL;
  cJSON_Delete(j);
  free(text);
  return v;
}
#endif
