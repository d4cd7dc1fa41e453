/* morsegs bench mpi: what splitting a scene into blocks costs (issue 12, item 9). The
 * builtin city (city 2 by default) trained by `mpirun -np K morsegs train --mpi` twice, with
 * densification until half the iterations: blocks independent until the merge
 * (--independent), and blocks that hand off at the end of densification and exchange
 * read-only ghosts every E steps; and by one process at the same total number of steps (K x
 * iterations). All models rendered on the test views. Pixels are split by where they land: "seam" when the
 * expected surface point's tile touches (26-neighbourhood) an occupied tile of another
 * block, "interior" otherwise, background left out.
 * Reports PSNR on each set for both models, bytes gathered, load imbalance (max / mean
 * rank training time) and wall time, and a weak-scaling pair (city 1 on 1 rank, city 2 --
 * 4x the content -- on 4 ranks: rank training time, not wall, as ranks may outnumber the
 * cores). All runs in one invocation; compare within it. Writes OUT/mpi.md and OUT/mpi.csv. */
#include <getopt.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cjson/cJSON.h>
#include "apps/mgs_cli.h"
#include "assets/mgs_assets.h"
#include "core/mgs_core.h"
#include "render/mgs_raster.h"
#include "render/mgs_scene.h"
#include "train/mgs_partition.h"

#define MAX_K 8

typedef struct psnr_acc { double se[2]; size_t n[2]; } psnr_acc; /* 0 seam, 1 interior */

static double psnr_of(const psnr_acc *a, int set) {
  if (!a->n[set]) return NAN;
  double mse = a->se[set] / (3.0 * (double)a->n[set]);
  return mse > 0 ? -10.0 * log10(mse) : INFINITY;
}

/* Occupied tiles (those holding initial points) and their owners, sorted by key: a tile
   is on a seam when one of its 26 neighbours is occupied and owned by another rank (empty
   tiles' owners are arbitrary curve positions, so they do not count). */
typedef struct tile_map { uint64_t *key; int *owner; size_t n; double side; } tile_map;

static uint64_t tile_key(long long x, long long y, long long z) {
  const long long o = 1LL << 20;
  return ((uint64_t)(x + o) & 0x1FFFFF) << 42 | ((uint64_t)(y + o) & 0x1FFFFF) << 21 | ((uint64_t)(z + o) & 0x1FFFFF);
}
static int cmp_u64(const void *a, const void *b) {
  uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return x < y ? -1 : x > y;
}
static int tile_owner(const tile_map *m, uint64_t k) {
  size_t lo = 0, hi = m->n;
  while (lo < hi) {
    size_t mid = (lo + hi) / 2;
    if (m->key[mid] < k) lo = mid + 1; else hi = mid;
  }
  return lo < m->n && m->key[lo] == k ? m->owner[lo] : -1;
}
static int tile_map_build(const mgs_partition *p, const mgs_point_cloud *pc, tile_map *m) {
  m->side = p->tile;
  m->key = malloc((pc->n + 1) * sizeof *m->key);
  m->owner = malloc((pc->n + 1) * sizeof *m->owner);
  if (!m->key || !m->owner) return 0;
  size_t n = 0;
  for (size_t i = 0; i < pc->n; i++) {
    const float *q = pc->xyz + 3 * i;
    m->key[n++] = tile_key((long long)floor(q[0] / m->side), (long long)floor(q[1] / m->side), (long long)floor(q[2] / m->side));
  }
  qsort(m->key, n, sizeof *m->key, cmp_u64);
  size_t u = 0;
  for (size_t i = 0; i < n; i++)
    if (!u || m->key[i] != m->key[u - 1]) m->key[u++] = m->key[i];
  m->n = u;
  for (size_t i = 0; i < u; i++) { /* the owner of the tile's centre */
    long long x = (long long)(m->key[i] >> 42) - (1LL << 20), y = (long long)((m->key[i] >> 21) & 0x1FFFFF) - (1LL << 20),
              z = (long long)(m->key[i] & 0x1FFFFF) - (1LL << 20);
    float c[3] = {(float)((x + 0.5) * m->side), (float)((y + 0.5) * m->side), (float)((z + 0.5) * m->side)};
    m->owner[i] = mgs_partition_owner(p, c);
  }
  return 1;
}
static int seam_point(const tile_map *m, const mgs_partition *p, const double w[3]) {
  long long t[3];
  for (int k = 0; k < 3; k++) t[k] = (long long)floor(w[k] / m->side);
  float c[3] = {(float)w[0], (float)w[1], (float)w[2]};
  int o = mgs_partition_owner(p, c);
  for (int dx = -1; dx <= 1; dx++)
    for (int dy = -1; dy <= 1; dy++)
      for (int dz = -1; dz <= 1; dz++) {
        int q = tile_owner(m, tile_key(t[0] + dx, t[1] + dy, t[2] + dz));
        if (q >= 0 && q != o) return 1;
      }
  return 0;
}

/* Seam / interior squared errors of `model` over the test views, pixels classified on its
   own expected depth against partition p. */
static mgs_status eval_model(mgs_dataset *ds, const char *ply, const mgs_partition *p, const tile_map *tm, psnr_acc *acc,
                             size_t *seam_share_num, size_t *seam_share_den, mgs_error *err) {
  mgs_gaussians *g = NULL;
  mgs_status st = mgs_ply_read_gaussians(ply, &g, err);
  if (st) return st;
  mgs_raster *r = mgs_raster_create();
  if (!r) { mgs_gaussians_destroy(g); return mgs_error_set(err, MGS_ERR_NOMEM, "bench mpi: out of memory"); }
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  memcpy(rs.background, ds->background, sizeof rs.background);
  rs.sh_degree = g->sh_degree;
  memset(acc, 0, sizeof *acc);
  for (size_t v = 0; v < ds->n_views[MGS_SPLIT_TEST] && !st; v++) {
    mgs_view *vw = &ds->views[MGS_SPLIT_TEST][v];
    if ((st = mgs_dataset_load_image(ds, vw, err))) break;
    mgs_raster_output out;
    if ((st = mgs_raster_forward(r, g, &vw->cam, &rs, &out, err))) break;
    const mgs_camera *c = &vw->cam;
    for (int y = 0; y < out.height; y++)
      for (int x = 0; x < out.width; x++) {
        size_t i = (size_t)y * out.width + x;
        if (out.alpha[i] < 0.5f) continue; /* background: neither set */
        double z = out.depth[i] / out.alpha[i];
        double pc[3] = {(x + 0.5 - c->cx) / c->fx * z, (y + 0.5 - c->cy) / c->fy * z, z}, w[3];
        for (int k = 0; k < 3; k++) w[k] = c->c2w[4 * k] * pc[0] + c->c2w[4 * k + 1] * pc[1] + c->c2w[4 * k + 2] * pc[2] + c->c2w[4 * k + 3];
        int set = seam_point(tm, p, w) ? 0 : 1;
        double se = 0;
        for (int k = 0; k < 3; k++) {
          double d = (double)out.color[3 * i + k] - (double)vw->image->data[3 * i + k];
          se += d * d;
        }
        acc->se[set] += se;
        acc->n[set]++;
      }
  }
  if (seam_share_num) { *seam_share_num = acc->n[0]; *seam_share_den = acc->n[0] + acc->n[1]; }
  mgs_raster_destroy(r);
  mgs_gaussians_destroy(g);
  return st;
}

static int run(const char *cmd) {
  int rc = system(cmd);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

static cJSON *read_json(const char *dir, const char *name) {
  char *p = mgs_path_join(dir, name), *text = NULL;
  size_t n = 0;
  mgs_error err;
  cJSON *j = NULL;
  if (p && !mgs_read_file(p, &text, &n, &err)) j = cJSON_Parse(text);
  free(p); free(text);
  return j;
}

static double jnum(const cJSON *j, const char *k) {
  const cJSON *v = cJSON_GetObjectItem(j, k);
  return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

static mgs_status make_city(const char *dir, int size, int res, mgs_error *err) {
  if (mgs_path_exists(dir)) return MGS_OK;
  mgs_mesh *mesh = NULL;
  mgs_status st = mgs_assets_city(size, 1, &mesh, err);
  if (st) return st;
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.city_size = size;
  o.n_train = 16 * size * size;
  o.n_test = 8;
  o.width = o.height = res;
  o.spp = 2;
  o.init_points = (size_t)10000 * size * size;
  o.quiet = 1;
  o.mesh_name = "builtin:city";
  st = mgs_scene_render_dataset(mesh, &o, dir, err);
  mgs_mesh_destroy(mesh);
  return st;
}

int mgs_bench_mpi(int argc, char **argv) {
  static const struct option opts[] = {{"ranks", required_argument, 0, 'k'}, {"iters", required_argument, 0, 'i'},
                                       {"res", required_argument, 0, 'r'},   {"mpirun", required_argument, 0, 'm'},
                                       {"output", required_argument, 0, 'o'}, {"no-weak", no_argument, 0, 'w'}, {"size", required_argument, 0, 's'}, {"exchange-every", required_argument, 0, 'e'},
                                       {"split-by", required_argument, 0, 'p'}, {"help", no_argument, 0, 'h'},        {0, 0, 0, 0}};
  int ks[MAX_K] = {2, 4}, nk = 2, iters = 300, res = 64, weak = 1, size = 2, every = 10, by_pixels = 0;
  const char *mpirun = "mpirun", *outdir = NULL;
  optind = 1;
  int c;
  while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
    switch (c) {
      case 'p':
        if (!strcmp(optarg, "pixels")) by_pixels = 1;
        else if (!strcmp(optarg, "points")) by_pixels = 0;
        else { fprintf(stderr, "morsegs bench mpi: --split-by must be pixels or points (got '%s')\n", optarg); return 2; }
        break;
      case 'k': {
        nk = 0;
        char *s = optarg, *end;
        while (*s && nk < MAX_K) {
          long v = strtol(s, &end, 10);
          if (end == s || v < 2 || v > 64) { fprintf(stderr, "morsegs bench mpi: --ranks needs a list of 2..64 (got '%s')\n", optarg); return 2; }
          ks[nk++] = (int)v;
          s = *end == ',' ? end + 1 : end;
          if (*end && *end != ',') { fprintf(stderr, "morsegs bench mpi: bad --ranks '%s'\n", optarg); return 2; }
        }
        break;
      }
      case 'i': iters = atoi(optarg); if (iters < 10) { fprintf(stderr, "morsegs bench mpi: --iters must be >= 10\n"); return 2; } break;
      case 'r': res = atoi(optarg); if (res < 16 || res > 2048) { fprintf(stderr, "morsegs bench mpi: --res must be 16..2048\n"); return 2; } break;
      case 'm': mpirun = optarg; break;
      case 'o': outdir = optarg; break;
      case 'w': weak = 0; break;
      case 'e': every = atoi(optarg); if (every < 1) { fprintf(stderr, "morsegs bench mpi: --exchange-every must be >= 1\n"); return 2; } break;
      case 's': size = atoi(optarg); if (size < 1 || size > 8) { fprintf(stderr, "morsegs bench mpi: --size must be 1..8\n"); return 2; } break;
      case 'h':
        printf("usage: morsegs bench mpi [--ranks 2,4] [--iters N (300)] [--res R (64)] [--size S (2)] [--exchange-every E (10)] [--split-by points|pixels (points)] [--mpirun PATH] [--no-weak] [-o DIR]\n"
               "  K blocks on K ranks (independent; ghosts exchanged every E steps after densification, which\n"
               "  ends at N/2) against one process at K x N steps: seam / interior PSNR, bytes gathered and exchanged,\n"
               "  load imbalance; weak scaling city 1 on 1 rank vs city 2 on 4 ranks. Writes DIR/mpi.md, mpi.csv.\n");
        return 0;
      default: return 2;
    }
  }
  char self[4096];
  ssize_t sl = readlink("/proc/self/exe", self, sizeof self - 1);
  if (sl <= 0) { fprintf(stderr, "morsegs bench mpi: cannot find its own executable\n"); return 1; }
  self[sl] = 0;
  char tmpl[] = "/tmp/mgs-bench-mpi-XXXXXX";
  const char *base = outdir;
  mgs_error err;
  mgs_error_clear(&err);
  if (!base) {
    if (!mkdtemp(tmpl)) { fprintf(stderr, "morsegs bench mpi: cannot make a temp folder\n"); return 1; }
    base = tmpl;
  } else if (mgs_mkdir_p(base, &err)) return mgs_cli_fail("bench mpi", &err);
  setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 0);
  setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 0);
  setenv("MGS_THREADS", "1", 1); /* one thread per rank: ranks are the parallelism */
  char city[4200], cmd[32768];
  snprintf(city, sizeof city, "%s/city%d_%d", base, size, res);
  if (make_city(city, size, res, &err)) return mgs_cli_fail("bench mpi", &err);
  mgs_dataset_options dopt;
  mgs_dataset_options_default(&dopt);
  dopt.load_images = 0;
  mgs_dataset *ds = NULL;
  if (mgs_dataset_load(city, &dopt, &ds, &err)) return mgs_cli_fail("bench mpi", &err);
  char md[65536];
  size_t ml = 0;
  char csv[16384];
  size_t cl = 0;
  cl += (size_t)snprintf(csv + cl, sizeof csv - cl, "ranks,model,steps_per_rank,psnr_seam,psnr_interior,seam_pixels,pixels,wall_s,bytes_gathered,bytes_exchanged_per_step,load_imbalance\n");
  ml += (size_t)snprintf(md + ml, sizeof md - ml,
                         "# morsegs bench mpi\n\ncity %d (%d² views, %zu train / %zu test), %d iterations per rank, densification until half of them, one thread per rank, `%s`; blocks of equal %s.\n\n"
                         "| ranks | model | steps per rank | PSNR seam | PSNR interior | seam share of pixels | wall s | bytes gathered | bytes exchanged per step | load imbalance |\n"
                         "|---|---|---|---|---|---|---|---|---|---|\n",
                         size, res, ds->n_views[MGS_SPLIT_TRAIN], ds->n_views[MGS_SPLIT_TEST], iters, mpirun,
                         by_pixels ? "points + pixels that see them (--split-by pixels)" : "points (--split-by points)");
  int rc = 0;
  for (int q = 0; q < nk && !rc; q++) {
    int K = ks[q], half = iters / 2;
    char rbuf[3][4400], rs[4400];
    const char *rb[3] = {rbuf[0], rbuf[1], rbuf[2]}; /* (pointers: gcc sizes a row of a 2-D array as the whole) */
    double wall_b[3];
    /* [0] independent blocks, [1] read-only ghosts exchanged after the hand-off at `half`,
       [2] ghosts averaged with their owners at each exchange */
    static const char *suffix[3] = {"", "_ghosts", "_average"};
    for (int x = 0; x < 3 && !rc; x++) {
      snprintf(rbuf[x], sizeof rbuf[x], "%s/np%d%s", base, K, suffix[x]);
      char extra[128];
      if (x) snprintf(extra, sizeof extra, "--exchange-every %d --ghosts %s --split-by %s", every, x == 2 ? "average" : "owner",
                      by_pixels ? "pixels" : "points");
      else snprintf(extra, sizeof extra, "--independent --split-by %s", by_pixels ? "pixels" : "points");
      snprintf(cmd, sizeof cmd, "'%s' --oversubscribe -np %d '%s' train --mpi '%s' -o '%s' --iters %d --densify-until %d %s --seed 1 "
               "--quiet --force > '%s.log' 2>&1", mpirun, K, self, city, rb[x], iters, half, extra, rb[x]);
      double t0 = mgs_now();
      if (run(cmd)) { fprintf(stderr, "morsegs bench mpi: -np %d failed (see %s.log)\n", K, rb[x]); rc = 1; }
      wall_b[x] = mgs_now() - t0;
    }
    if (rc) break;
    snprintf(rs, sizeof rs, "%s/serial%d", base, K);
    snprintf(cmd, sizeof cmd, "'%s' train '%s' -o '%s' --iters %d --densify-until %d --seed 1 --quiet --force --checkpoint-every 0 > '%s.log' 2>&1",
             self, city, rs, K * iters, K * half, rs);
    double t0 = mgs_now();
    if (run(cmd)) { fprintf(stderr, "morsegs bench mpi: the single-process run failed (see %s.log)\n", rs); rc = 1; break; }
    double wall_s = mgs_now() - t0;
    mgs_partition *part = NULL;
    if (mgs_partition_for_dataset(ds, K, by_pixels, &part, &err)) { rc = mgs_cli_fail("bench mpi", &err); break; }
    char pb[3][9000], ps[4600];
    for (int x = 0; x < 3; x++) snprintf(pb[x], sizeof pb[x], "%s/point_cloud/iteration_%d/point_cloud.ply", rb[x], iters);
    snprintf(ps, sizeof ps, "%s/point_cloud/iteration_%d/point_cloud.ply", rs, K * iters);
    psnr_acc ab[3], as;
    size_t sn = 0, sd = 0;
    tile_map tm = {0};
    if (!tile_map_build(part, ds->init_points, &tm)) { free(tm.key); free(tm.owner); mgs_partition_destroy(part); fprintf(stderr, "morsegs bench mpi: out of memory\n"); rc = 1; break; }
    mgs_status es = eval_model(ds, pb[0], part, &tm, &ab[0], &sn, &sd, &err);
    if (!es) es = eval_model(ds, pb[1], part, &tm, &ab[1], NULL, NULL, &err);
    if (!es) es = eval_model(ds, pb[2], part, &tm, &ab[2], NULL, NULL, &err);
    if (!es) es = eval_model(ds, ps, part, &tm, &as, NULL, NULL, &err);
    free(tm.key); free(tm.owner);
    mgs_partition_destroy(part);
    if (es) { rc = mgs_cli_fail("bench mpi", &err); break; }
    for (int x = 0; x < 3; x++) {
      cJSON *st = read_json(rb[x], "mpi_stats.json");
      double bytes = st ? jnum(st, "bytes_gathered") : NAN, imb = st ? jnum(st, "load_imbalance") : NAN;
      double xps = st && x ? jnum(st, "bytes_exchanged_per_step") : 0;
      cJSON_Delete(st);
      char model[96];
      if (x == 1) snprintf(model, sizeof model, "%d blocks, ghosts every %d steps", K, every);
      else if (x == 2) snprintf(model, sizeof model, "%d blocks, averaged ghosts every %d steps", K, every);
      else snprintf(model, sizeof model, "%d blocks, independent", K);
      ml += (size_t)snprintf(md + ml, sizeof md - ml, "| %d | %s | %d | %.2f | %.2f | %.1f %% | %.1f | %.0f | %.0f | %.2f |\n", K, model,
                             iters, psnr_of(&ab[x], 0), psnr_of(&ab[x], 1), sd ? 100.0 * sn / sd : 0.0, wall_b[x], bytes, xps, imb);
      cl += (size_t)snprintf(csv + cl, sizeof csv - cl, "%d,%s,%d,%.4f,%.4f,%zu,%zu,%.2f,%.0f,%.0f,%.3f\n", K, x == 2 ? "blocks_average" : x ? "blocks_ghosts" : "blocks", iters,
                             psnr_of(&ab[x], 0), psnr_of(&ab[x], 1), sn, sd, wall_b[x], bytes, xps, imb);
      printf("-np %d %s: seam %.2f / interior %.2f dB, seam pixels %.1f %%, %.0f bytes gathered, %.0f bytes exchanged per step, imbalance %.2f\n",
             K, x == 2 ? "averaged ghosts" : x ? "ghosts" : "independent", psnr_of(&ab[x], 0), psnr_of(&ab[x], 1), sd ? 100.0 * sn / sd : 0.0, bytes, xps, imb);
    }
    ml += (size_t)snprintf(md + ml, sizeof md - ml, "| 1 | one process, same total steps | %d | %.2f | %.2f | (same pixel split) | %.1f | – | – | – |\n",
                           K * iters, psnr_of(&as, 0), psnr_of(&as, 1), wall_s);
    cl += (size_t)snprintf(csv + cl, sizeof csv - cl, "%d,single,%d,%.4f,%.4f,%zu,%zu,%.2f,,,\n", K, K * iters, psnr_of(&as, 0),
                           psnr_of(&as, 1), sn, sd, wall_s);
    printf("-np %d: one process at %d steps: seam %.2f / interior %.2f dB\n", K, K * iters, psnr_of(&as, 0), psnr_of(&as, 1));
    fflush(stdout);
  }
  mgs_dataset_destroy(ds);
  if (!rc && weak) {
    /* weak scaling: 4x the content on 4x the ranks; per-rank training time */
    char city1[4200], city2[4200], r1[4400], r4[4400];
    snprintf(city1, sizeof city1, "%s/city1_%d", base, res);
    snprintf(city2, sizeof city2, "%s/city2_%d", base, res);
    if (make_city(city1, 1, res, &err) || make_city(city2, 2, res, &err)) return mgs_cli_fail("bench mpi", &err);
    snprintf(r1, sizeof r1, "%s/weak1", base);
    snprintf(r4, sizeof r4, "%s/weak4", base);
    snprintf(cmd, sizeof cmd, "'%s' train '%s' -o '%s' --iters %d --densify-until %d --seed 1 --quiet --force --checkpoint-every 0 > '%s.log' 2>&1",
             self, city1, r1, iters, iters / 2, r1);
    int ok = run(cmd) == 0;
    snprintf(cmd, sizeof cmd, "'%s' --oversubscribe -np 4 '%s' train --mpi '%s' -o '%s' --iters %d --densify-until %d --exchange-every %d "
             "--split-by %s --seed 1 --quiet --force > '%s.log' 2>&1", mpirun, self, city2, r4, iters, iters / 2, every,
             by_pixels ? "pixels" : "points", r4);
    ok = ok && run(cmd) == 0;
    cJSON *a = ok ? read_json(r1, "train_stats.json") : NULL, *b = ok ? read_json(r4, "mpi_stats.json") : NULL;
    double t1 = a ? jnum(a, "train_seconds") : NAN, t4 = b ? jnum(b, "train_seconds_max") : NAN;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    ml += (size_t)snprintf(md + ml, sizeof md - ml,
                           "\nWeak scaling (city 1 on 1 rank, city 2 = 4× the content on 4 ranks with ghosts exchanged, %d iterations each): rank training "
                           "time %.1f s vs %.1f s (max over ranks), ratio %.2f; this machine has %ld cores, so with 4 ranks each "
                           "rank had %.2f of a core (the ratio normalized by that: %.2f).\n",
                           iters, t1, t4, t4 / t1, cores, cores >= 4 ? 1.0 : cores / 4.0, cores >= 4 ? t4 / t1 : t4 / t1 * cores / 4.0);
    printf("weak scaling: 1 rank %.1f s, 4 ranks (4x content) %.1f s max per rank (%ld cores)\n", t1, t4, cores);
    cJSON_Delete(a); cJSON_Delete(b);
    if (!ok) { fprintf(stderr, "morsegs bench mpi: a weak-scaling run failed (see %s.log, %s.log)\n", r1, r4); rc = 1; }
  }
  if (!rc) {
    char *p = mgs_path_join(base, "mpi.md"), *p2 = mgs_path_join(base, "mpi.csv");
    if (!p || !p2 || mgs_write_file_atomic(p, md, ml, &err) || mgs_write_file_atomic(p2, csv, cl, &err)) rc = mgs_cli_fail("bench mpi", &err);
    else printf("wrote %s, %s\n", p, p2);
    free(p); free(p2);
  }
  return rc;
}
