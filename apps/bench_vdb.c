/* morsegs bench vdb: α-field + SDF build time and memory for 100k and 1M Gaussians on a torus
 * surface (the band is sparse) at effective 256³, 512³, 1024³ (voxel size = the torus's
 * largest bounding-box side / N), with the active voxel count beside the dense count, and
 * OpenVDB's own ParticlesToLevelSet on spheres at the same voxel size, in the same run.
 * Peak memory: each case, ours and OpenVDB's apart, runs in its own forked process whose
 * high-water mark is reset first (/proc/self/clear_refs), so "peak" is that build's own peak
 * RSS (the shared input arrays included). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include "apps/mgs_cli.h"
#include "core/mgs_log.h"
#include "core/mgs_parallel.h"
#include "core/mgs_rng.h"
#include "vdb/mgs_vdb.h"

static const double TOR_R = 1.0, TOR_r = 0.4;

static double cpu_seconds(void) {
  struct rusage ru;
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_utime.tv_sec + ru.ru_stime.tv_sec + 1e-6 * (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

static void reset_peak(void) {
  FILE *f = fopen("/proc/self/clear_refs", "w");
  if (f) { fputs("5", f); fclose(f); }
}
static double status_kib(const char *key) {
  FILE *f = fopen("/proc/self/status", "r");
  char line[256];
  double v = 0;
  size_t kl = strlen(key);
  while (f && fgets(line, sizeof line, f))
    if (!strncmp(line, key, kl)) v = atof(line + kl + 1);
  if (f) fclose(f);
  return v;
}

/* n Gaussians area-uniform on the torus: flat discs tangent to it, neighbours overlapping
 * (ρ·2πσt² = 4), thickness σt/4, opacity 0.6. Raw covariances for mgs_vdb_alpha_field_cov. */
static void torus_scene(size_t n, float *mean, float *cov, float *alpha, float *sig_t) {
  const double area = 4 * M_PI * M_PI * TOR_R * TOR_r, rho = n / area;
  const double st = sqrt(4.0 / (2 * M_PI * rho)), sn = st / 4;
  *sig_t = (float)st;
  mgs_rng r;
  mgs_rng_init(&r, 2024, 0);
  for (size_t i = 0; i < n;) {
    double u = 2 * M_PI * mgs_rng_uniform(&r), v = 2 * M_PI * mgs_rng_uniform(&r);
    if (mgs_rng_uniform(&r) * (TOR_R + TOR_r) > TOR_R + TOR_r * cos(v)) continue; /* area weight */
    double nn[3] = {cos(v) * cos(u), cos(v) * sin(u), sin(v)};
    mean[3 * i] = (float)((TOR_R + TOR_r * cos(v)) * cos(u));
    mean[3 * i + 1] = (float)((TOR_R + TOR_r * cos(v)) * sin(u));
    mean[3 * i + 2] = (float)(TOR_r * sin(v));
    /* Σ = st² (I - n nᵀ) + sn² n nᵀ */
    double c[6] = {st * st + (sn * sn - st * st) * nn[0] * nn[0], (sn * sn - st * st) * nn[0] * nn[1],
                   (sn * sn - st * st) * nn[0] * nn[2],         st * st + (sn * sn - st * st) * nn[1] * nn[1],
                   (sn * sn - st * st) * nn[1] * nn[2],         st * st + (sn * sn - st * st) * nn[2] * nn[2]};
    for (int k = 0; k < 6; k++) cov[6 * i + k] = (float)c[k];
    alpha[i] = 0.6f;
    i++;
  }
}

typedef struct {
  size_t n;
  int res;
  double h, t_alpha, t_sdf, peak_mib, base_mib, cpu, cpu_p2ls;
  size_t alpha_active, sdf_active, sdf_bytes, alpha_bytes;
  double dense;
  double t_p2ls, p2ls_peak_mib;
  size_t p2ls_active, p2ls_bytes, p2ls_ignored;
  int refused;
  char msg[1100];
} row;

static void run_ours(row *rw, size_t n, const float *mean, const float *cov, const float *alpha, int method, int refine) {
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = rw->h;
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.method = method;
  if (refine >= 0) sp.mesh_refine = refine;
  mgs_error err = {0};
  mgs_vdb_grid *a = NULL, *s = NULL;
  mgs_vdb_build_info info;
  rw->base_mib = status_kib("VmRSS:") / 1024;
  reset_peak();
  double c0 = cpu_seconds(), t0 = mgs_now();
  if (mgs_vdb_alpha_field_cov(n, mean, cov, alpha, &ap, &a, &info, &err) != MGS_OK) {
    rw->refused = 1;
    snprintf(rw->msg, sizeof rw->msg, "%s", err.msg);
    return;
  }
  double t1 = mgs_now();
  if (mgs_vdb_sdf_from_alpha(a, &sp, &s, &err) != MGS_OK) {
    rw->refused = 1;
    snprintf(rw->msg, sizeof rw->msg, "%s", err.msg);
    mgs_vdb_grid_destroy(a);
    return;
  }
  double t2 = mgs_now();
  rw->t_alpha = t1 - t0;
  rw->t_sdf = t2 - t1;
  rw->cpu = cpu_seconds() - c0;
  rw->peak_mib = status_kib("VmHWM:") / 1024;
  rw->alpha_active = mgs_vdb_grid_active_voxel_count(a);
  rw->alpha_bytes = mgs_vdb_grid_memory_bytes(a);
  rw->sdf_active = mgs_vdb_grid_active_voxel_count(s);
  rw->sdf_bytes = mgs_vdb_grid_memory_bytes(s);
  int32_t lo[3], hi[3];
  rw->dense = mgs_vdb_grid_active_bbox(s, lo, hi) ? (double)(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1) : 0;
  mgs_vdb_grid_destroy(a);
  mgs_vdb_grid_destroy(s);
}

/* OpenVDB's ParticlesToLevelSet on spheres at the same positions and voxel size, radius
 * 2σt (the disc's visible radius) but at least OpenVDB's 1.5-voxel minimum. */
static void run_p2ls(row *rw, size_t n, const float *mean, float sig_t) {
  mgs_error err = {0};
  float *rad = malloc(n * sizeof(float));
  if (!rad) return;
  for (size_t i = 0; i < n; i++) rad[i] = (float)fmax(2.0 * sig_t, 1.51 * rw->h);
  reset_peak();
  double c0 = cpu_seconds(), t0 = mgs_now();
  mgs_vdb_grid *p = NULL;
  if (mgs_vdb_particles_to_level_set(n, mean, rad, rw->h, 3, &p, &rw->p2ls_ignored, &err) == MGS_OK) {
    rw->t_p2ls = mgs_now() - t0;
    rw->cpu_p2ls = cpu_seconds() - c0;
    rw->p2ls_peak_mib = status_kib("VmHWM:") / 1024;
    rw->p2ls_active = mgs_vdb_grid_active_voxel_count(p);
    rw->p2ls_bytes = mgs_vdb_grid_memory_bytes(p);
  }
  mgs_vdb_grid_destroy(p);
  free(rad);
}

/* part: 1 = ours, 2 = OpenVDB's ParticlesToLevelSet. */
static void run_case(row *rw, size_t n, int res, const float *mean, const float *cov, const float *alpha, float sig_t,
                     int method, int refine, int part) {
  memset(rw, 0, sizeof *rw);
  rw->n = n;
  rw->res = res;
  rw->h = 2 * (TOR_R + TOR_r) / res;
  if (part == 1) run_ours(rw, n, mean, cov, alpha, method, refine);
  else run_p2ls(rw, n, mean, sig_t);
}

/* Each part in a forked child: freed heap stays in a process's RSS, so a case run after a
 * larger one would report the larger one's peak. The parent never starts TBB (the scene is
 * made serially), so each child starts its own scheduler. */
static void run_case_forked(row *rw, size_t n, int res, const float *mean, const float *cov, const float *alpha,
                            float sig_t, int method, int refine, int part) {
  int fds[2];
  if (pipe(fds) != 0) { run_case(rw, n, res, mean, cov, alpha, sig_t, method, refine, part); return; }
  fflush(stdout);
  fflush(stderr);
  pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    run_case(rw, n, res, mean, cov, alpha, sig_t, method, refine, part);
    return;
  }
  if (pid == 0) {
    close(fds[0]);
    row cr;
    run_case(&cr, n, res, mean, cov, alpha, sig_t, method, refine, part);
    const char *b = (const char *)&cr;
    for (size_t off = 0; off < sizeof cr;) {
      ssize_t k = write(fds[1], b + off, sizeof cr - off);
      if (k <= 0) break;
      off += (size_t)k;
    }
    close(fds[1]);
    _exit(0);
  }
  close(fds[1]);
  size_t got = 0;
  while (got < sizeof *rw) {
    ssize_t k = read(fds[0], (char *)rw + got, sizeof *rw - got);
    if (k <= 0) break;
    got += (size_t)k;
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (got != sizeof *rw) {
    memset(rw, 0, sizeof *rw);
    rw->n = n;
    rw->res = res;
    rw->h = 2 * (TOR_R + TOR_r) / res;
    rw->refused = 1;
    snprintf(rw->msg, sizeof rw->msg, "the measuring process failed (status %d)", status);
  }
}

int mgs_bench_vdb(int argc, char **argv) {
  static const struct option opts[] = {{"quick", no_argument, 0, 'q'}, {"sweep", no_argument, 0, 's'}, {"sdf-method", required_argument, 0, 'M'},
                                       {"sizes", required_argument, 0, 'n'}, {"res", required_argument, 0, 'r'}, {"refine", required_argument, 0, 'f'},
                                       {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
  mgs_vdb_sdf_params defaults;
  mgs_vdb_sdf_params_default(&defaults);
  int quick = 0, c, method = (int)defaults.method, refine = -1;
  const char *sizes = NULL, *resl = NULL;
  optind = 1;
  while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
    if (c == 'q') quick = 1;
    else if (c == 's') method = MGS_VDB_SDF_SWEEP;
    else if (c == 'M') {
      if (!strcmp(optarg, "mesh")) method = MGS_VDB_SDF_MESH;
      else if (!strcmp(optarg, "sweep")) method = MGS_VDB_SDF_SWEEP;
      else if (!strcmp(optarg, "closest")) method = MGS_VDB_SDF_CLOSEST;
      else { fprintf(stderr, "morsegs bench vdb: --sdf-method '%s': expected closest, mesh or sweep\n", optarg); return 2; }
    }
    else if (c == 'n') sizes = optarg;
    else if (c == 'r') resl = optarg;
    else if (c == 'f') refine = atoi(optarg);
    else if (c == 'h') {
      printf("usage: morsegs bench vdb [--quick] [--sdf-method closest|mesh|sweep] [--sweep] [--sizes 100000,1000000]\n"
             "                         [--res 256,512,1024] [--refine 0|1|2]\n"
             "  α-field + SDF of Gaussians on a torus vs OpenVDB ParticlesToLevelSet; --quick: 100k at 256³ only;\n"
             "  --sdf-method: SDF construction (default: the library's); --sweep = --sdf-method sweep;\n"
             "  --refine: mesh refinement of --sdf-method mesh\n");
      return 0;
    } else return 2;
  }
  size_t ns[8];
  int nn = 0, rs[8], nr = 0;
  if (sizes) {
    char *dup = strdup(sizes), *save = NULL;
    for (char *t = strtok_r(dup, ",", &save); t && nn < 8; t = strtok_r(NULL, ",", &save)) ns[nn++] = (size_t)atof(t);
    free(dup);
  } else if (quick) ns[nn++] = 100000;
  else { ns[nn++] = 100000; ns[nn++] = 1000000; }
  if (resl) {
    char *dup = strdup(resl), *save = NULL;
    for (char *t = strtok_r(dup, ",", &save); t && nr < 8; t = strtok_r(NULL, ",", &save)) rs[nr++] = atoi(t);
    free(dup);
  } else if (quick) rs[nr++] = 256;
  else { rs[nr++] = 256; rs[nr++] = 512; rs[nr++] = 1024; }
  for (int i = 0; i < nn; i++) if (ns[i] < 1 || ns[i] > 100000000) { fprintf(stderr, "morsegs bench vdb: bad size\n"); return 2; }
  for (int i = 0; i < nr; i++) if (rs[i] < 8 || rs[i] > 8192) { fprintf(stderr, "morsegs bench vdb: bad resolution\n"); return 2; }

  if (method == MGS_VDB_SDF_MESH)
    printf("# morsegs bench vdb: %d threads, SDF method mesh (refine %d)\n", mgs_parallel_max_threads(), refine < 0 ? 2 : refine);
  else
    printf("# morsegs bench vdb: %d threads, SDF method %s\n", mgs_parallel_max_threads(),
           method == MGS_VDB_SDF_SWEEP ? "sweep" : "closest");
  printf("| Gaussians | eff. res | voxel | α-field s | SDF s | total s (CPU s) | peak RSS MiB | α active | SDF active (dense bbox) | SDF B/active | α+SDF B/active | P2LS s (CPU s) | P2LS peak MiB | P2LS active | P2LS B/active |\n");
  printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  fflush(stdout);
  for (int i = 0; i < nn; i++) {
    size_t n = ns[i];
    float *mean = malloc(n * 3 * sizeof(float)), *cov = malloc(n * 6 * sizeof(float)), *alpha = malloc(n * sizeof(float));
    if (!mean || !cov || !alpha) { fprintf(stderr, "morsegs bench vdb: out of memory\n"); return 1; }
    float sig_t;
    torus_scene(n, mean, cov, alpha, &sig_t);
    for (int j = 0; j < nr; j++) {
      row rw, rp;
      run_case_forked(&rw, n, rs[j], mean, cov, alpha, sig_t, method, refine, 1);
      run_case_forked(&rp, n, rs[j], mean, cov, alpha, sig_t, method, refine, 2);
      rw.t_p2ls = rp.t_p2ls;
      rw.cpu_p2ls = rp.cpu_p2ls;
      rw.p2ls_peak_mib = rp.p2ls_peak_mib;
      rw.p2ls_active = rp.p2ls_active;
      rw.p2ls_bytes = rp.p2ls_bytes;
      rw.p2ls_ignored = rp.p2ls_ignored;
      if (rw.refused) {
        printf("| %zu | %d³ | %.5f | refused: %s |\n", n, rs[j], rw.h, rw.msg);
        continue;
      }
      printf("| %zu | %d³ | %.5f (σt %.2f vox) | %.2f | %.2f | %.2f (%.2f) | %.0f | %zu | %zu (%.3g, %.2f %%) | %.1f | %.1f | %.2f (%.2f) | %.0f | %zu%s | %.1f |\n",
             n, rs[j], rw.h, sig_t / rw.h, rw.t_alpha, rw.t_sdf, rw.t_alpha + rw.t_sdf, rw.cpu, rw.peak_mib, rw.alpha_active,
             rw.sdf_active, rw.dense, rw.dense > 0 ? 100.0 * rw.sdf_active / rw.dense : 0.0,
             rw.sdf_active ? (double)rw.sdf_bytes / rw.sdf_active : 0.0,
             rw.sdf_active ? (double)(rw.sdf_bytes + rw.alpha_bytes) / (rw.sdf_active + rw.alpha_active) : 0.0, rw.t_p2ls, rw.cpu_p2ls,
             rw.p2ls_peak_mib, rw.p2ls_active, rw.p2ls_ignored ? " (some ignored)" : "",
             rw.p2ls_active ? (double)rw.p2ls_bytes / rw.p2ls_active : 0.0);
      fflush(stdout);
    }
    free(mean);
    free(cov);
    free(alpha);
  }
  return 0;
}
