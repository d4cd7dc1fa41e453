/* `morsegs bench scene`: the time `morsegs scene` takes for 100 views at 400x400 of a
 * mesh of at least 100k triangles (the builtin genus2 at a finer detail), split into
 * ray casting + shading and everything else (PNG encoding, JSON, files). */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "apps/mgs_cli.h"
#include "assets/mgs_assets.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "render/mgs_scene.h"

int mgs_bench_scene(int argc, char **argv) {
  static const struct option longopts[] = {
      {"builtin", required_argument, 0, 'b'}, {"min-triangles", required_argument, 0, 't'},
      {"views", required_argument, 0, 'v'}, {"size", required_argument, 0, 's'}, {"spp", required_argument, 0, 'p'},
      {"keep", required_argument, 0, 'k'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  const char *builtin = "genus2", *keep = NULL;
  long min_tris = 100000, views = 100, size = 400, spp = 4;
  optind = 1;
  opterr = 0;
  int c;
  while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
    char *end = NULL;
    switch (c) {
    case 'b': builtin = optarg; break;
    case 't': min_tris = strtol(optarg, &end, 10); break;
    case 'v': views = strtol(optarg, &end, 10); break;
    case 's': size = strtol(optarg, &end, 10); break;
    case 'p': spp = strtol(optarg, &end, 10); break;
    case 'k': keep = optarg; break;
    case 'h':
      printf("usage: morsegs bench scene [--builtin genus2] [--min-triangles 100000] [--views 100] [--size 400]\n"
             "                           [--spp 4] [--keep DIR]\n"
             "Times `morsegs scene` on a builtin refined until it has at least --min-triangles.\n");
      return 0;
    default: fprintf(stderr, "morsegs bench scene: bad option %s\n", argv[optind - 1]); return 2;
    }
    if (end && (*end || min_tris < 1 || views < 1 || size < 1 || size > 8192 || spp < 1 || spp > 16)) {
      fprintf(stderr, "morsegs bench scene: bad value '%s'\n", optarg);
      return 2;
    }
  }
  mgs_error err;
  mgs_error_clear(&err);
  mgs_mesh *mesh = NULL;
  int detail = 1;
  double t0 = mgs_now();
  for (;; detail++) {
    if (mgs_assets_builtin_detail(builtin, detail, &mesh, &err) != MGS_OK) return mgs_cli_fail("bench scene", &err);
    if ((long)mesh->nt >= min_tris || detail == 16) break;
    mgs_mesh_destroy(mesh);
    mesh = NULL;
  }
  double t_mesh = mgs_now() - t0;
  char tmpl[] = "/tmp/mgs-bench-scene-XXXXXX";
  const char *base = keep;
  if (!base) {
    if (!mkdtemp(tmpl)) { mgs_mesh_destroy(mesh); fprintf(stderr, "morsegs bench scene: cannot make a temp folder\n"); return 1; }
    base = tmpl;
  }
  char *out = mgs_path_join(base, "dataset");
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.n_train = (int)views;
  o.n_test = 0;
  o.width = o.height = (int)size;
  o.spp = (int)spp;
  o.init = MGS_SCENE_INIT_NONE;
  o.mesh_name = builtin;
  o.quiet = 1;
  o.force = 1;
  mgs_scene_stats st;
  mgs_status s = mgs_scene_render_dataset_stats(mesh, &o, out, &st, &err);
  mgs_mesh_destroy(mesh);
  if (!keep) {
    mgs_error e2;
    mgs_remove_tree(tmpl, &e2);
  }
  free(out);
  if (s != MGS_OK) return mgs_cli_fail("bench scene", &err);
  printf("bench scene: builtin %s detail %d, %zu triangles (made in %.2f s), %zu views at %ldx%ld, %ldx%ld spp, %d threads\n",
         builtin, detail, st.triangles, t_mesh, st.views, size, size, spp, spp, mgs_parallel_max_threads());
  printf("  total        %8.2f s  (%.2f views/s)   [BVH build, rendering, PNG + JSON + PLY writing]\n", st.total_seconds,
         st.views / st.total_seconds);
  printf("  ray casting  %8.2f s  (%.2f views/s, %.2f Mrays/s primary rays incl. shading)\n", st.render_seconds,
         st.views / st.render_seconds, st.rays / st.render_seconds * 1e-6);
  printf("  peak RSS     %8.1f MiB\n", (double)mgs_peak_rss() / (1024.0 * 1024.0));
  return 0;
}
