/* Every pair of neighbouring voxels in the SDF of trained models (band_check.h).
 * With file arguments: prints the band check of each .vdb's 'sdf' grid at several
 * tolerances (a diagnostic tool; exits non-zero if any has jump/sign pairs at tol 0.1). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "band_check.h"
#include "mgs_test.h"

static int check_files(int argc, char **argv) {
  int bad = 0;
  for (int i = 1; i < argc; i++) {
    mgs_vdb_grid *g = NULL;
    mgs_error err = {0};
    if (mgs_vdb_read_grid(argv[i], "sdf", &g, &err) != MGS_OK) {
      fprintf(stderr, "%s\n", err.msg);
      return 2;
    }
    static const double tols[] = {0.01, 0.1, 1.0, 2.0};
    for (int t = 0; t < 4; t++) {
      bc_report r;
      if (bc_check(g, tols[t], &r)) return 2;
      char w[512];
      snprintf(w, sizeof w, "%s tol %.2f", argv[i], tols[t]);
      bc_print(stdout, w, &r, mgs_vdb_grid_voxel_size(g));
      if (tols[t] == 0.1 && bc_bad(&r)) bad = 1;
    }
    mgs_vdb_grid_destroy(g);
  }
  return bad;
}

int main(int argc, char **argv) {
  if (argc > 1) return check_files(argc, argv);
  return mgs_test_finish();
}
