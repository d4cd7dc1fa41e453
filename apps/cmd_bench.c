/* morsegs bench NAME: dispatch to one benchmark. */
#include <stdio.h>
#include <string.h>
#include "apps/mgs_cli.h"

typedef struct { const char *name; int (*fn)(int, char **); const char *help; } bench;
static const bench benches[] = {
  {"io", mgs_bench_io, "3DGS .ply write/read throughput and bit-exact round trip"},
  {"scene", mgs_bench_scene, "Embree dataset rendering: views/s for a large mesh"},
  {"raster", mgs_bench_raster, "rasterizer forward/backward ms and fraction of peak FLOP/s"},
  {"train", mgs_bench_train, "test PSNR against wall time for the built-in scenes"},
  {"vdb", mgs_bench_vdb, "alpha-field + SDF build time and memory vs OpenVDB ParticlesToLevelSet"},
  {"diagram", mgs_bench_diagram, "bottleneck/Wasserstein distances vs GUDHI"},
  {"topo", mgs_bench_topo, "narrow-band persistence time and memory vs dense peers"},
  {"scale", mgs_bench_scale, "city N=1,2,4: s/iteration, peak RSS, bytes/Gaussian, image-cache hits"},
  {"patchmatch", mgs_bench_patchmatch, "GaussianPro's plane patch matching: wall/CPU ms per run, output checksum"},
  {"mpi", mgs_bench_mpi, "K blocks on K MPI ranks vs one process: seam/interior PSNR, bytes, imbalance, weak scaling"},
};

int mgs_cmd_bench(int argc, char **argv) {
  if (argc < 2 || !strcmp(argv[1], "--help")) {
    fprintf(argc < 2 ? stderr : stdout, "usage: morsegs bench NAME [options]\n");
    for (size_t i = 0; i < sizeof benches / sizeof benches[0]; i++)
      fprintf(argc < 2 ? stderr : stdout, "  %-10s %s\n", benches[i].name, benches[i].help);
    return argc < 2 ? 2 : 0;
  }
  for (size_t i = 0; i < sizeof benches / sizeof benches[0]; i++)
    if (!strcmp(argv[1], benches[i].name)) return benches[i].fn(argc - 1, argv + 1);
  fprintf(stderr, "morsegs bench: unknown benchmark '%s'\n", argv[1]);
  return 2;
}
