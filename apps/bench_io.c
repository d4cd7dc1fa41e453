/* morsegs bench io: 3DGS .ply write and read throughput (SH degree 3), and the
 * bit-exactness of the round trip, for N Gaussians (default 1,000,000). */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "core/mgs_ply.h"

int mgs_bench_io(int argc, char **argv);

int mgs_bench_io(int argc, char **argv) {
  size_t n = 1000000;
  const char *dir = "/tmp";
  static const struct option opts[] = {{"count", required_argument, 0, 'n'}, {"dir", required_argument, 0, 'd'},
                                       {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  int c;
  optind = 1;
  while ((c = getopt_long(argc, argv, "n:d:h", opts, NULL)) != -1) {
    if (c == 'n') n = strtoull(optarg, NULL, 10);
    else if (c == 'd') dir = optarg;
    else {
      fprintf(c == 'h' ? stdout : stderr, "usage: morsegs bench io [--count N] [--dir DIR]\n"
                                          "  writes and reads a degree-3 3DGS .ply of N Gaussians in DIR\n");
      return c == 'h' ? 0 : 2;
    }
  }
  if (n == 0) { fprintf(stderr, "bench io: --count must be positive\n"); return 2; }
  mgs_error err;
  mgs_gaussians *g = mgs_gaussians_create(n, 3);
  size_t first;
  if (!g || mgs_gaussians_append(g, n, &first, &err) != MGS_OK) { fprintf(stderr, "bench io: out of memory\n"); return 1; }
  for (size_t i = 0; i < n * 45; i++) g->sh_rest[i] = (float)(i % 1013) * 1e-3f;
  for (size_t i = 0; i < n * 3; i++) { g->mean[i] = (float)i * 1e-3f; g->log_scale[i] = -4.0f; g->sh_dc[i] = 0.1f; }
  for (size_t i = 0; i < n; i++) g->opacity[i] = 0.5f;
  char name[64];
  snprintf(name, sizeof name, "mgs-bench-io-%ld.ply", (long)getpid());
  char *path = mgs_path_join(dir, name);
  double t0 = mgs_now();
  if (mgs_ply_write_gaussians(path, g, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); return 1; }
  double t1 = mgs_now();
  mgs_gaussians *h = NULL;
  if (mgs_ply_read_gaussians(path, &h, &err) != MGS_OK) { fprintf(stderr, "%s\n", err.msg); remove(path); return 1; }
  double t2 = mgs_now();
  int exact = h->n == g->n;
  for (int grp = 0; exact && grp < MGS_PARAM_COUNT; grp++)
    exact = memcmp(mgs_gaussians_group(g, (mgs_param_group)grp), mgs_gaussians_group(h, (mgs_param_group)grp),
                   sizeof(float) * n * (size_t)mgs_param_dim((mgs_param_group)grp)) == 0;
  double mb = (double)n * 62 * 4 / 1e6;
  printf("ply io: %zu Gaussians (SH 3, %.0f MB): write %.3f s (%.0f MB/s, incl. fsync), read %.3f s (%.0f MB/s), round trip %s\n",
         n, mb, t1 - t0, mb / (t1 - t0), t2 - t1, mb / (t2 - t1), exact ? "bit-exact" : "DIFFERS");
  remove(path);
  free(path);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(h);
  return exact ? 0 : 1;
}
