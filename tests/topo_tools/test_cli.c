/* `morsegs persistence` end to end: .vdb files written here through the vdb module's API
 * (solid torus, torus shell, sphere shell level sets; a fog torus), Betti numbers and
 * outputs checked, the diagram compared with the engine's dense result on the same clamped
 * field; --force; bad input (missing file, missing grid, vector grid, not a .vdb, broken
 * narrow bands): one-line error naming the file, exit 1, no output directory. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include "mgs_test.h"
#include "core/mgs_fs.h"
#include "core/mgs_rng.h"
#include "topo/mgs_levelset_check.h"
#include "topo/mgs_diagram_tools.h"
#include "topo/mgs_persistence.h"
#include "vdb/mgs_vdb.h"

#define N 40
static const double H = 1.0 / N;
static const char *cli;
static const char *dir;

typedef double (*shape_fn)(double x, double y, double z);
static double torus(double x, double y, double z) {
  x -= 0.5; y -= 0.5; z -= 0.5;
  double q = sqrt(x * x + y * y) - 0.3;
  return sqrt(q * q + z * z) - 0.1;
}
static double torus_shell(double x, double y, double z) { return fabs(torus(x, y, z)) - 0.03; }
static double sphere_shell(double x, double y, double z) {
  x -= 0.5; y -= 0.5; z -= 0.5;
  return fabs(sqrt(x * x + y * y + z * z) - 0.3) - 0.06;
}

static float *sample(shape_fn f, double clamp) {
  float *v = malloc((size_t)N * N * N * sizeof *v);
  for (int i = 0; i < N; i++)
    for (int j = 0; j < N; j++)
      for (int k = 0; k < N; k++) {
        double d = f(i * H, j * H, k * H);
        v[((size_t)i * N + j) * N + k] = (float)fmin(fmax(d, -clamp), clamp);
      }
  return v;
}

static void write_grid(const char *path, mgs_vdb_grid *g) {
  mgs_error e;
  const mgs_vdb_grid *gs[1] = {g};
  CHECK_OK(mgs_vdb_write(path, gs, 1, NULL, 0, NULL, &e), &e);
}

static mgs_vdb_grid *level_set(const float *v, float bg) {
  int32_t origin[3] = {0, 0, 0}, dims[3] = {N, N, N};
  mgs_vdb_grid *g = NULL;
  mgs_error e;
  CHECK_OK(mgs_vdb_grid_from_dense("sdf", MGS_VDB_CLASS_LEVEL_SET, H, NULL, bg, origin, dims, v, &g, &e), &e);
  return g;
}

/* Runs the CLI; returns the exit code, stderr's first line in msg. */
static int run(const char *args, char *msg, size_t msg_size) {
  char cmd[8192], errf[4300];
  snprintf(errf, sizeof errf, "%s/stderr.txt", dir);
  snprintf(cmd, sizeof cmd, "'%s' persistence %s > '%s/stdout.txt' 2> '%s'", cli, args, dir, errf);
  int rc = system(cmd);
  rc = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  msg[0] = 0;
  FILE *f = fopen(errf, "r");
  if (f) {
    char line[4096];
    int nlines = 0;
    while (fgets(line, sizeof line, f)) {
      if (nlines == 0) snprintf(msg, msg_size, "%s", line);
      nlines++;
    }
    fclose(f);
    if (nlines > 1) snprintf(msg, msg_size, "MORE THAN ONE LINE");
  }
  return rc;
}

static int read_betti(const char *out, int b[3]) {
  char path[4400];
  snprintf(path, sizeof path, "%s/betti.txt", out);
  FILE *f = fopen(path, "r");
  if (!f) return 0;
  char line[512];
  int got = 0;
  while (fgets(line, sizeof line, f)) {
    int k, v;
    if (sscanf(line, "b%d %d", &k, &v) == 2 && k >= 0 && k <= 2) { b[k] = v; got++; }
  }
  fclose(f);
  return got == 3;
}

static int has_prefix(const char *path, const void *sig, size_t n) {
  unsigned char buf[16] = {0};
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  size_t got = fread(buf, 1, n, f);
  fclose(f);
  return got == n && !memcmp(buf, sig, n);
}

/* The outputs exist and agree with each other and with the engine's dense result. */
static void check_outputs(const char *out, const mgs_diagram *ref, int superlevel) {
  static const unsigned char png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static const unsigned char vdb_sig[4] = {0x20, 0x42, 0x44, 0x56}; /* OpenVDB magic, little endian */
  char p[4400];
  snprintf(p, sizeof p, "%s/diagram.png", out); CHECK(has_prefix(p, png_sig, 8));
  snprintf(p, sizeof p, "%s/barcode.png", out); CHECK(has_prefix(p, png_sig, 8));
  snprintf(p, sizeof p, "%s/diagram.svg", out); CHECK(has_prefix(p, "<?xml", 5));
  snprintf(p, sizeof p, "%s/barcode.svg", out); CHECK(has_prefix(p, "<?xml", 5));
  snprintf(p, sizeof p, "%s/critical.vdb", out); CHECK(has_prefix(p, vdb_sig, 4));
  /* the point grid is named "critical" and holds one point per pair (vdb_print, Debian's
   * libopenvdb-tools, is an independent reader) */
  mgs_diagram *t = NULL, *j = NULL;
  mgs_error e;
  char tp[4400], jp[4400];
  snprintf(tp, sizeof tp, "%s/diagram.txt", out);
  snprintf(jp, sizeof jp, "%s/diagram.json", out);
  CHECK_OK(mgs_diagram_read_text(tp, &t, &e), &e);
  CHECK_OK(mgs_diagram_read_json(jp, &j, &e), &e);
  if (!t || !j) { mgs_diagram_destroy(t); mgs_diagram_destroy(j); return; }
  CHECK(t->n == j->n && t->n > 0);
  for (size_t i = 0; i < t->n && i < j->n; i++)
    CHECK(t->pairs[i].dim == j->pairs[i].dim && t->pairs[i].birth == j->pairs[i].birth && t->pairs[i].death == j->pairs[i].death);
  char cmd[9000];
  snprintf(cmd, sizeof cmd, "vdb_print -l '%s/critical.vdb' 2>&1 | grep -q 'critical'", out);
  CHECK_MSG(system(cmd) == 0, "vdb_print does not list a grid 'critical'");
  if (ref) {
    /* the CLI's diagram (negated back for superlevel) = the engine on the dense field */
    mgs_diagram *r = mgs_diagram_create();
    for (size_t i = 0; i < ref->n; i++) {
      mgs_pair q = ref->pairs[i];
      if (superlevel) { q.birth = -q.birth; q.death = -q.death; }
      mgs_diagram_push(r, &q, NULL);
    }
    double bd = -1;
    CHECK_OK(mgs_diagram_bottleneck(t, r, MGS_DIM_ALL, &bd, &e), &e);
    CHECK_MSG(bd < 1e-6, "CLI diagram differs from the dense engine result: bottleneck %g", bd);
    size_t pa[3], pb[3], ea, eb;
    mgs_diagram_counts(t, pa, &ea, NULL);
    mgs_diagram_counts(r, pb, &eb, NULL);
    CHECK(ea == eb);
    mgs_diagram_destroy(r);
  }
  /* betti.txt agrees with the diagram */
  int b[3] = {-1, -1, -1}, bt[3];
  CHECK(read_betti(out, b));
  if (superlevel) mgs_diagram_betti_superlevel(t, 0.5, bt); else mgs_diagram_betti(t, 0.0, bt);
  CHECK(b[0] == bt[0] && b[1] == bt[1] && b[2] == bt[2]);
  mgs_diagram_destroy(t);
  mgs_diagram_destroy(j);
}

static void case_level_set(const char *name, shape_fn f, int b0, int b1, int b2) {
  float bg = (float)(3 * H);
  float *v = sample(f, bg);
  mgs_vdb_grid *g = level_set(v, bg);
  char in[4400], out[4400], args[9000], msg[4096];
  snprintf(in, sizeof in, "%s/%s.vdb", dir, name);
  snprintf(out, sizeof out, "%s/%s_out", dir, name);
  write_grid(in, g);
  snprintf(args, sizeof args, "'%s' -o '%s'", in, out);
  int rc = run(args, msg, sizeof msg);
  CHECK_MSG(rc == 0, "%s: exit %d: %s", name, rc, msg);
  int b[3] = {-1, -1, -1};
  CHECK_MSG(read_betti(out, b) && b[0] == b0 && b[1] == b1 && b[2] == b2, "%s: Betti %d %d %d, expected %d %d %d",
            name, b[0], b[1], b[2], b0, b1, b2);
  /* reference: the engine on the dense clamped field */
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.half_width = bg;
  o.voxel_size = H;
  mgs_diagram *ref = NULL;
  mgs_error e;
  CHECK_OK(mgs_topo_persistence_dense(v, N, N, N, &o, &ref, &e), &e);
  check_outputs(out, ref, 0);
  mgs_diagram_destroy(ref);
  /* T construction: same Betti numbers for these well-resolved shapes */
  char outT[4500];
  snprintf(outT, sizeof outT, "%s_T", out);
  snprintf(args, sizeof args, "'%s' -o '%s' --construction T --min-persistence 0.001", in, outT);
  rc = run(args, msg, sizeof msg);
  CHECK_MSG(rc == 0, "%s T: exit %d: %s", name, rc, msg);
  CHECK_MSG(read_betti(outT, b) && b[0] == b0 && b[1] == b1 && b[2] == b2, "%s T: Betti %d %d %d", name, b[0], b[1], b[2]);
  mgs_vdb_grid_destroy(g);
  free(v);
}

static void test_level_sets(void) {
  case_level_set("torus", torus, 1, 1, 0);
  case_level_set("torus_shell", torus_shell, 1, 2, 1);
  case_level_set("sphere_shell", sphere_shell, 1, 0, 1);
}

static void test_fog(void) {
  float *v = malloc((size_t)N * N * N * sizeof *v);
  for (int i = 0; i < N; i++)
    for (int j = 0; j < N; j++)
      for (int k = 0; k < N; k++) {
        double d = torus(i * H, j * H, k * H);
        double rho = 1.0 / (1.0 + exp(d / H)); /* 0.5 on the surface */
        v[((size_t)i * N + j) * N + k] = rho < 1e-3 ? 0.0f : (float)rho;
      }
  int32_t origin[3] = {0, 0, 0}, dims[3] = {N, N, N};
  mgs_vdb_grid *g = NULL;
  mgs_error e;
  CHECK_OK(mgs_vdb_grid_from_dense("density", MGS_VDB_CLASS_FOG, H, NULL, 0.0f, origin, dims, v, &g, &e), &e);
  char in[4400], out[4400], args[9000], msg[4096];
  snprintf(in, sizeof in, "%s/fog.vdb", dir);
  snprintf(out, sizeof out, "%s/fog_out", dir);
  write_grid(in, g);
  snprintf(args, sizeof args, "'%s' -o '%s'", in, out);
  int rc = run(args, msg, sizeof msg);
  CHECK_MSG(rc == 0, "fog: exit %d: %s", rc, msg);
  int b[3] = {-1, -1, -1};
  CHECK_MSG(read_betti(out, b) && b[0] == 1 && b[1] == 1 && b[2] == 0, "fog: Betti %d %d %d", b[0], b[1], b[2]);
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.filtration = MGS_TOPO_SUPERLEVEL;
  o.voxel_size = H;
  mgs_diagram *ref = NULL;
  CHECK_OK(mgs_topo_persistence_dense(v, N, N, N, &o, &ref, &e), &e);
  check_outputs(out, ref, 1);
  /* superlevel diagrams hold density values with birth ≥ death */
  char tp[4500];
  snprintf(tp, sizeof tp, "%s/diagram.txt", out);
  mgs_diagram *t = NULL;
  CHECK_OK(mgs_diagram_read_text(tp, &t, &e), &e);
  int ok = t != NULL;
  for (size_t i = 0; t && i < t->n; i++) ok &= t->pairs[i].birth >= t->pairs[i].death && t->pairs[i].birth <= 1.0f;
  CHECK(ok);
  mgs_diagram_destroy(t);
  mgs_diagram_destroy(ref);
  mgs_vdb_grid_destroy(g);
  free(v);
}

static void test_force_and_usage(void) {
  char in[4400], out[4400], args[9000], msg[4096];
  snprintf(in, sizeof in, "%s/torus.vdb", dir);
  snprintf(out, sizeof out, "%s/torus_out", dir);
  char betti[4500];
  snprintf(betti, sizeof betti, "%s/betti.txt", out);
  mgs_error e;
  CHECK_OK(mgs_mkdir_p(out, &e), &e);
  CHECK_OK(mgs_write_file_atomic(betti, "user data\n", 10, &e), &e);
  snprintf(args, sizeof args, "'%s' -o '%s'", in, out);
  CHECK(run(args, msg, sizeof msg) == 1 && strstr(msg, "exists") && strstr(msg, "--force"));
  char *data; size_t size;
  CHECK_OK(mgs_read_file(betti, &data, &size, &e), &e);
  CHECK(size == 10 && !memcmp(data, "user data\n", 10)); /* untouched */
  free(data);
  snprintf(args, sizeof args, "'%s' -o '%s' --force", in, out);
  CHECK(run(args, msg, sizeof msg) == 0);
  int b[3];
  CHECK(read_betti(out, b) && b[0] == 1 && b[1] == 1);
  /* no staging directory left behind */
  char cmd[9000];
  snprintf(cmd, sizeof cmd, "ls -a '%s' | grep -q staging", out);
  CHECK(system(cmd) != 0);
  CHECK(run("", msg, sizeof msg) == 2);
  snprintf(args, sizeof args, "'%s' --construction X", in);
  CHECK(run(args, msg, sizeof msg) == 2);
  snprintf(args, sizeof args, "'%s' --band -1", in);
  CHECK(run(args, msg, sizeof msg) == 2);
  CHECK(run("--help", msg, sizeof msg) == 0);
  /* a level set cannot be read with --superlevel */
  snprintf(args, sizeof args, "'%s' -o '%s/never' --superlevel", in, dir);
  CHECK(run(args, msg, sizeof msg) == 1 && strstr(msg, "level set"));
}

/* Bad input: exit 1, one line naming the file and the problem, no output directory. */
static void expect_fail(const char *in, const char *extra, const char *needle) {
  char out[4400], args[9000], msg[4096];
  snprintf(out, sizeof out, "%s/bad_out", dir);
  snprintf(args, sizeof args, "'%s' -o '%s' %s", in, out, extra);
  int rc = run(args, msg, sizeof msg);
  CHECK_MSG(rc == 1, "%s %s: exit %d", in, extra, rc);
  CHECK_MSG(strstr(msg, in) != NULL, "message does not name %s: %s", in, msg);
  CHECK_MSG(strstr(msg, needle) != NULL, "message lacks '%s': %s", needle, msg);
  CHECK_MSG(!mgs_path_exists(out), "%s: output directory created", in);
}

static void test_bad_input(void) {
  char p[4400];
  snprintf(p, sizeof p, "%s/does_not_exist.vdb", dir);
  expect_fail(p, "", "no such file");
  snprintf(p, sizeof p, "%s/torus.vdb", dir);
  expect_fail(p, "--grid nope", "no grid named 'nope'");
  snprintf(p, sizeof p, "%s/garbage.vdb", dir);
  mgs_error e;
  CHECK_OK(mgs_write_file_atomic(p, "not a vdb\n", 10, &e), &e);
  expect_fail(p, "", "vdb");
  /* a vector grid, written by python3-openvdb (independent of our writer) */
  snprintf(p, sizeof p, "%s/vector.vdb", dir);
  char cmd[9000];
  snprintf(cmd, sizeof cmd,
           "/usr/bin/python3 -c \"import pyopenvdb as v; g=v.Vec3SGrid(); g.name='vel'; "
           "g.getAccessor().setValueOn((1,2,3),(1.0,0.0,0.0)); v.write('%s', grids=[g])\"", p);
  CHECK_MSG(system(cmd) == 0, "python3-openvdb could not write a vector grid");
  expect_fail(p, "--grid vel", "not float");
  expect_fail(p, "", "no float grid");

  float bg = (float)(3 * H);
  float *v = sample(torus, bg);
  /* 1. an active voxel deep inside with the wrong sign */
  mgs_vdb_grid *g = level_set(v, bg);
  int32_t deep[3] = {(int32_t)(0.8 * N), N / 2, N / 2}; /* tube centre: (0.8, 0.5, 0.5) */
  mgs_vdb_set_value(g, deep, 0.5f * bg, 1);
  snprintf(p, sizeof p, "%s/wrong_sign.vdb", dir);
  write_grid(p, g);
  expect_fail(p, "", "broken narrow band");
  mgs_vdb_grid_destroy(g);
  /* 2. a band value beyond the background */
  g = level_set(v, bg);
  int32_t surf[3] = {(int32_t)(0.9 * N), N / 2, N / 2}; /* on the outer surface */
  mgs_vdb_set_value(g, surf, 10 * bg, 1);
  snprintf(p, sizeof p, "%s/clipped.vdb", dir);
  write_grid(p, g);
  expect_fail(p, "", "lies beyond +-background");
  mgs_vdb_grid_destroy(g);
  /* 3. interior never sign-filled: everything below -bg stored as +bg */
  for (size_t i = 0; i < (size_t)N * N * N; i++) if (v[i] <= -bg) v[i] = bg;
  g = level_set(v, bg);
  snprintf(p, sizeof p, "%s/unfilled.vdb", dir);
  write_grid(p, g);
  expect_fail(p, "", "broken narrow band");
  mgs_vdb_grid_destroy(g);
  free(v);
}

/* Real OpenVDB level sets (the vdb module's α-field → SDF, both methods) pass the
 * narrow-band check and give the expected topology: a solid ball of Gaussians → 1, 0, 0. */
static void test_real_level_set(void) {
  const size_t n = 400;
  float *mean = malloc(n * 3 * sizeof *mean), *cov = malloc(n * 6 * sizeof *cov), *alpha = malloc(n * sizeof *alpha);
  mgs_rng r;
  mgs_rng_init(&r, 99, 2);
  for (size_t i = 0; i < n; i++) {
    double x, y, z;
    do { x = 2 * mgs_rng_uniform(&r) - 1; y = 2 * mgs_rng_uniform(&r) - 1; z = 2 * mgs_rng_uniform(&r) - 1; } while (x * x + y * y + z * z > 1);
    mean[3 * i] = (float)(0.3 * x); mean[3 * i + 1] = (float)(0.3 * y); mean[3 * i + 2] = (float)(0.3 * z);
    float s2 = 0.06f * 0.06f;
    cov[6 * i] = s2; cov[6 * i + 1] = 0; cov[6 * i + 2] = 0; cov[6 * i + 3] = s2; cov[6 * i + 4] = 0; cov[6 * i + 5] = s2;
    alpha[i] = 0.9f;
  }
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.resolution = 64;
  mgs_vdb_grid *a = NULL;
  mgs_error e;
  CHECK_OK(mgs_vdb_alpha_field_cov(n, mean, cov, alpha, &ap, &a, NULL, &e), &e);
  for (int method = 0; method < 2 && a; method++) {
    mgs_vdb_sdf_params sp;
    mgs_vdb_sdf_params_default(&sp);
    sp.method = (mgs_vdb_sdf_method)method;
    mgs_vdb_grid *sdf = NULL;
    CHECK_OK(mgs_vdb_sdf_from_alpha(a, &sp, &sdf, &e), &e);
    if (!sdf) continue;
    CHECK_OK(mgs_topo_check_level_set(sdf, "real", &e), &e);
    char in[4400], out[4400], args[9000], msg[4096];
    snprintf(in, sizeof in, "%s/real%d.vdb", dir, method);
    snprintf(out, sizeof out, "%s/real%d_out", dir, method);
    write_grid(in, sdf);
    snprintf(args, sizeof args, "'%s' -o '%s' --min-persistence 0.01", in, out);
    int rc = run(args, msg, sizeof msg);
    CHECK_MSG(rc == 0, "real level set (method %d): exit %d: %s", method, rc, msg);
    int b[3] = {-1, -1, -1};
    CHECK_MSG(read_betti(out, b) && b[0] == 1 && b[1] == 0 && b[2] == 0, "real level set (method %d): Betti %d %d %d",
              method, b[0], b[1], b[2]);
    mgs_vdb_grid_destroy(sdf);
  }
  mgs_vdb_grid_destroy(a);
  free(mean); free(cov); free(alpha);
}

/* A torus level set for the force/bad-input cases when run on their own. */
static void ensure_torus(void) {
  char in[4400];
  snprintf(in, sizeof in, "%s/torus.vdb", dir);
  if (mgs_path_exists(in)) return;
  float bg = (float)(3 * H);
  float *v = sample(torus, bg);
  mgs_vdb_grid *g = level_set(v, bg);
  write_grid(in, g);
  mgs_vdb_grid_destroy(g);
  free(v);
}

/* argv[1]: "all" (default), "outputs" (level sets, fog, real level sets: heavier, release
 * only) or "errors" (--force, usage and bad input: light, also run under ASan). */
int main(int argc, char **argv) {
  const char *mode = argc > 1 ? argv[1] : "all";
  int outputs_ = strcmp(mode, "errors") != 0, errors = strcmp(mode, "outputs") != 0;
  cli = getenv("MGS_CLI");
  if (!cli || !mgs_path_exists(cli)) {
    fprintf(stderr, "MGS_CLI is not set to the morsegs binary\n");
    return 1;
  }
  dir = mgs_test_tmpdir(mode);
  if (outputs_) { RUN(test_level_sets); RUN(test_fog); RUN(test_real_level_set); }
  if (errors) { ensure_torus(); RUN(test_force_and_usage); RUN(test_bad_input); }
  return mgs_test_finish();
}
