/* morsegs bench diagram: bottleneck and Wasserstein distances between random persistence
 * diagrams of n points (one dimension), ours beside GUDHI (python3-gudhi: exact
 * bottleneck_distance(e=0); wasserstein_distance via POT, internal_p = inf) on the same
 * points, in one run so the machine load is shared. Reports seconds for each and checks the
 * values agree. GUDHI runs as a subprocess: its time is measured inside Python (the
 * distance call only, not start-up). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "apps/mgs_cli.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "core/mgs_rng.h"
#include "topo/mgs_diagram_tools.h"

static const char *gudhi_script =
    "import sys, time, numpy as np, gudhi\n"
    "from gudhi.wasserstein import wasserstein_distance\n"
    "a = np.loadtxt(sys.argv[1], ndmin=2); b = np.loadtxt(sys.argv[2], ndmin=2)\n"
    "t = time.perf_counter(); bn = gudhi.bottleneck_distance(a, b, 0.0); tb = time.perf_counter() - t\n"
    "w1 = tw1 = -1\n"
    "if int(sys.argv[3]):\n"
    "    t = time.perf_counter(); w1 = wasserstein_distance(a, b, order=1.0, internal_p=np.inf); tw1 = time.perf_counter() - t\n"
    "print('%.17g %.6f %.17g %.6f' % (bn, tb, w1, tw1))\n";

static void random_diagram(mgs_rng *r, size_t n, double *b, double *d) {
  for (size_t i = 0; i < n; i++) {
    b[i] = mgs_rng_uniform(r);
    d[i] = b[i] + 0.2 * pow(mgs_rng_uniform(r), 2);
  }
}

static int write_pts(const char *path, const double *b, const double *d, size_t n) {
  FILE *f = fopen(path, "w");
  if (!f) return 0;
  for (size_t i = 0; i < n; i++) fprintf(f, "%.17g %.17g\n", b[i], d[i]);
  return fclose(f) == 0;
}

int mgs_bench_diagram(int argc, char **argv) {
  int with_gudhi = 1, c;
  static const struct option opts[] = {{"no-gudhi", no_argument, 0, 'n'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  optind = 1;
  while ((c = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
    if (c == 'n') with_gudhi = 0;
    else {
      fprintf(c == 'h' ? stdout : stderr, "usage: morsegs bench diagram [--no-gudhi]\n");
      return c == 'h' ? 0 : 2;
    }
  }
  static const size_t sizes[] = {100, 500, 1000, 2000, 5000, 20000};
  char dir[] = "/tmp/mgs-bench-diagram-XXXXXX";
  if (!mkdtemp(dir)) { perror("mkdtemp"); return 1; }
  char script[256], pa[256], pb[256];
  snprintf(script, sizeof script, "%s/gudhi_dist.py", dir);
  snprintf(pa, sizeof pa, "%s/a.txt", dir);
  snprintf(pb, sizeof pb, "%s/b.txt", dir);
  mgs_error err;
  if (mgs_write_file_atomic(script, gudhi_script, strlen(gudhi_script), &err) != MGS_OK) return mgs_cli_fail("bench diagram", &err);
  printf("%-7s %12s %12s %8s %12s %12s %8s  %s\n", "n", "bottleneck", "GUDHI", "ratio", "W1 (ours)", "W1 (GUDHI)", "ratio", "values agree");
  mgs_rng r;
  mgs_rng_init(&r, 2024, 1);
  int rc = 0;
  for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
    size_t n = sizes[s];
    double *b1 = malloc(n * sizeof(double)), *d1 = malloc(n * sizeof(double));
    double *b2 = malloc(n * sizeof(double)), *d2 = malloc(n * sizeof(double));
    if (!b1 || !d1 || !b2 || !d2) { free(b1); free(d1); free(b2); free(d2); return 1; }
    random_diagram(&r, n, b1, d1);
    random_diagram(&r, n, b2, d2);
    double t = mgs_now();
    double bn = mgs_bottleneck_points(b1, d1, n, b2, d2, n, 0);
    double tb = mgs_now() - t;
    int do_w = 2 * n <= MGS_WASSERSTEIN_EXACT_MAX;
    double w1 = -1, tw = -1;
    if (do_w) {
      t = mgs_now();
      w1 = mgs_wasserstein_points(b1, d1, n, b2, d2, n, 1.0, INFINITY, NULL);
      tw = mgs_now() - t;
    }
    double gb = NAN, gtb = NAN, gw = NAN, gtw = NAN;
    if (with_gudhi && n <= 5000) {
      char cmd[1024];
      snprintf(cmd, sizeof cmd, "/usr/bin/python3 %s %s %s %d", script, pa, pb, do_w && n <= 1000);
      if (write_pts(pa, b1, d1, n) && write_pts(pb, b2, d2, n)) {
        FILE *p = popen(cmd, "r");
        if (p) {
          if (fscanf(p, "%lf %lf %lf %lf", &gb, &gtb, &gw, &gtw) != 4) gb = NAN;
          pclose(p);
        }
      }
    }
    int agree = isnan(gb) || (fabs(gb - bn) <= 1e-12 && (gw < 0 || fabs(gw - w1) <= 1e-9 * (1 + w1)));
    if (!agree) rc = 1;
    printf("%-7zu %10.4f s %10.4f s %7.1fx", n, tb, gtb, gtb / tb);
    if (do_w) printf(" %10.4f s %10.4f s %7.1fx", tw, gtw > 0 ? gtw : NAN, gtw > 0 ? gtw / tw : NAN);
    else printf(" %12s %12s %8s", "(approx)", "-", "-");
    printf("  %s\n", isnan(gb) ? "(no GUDHI run)" : agree ? "yes" : "NO");
    fflush(stdout);
    free(b1); free(d1); free(b2); free(d2);
  }
  mgs_remove_tree(dir, &err);
  return rc;
}
