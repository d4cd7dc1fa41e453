/* What `morsegs experiment` records (measure/mgs_measure.h), without the command: run
 * records written and read back, and the ground-truth SDF topology of meshes of known
 * genus (sphere: Betti (1,0,0); torus: (1,1,0)). */
#include <math.h>
#include "mgs_test.h"
#include "measure/mgs_measure.h"
#include "core/mgs_core.h"

static void fill_run(exp_run *r, const char *var, int seed, double factor, double psnr, double gaussians, double chamfer,
                     double floaters) {
  memset(r, 0, sizeof *r);
  snprintf(r->dataset, sizeof r->dataset, "toy");
  snprintf(r->variant, sizeof r->variant, "%s", var);
  r->seed = seed;
  r->factor = factor;
  r->iters = 100;
  r->train_seconds = 10 + seed;
  r->analysis_seconds = NAN;
  r->n_points = 2;
  for (int k = 0; k < 2; k++) {
    exp_point *p = &r->pt[k];
    p->iteration = 50 * (k + 1);
    p->wall_seconds = r->train_seconds * (k + 1) / 2;
    p->psnr = psnr - (1 - k);
    p->ssim = 0.9;
    p->gaussians = gaussians;
    p->chamfer = chamfer * (k ? 1 : 1.5);
    p->fscore = 0.5;
    p->floaters = floaters;
    p->floaters_fraction = floaters / gaussians;
    p->floater_mass = floaters * 0.1;
    p->floater_mass_fraction = 0.01;
    for (int q = 0; q < 3; q++) p->betti[q] = p->betti_persistent[q] = q == 0;
    p->bottleneck = k ? INFINITY : 0.05;
  }
}

static void test_run_record(void) {
  const char *dir = mgs_test_tmpdir("exp_record");
  exp_run a, b;
  fill_run(&a, "baseline", 2, 0.5, 25.0, 1234, 0.01, 7);
  a.pt[0].chamfer = NAN;
  char path[512];
  snprintf(path, sizeof path, "%s/result.json", dir);
  mgs_error err;
  CHECK_OK(exp_run_write(path, &a, &err), &err);
  CHECK_OK(exp_run_read(path, &b, &err), &err);
  CHECK(!strcmp(b.variant, "baseline") && b.seed == 2 && b.factor == 0.5 && b.iters == 100 && b.n_points == 2);
  CHECK(isnan(b.pt[0].chamfer) && isnan(b.analysis_seconds));
  CHECK(isinf(b.pt[1].bottleneck) && b.pt[0].bottleneck == 0.05);
  CHECK(b.pt[1].psnr == a.pt[1].psnr && b.pt[1].gaussians == 1234 && b.pt[1].betti[0] == 1 && b.pt[1].betti[1] == 0);
  /* a damaged record is refused (the run is then redone) */
  CHECK_OK(mgs_write_file_atomic(path, "{\"format\":\"x\"}", 14, &err), &err);
  CHECK(exp_run_read(path, &b, &err) == MGS_ERR_FORMAT);
}

/* A torus (R, r) or a UV sphere (R, r = 0) as a closed triangle mesh. */
static mgs_mesh *make_mesh(double R, double r, int nu, int nv) {
  int sphere = r == 0;
  size_t nvert = sphere ? (size_t)(nu * (nv - 1) + 2) : (size_t)(nu * nv);
  size_t ntri = sphere ? (size_t)(2 * nu * (nv - 1)) : (size_t)(2 * nu * nv);
  mgs_mesh *m = mgs_mesh_create(nvert, ntri);
  size_t t = 0;
  if (!sphere) {
    for (int i = 0; i < nu; i++)
      for (int j = 0; j < nv; j++) {
        double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
        float *p = m->v + 3 * (size_t)(i * nv + j);
        p[0] = (float)((R + r * cos(v)) * cos(u)); p[1] = (float)((R + r * cos(v)) * sin(u)); p[2] = (float)(r * sin(v));
        uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(((i + 1) % nu) * nv + j), c = (uint32_t)(((i + 1) % nu) * nv + (j + 1) % nv),
                 d = (uint32_t)(i * nv + (j + 1) % nv);
        uint32_t *q = m->t + 3 * t;
        q[0] = a; q[1] = b; q[2] = c; q[3] = a; q[4] = c; q[5] = d;
        t += 2;
      }
  } else {
    /* vertices: rings 1..nv-1, then the poles */
    for (int j = 1; j < nv; j++)
      for (int i = 0; i < nu; i++) {
        double th = M_PI * j / nv, ph = 2 * M_PI * i / nu;
        float *p = m->v + 3 * (size_t)((j - 1) * nu + i);
        p[0] = (float)(R * sin(th) * cos(ph)); p[1] = (float)(R * sin(th) * sin(ph)); p[2] = (float)(R * cos(th));
      }
    uint32_t top = (uint32_t)(nu * (nv - 1)), bot = top + 1;
    m->v[3 * top] = 0; m->v[3 * top + 1] = 0; m->v[3 * top + 2] = (float)R;
    m->v[3 * bot] = 0; m->v[3 * bot + 1] = 0; m->v[3 * bot + 2] = (float)-R;
    for (int i = 0; i < nu; i++) {
      uint32_t a = (uint32_t)i, b = (uint32_t)((i + 1) % nu);
      uint32_t *q = m->t + 3 * t++;
      q[0] = top; q[1] = a; q[2] = b;
      for (int j = 1; j + 1 < nv; j++) {
        uint32_t p0 = (uint32_t)((j - 1) * nu + i), p1 = (uint32_t)((j - 1) * nu + (i + 1) % nu);
        uint32_t p2 = (uint32_t)(j * nu + (i + 1) % nu), p3 = (uint32_t)(j * nu + i);
        q = m->t + 3 * t;
        q[0] = p0; q[1] = p3; q[2] = p2; q[3] = p0; q[4] = p2; q[5] = p1;
        t += 2;
      }
      q = m->t + 3 * t++;
      q[0] = bot; q[1] = (uint32_t)((nv - 2) * nu + (i + 1) % nu); q[2] = (uint32_t)((nv - 2) * nu + i);
    }
  }
  return m;
}

static void check_truth(const char *name, mgs_mesh *m, const int want[3]) {
  const char *dir = mgs_test_tmpdir(name);
  char path[512];
  snprintf(path, sizeof path, "%s/mesh.ply", dir);
  mgs_error err;
  CHECK_OK(mgs_mesh_write(path, m, &err), &err);
  exp_truth t;
  CHECK_OK(exp_truth_build(path, 64, dir, &t, &err), &err);
  CHECK_MSG(t.betti_persistent[0] == want[0] && t.betti_persistent[1] == want[1] && t.betti_persistent[2] == want[2],
            "%s: persistent Betti (%d, %d, %d), want (%d, %d, %d)", name, t.betti_persistent[0], t.betti_persistent[1],
            t.betti_persistent[2], want[0], want[1], want[2]);
  CHECK(t.voxel > 0 && t.band >= 3 && t.half_width >= t.pers_threshold);
  snprintf(path, sizeof path, "%s/gt_diagram.json", dir);
  CHECK(mgs_path_exists(path));
  exp_truth_free(&t);
  /* no mesh: nothing measured, not an error */
  CHECK_OK(exp_truth_build(NULL, 64, NULL, &t, &err), &err);
  CHECK(t.diagram == NULL && t.betti[0] == -1);
  exp_truth_free(&t);
}

static void test_truth_topology(void) {
  mgs_mesh *s = make_mesh(1.0, 0, 48, 24), *t = make_mesh(1.0, 0.4, 64, 32);
  const int ws[3] = {1, 0, 0}, wt[3] = {1, 1, 0};
  check_truth("exp_sphere", s, ws);
  check_truth("exp_torus", t, wt);
  mgs_mesh_destroy(s);
  mgs_mesh_destroy(t);
  /* Betti numbers at level 0 from a hand-made diagram */
  mgs_diagram *d = mgs_diagram_create();
  mgs_pair p;
  memset(&p, 0, sizeof p);
  mgs_error err;
  p.dim = 0; p.birth = -0.5; p.death = INFINITY; mgs_diagram_push(d, &p, &err);
  p.dim = 1; p.birth = -0.01; p.death = 0.02; mgs_diagram_push(d, &p, &err);  /* short tunnel */
  p.dim = 1; p.birth = -0.3; p.death = 0.4; mgs_diagram_push(d, &p, &err);   /* long tunnel */
  p.dim = 2; p.birth = 0.1; p.death = 0.3; mgs_diagram_push(d, &p, &err);    /* born after 0 */
  p.dim = 0; p.birth = -0.2; p.death = 0.0; mgs_diagram_push(d, &p, &err);   /* dies at 0 */
  int all[3], per[3];
  exp_betti_at_zero(d, 0.1, all, per);
  CHECK(all[0] == 1 && all[1] == 2 && all[2] == 0);
  CHECK(per[0] == 1 && per[1] == 1 && per[2] == 0);
  mgs_diagram_destroy(d);
}

int main(void) {
  RUN(test_run_record);
  RUN(test_truth_topology);
  return mgs_test_finish();
}
