/* The α-field and SDF of a 2DGS model (surfels have no thickness: the builders give them a
 * third standard deviation of half a voxel, vdb/mgs_vdb.h). A sphere of radius 1 tiled by
 * tangent surfels, read back from a 2DGS .ply: the field reaches tau on the shell and is
 * empty inside, the SDF (CLOSEST) is a distance field between every pair of face neighbours,
 * negative on the shell and positive at the centre and outside, its zero crossings along
 * rays within two voxels of the shell (both faces of the one-voxel-thick disc sheet). Without
 * the voxel low-pass filter the same surfels still give the sheet, where the model read as
 * 3D Gaussians with its stored thickness (1e-6) leaves nothing. */
#include <math.h>
#include "band_check.h"
#include "core/mgs_gaussians.h"
#include "core/mgs_math.h"
#include "core/mgs_ply.h"
#include "mgs_test.h"
#include "vdb/mgs_vdb.h"
#include "vdb_test_util.h"

static mgs_gaussians *surfel_sphere(int n) {
  mgs_gaussians *g = mgs_gaussians_create((size_t)n, 0);
  g->kind = MGS_MODEL_2DGS;
  for (int i = 0; i < n; i++) { /* Fibonacci sphere; each surfel's normal radial */
    double z = 1 - (2.0 * i + 1) / n, r = sqrt(1 - z * z), ph = i * M_PI * (3 - sqrt(5.0));
    double nrm[3] = {r * cos(ph), r * sin(ph), z}, a[3] = {-nrm[1], nrm[0], 0}, b[3];
    if (fabs(nrm[2]) > 0.9) { a[0] = 0; a[1] = -nrm[2]; a[2] = nrm[1]; }
    mgs_normalize3d(a);
    b[0] = nrm[1] * a[2] - nrm[2] * a[1]; b[1] = nrm[2] * a[0] - nrm[0] * a[2]; b[2] = nrm[0] * a[1] - nrm[1] * a[0];
    double R[9] = {a[0], b[0], nrm[0], a[1], b[1], nrm[1], a[2], b[2], nrm[2]}, q[4];
    mgs_mat3_to_quatd(R, q);
    const double s[3] = {0.045, 0.045, 1e-6};
    vt_add(g, nrm[0], nrm[1], nrm[2], s, q, 0.9);
    g->log_scale[3 * (size_t)i + 2] = MGS_SURFEL_LOG_SCALE2;
  }
  return g;
}

static mgs_vdb_grid *alpha_of(const mgs_gaussians *g, double h, mgs_vdb_small_mode small) {
  mgs_vdb_alpha_params p;
  mgs_vdb_alpha_params_default(&p);
  p.voxel_size = h;
  p.small = small;
  mgs_vdb_grid *a = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_vdb_alpha_field(g, &p, &a, NULL, &err), &err);
  return a;
}

static float at(const mgs_vdb_grid *g, double x, double y, double z) {
  float p[3] = {(float)x, (float)y, (float)z}, v = 0;
  mgs_vdb_sample(g, 1, p, &v);
  return v;
}

static void test_sphere(void) {
  const double h = 0.04;
  mgs_gaussians *g0 = surfel_sphere(1500), *g = NULL;
  mgs_error err = {0};
  char path[4096];
  snprintf(path, sizeof path, "%s/surfels.ply", mgs_test_tmpdir("vdb_surfels"));
  CHECK_OK(mgs_ply_write_gaussians(path, g0, &err), &err);
  CHECK_OK(mgs_ply_read_gaussians(path, &g, &err), &err);
  if (!g) { mgs_gaussians_destroy(g0); return; }
  CHECK(g->kind == MGS_MODEL_2DGS);
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  ap.voxel_size = h;
  CHECK_NEAR(mgs_vdb_surfel_thickness(g, &ap), 0.5 * h, 1e-12);
  mgs_vdb_grid *a = alpha_of(g, h, MGS_VDB_SMALL_PEAK);
  if (!a) { mgs_gaussians_destroy(g); mgs_gaussians_destroy(g0); return; }
  double amin = 1e9, amax = 0;
  for (int k = 0; k < 40; k++) { /* the shell along a few directions */
    double t = 0.37 * k, d[3] = {cos(t) * sin(0.8 * t + 0.3), sin(t) * sin(0.8 * t + 0.3), cos(0.8 * t + 0.3)};
    float v = at(a, d[0], d[1], d[2]);
    amin = fmin(amin, v);
    amax = fmax(amax, v);
  }
  float ac = at(a, 0, 0, 0), ao = at(a, 0, 0, 1.0 + 4 * h);
  fprintf(stderr, "  alpha on the shell %.3g..%.3g, at the centre %.3g, 4 voxels out %.3g\n", amin, amax, ac, ao);
  CHECK(amin >= 0.5 && ac < 1e-6 && ao < 0.05);
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  sp.method = MGS_VDB_SDF_CLOSEST;
  mgs_vdb_grid *sdf = NULL;
  CHECK_OK(mgs_vdb_sdf_from_alpha(a, &sp, &sdf, &err), &err);
  if (sdf) {
    bc_report r;
    CHECK(bc_check(sdf, 1e-3, &r) == 0);
    CHECK_MSG(bc_bad(&r) == 0 && r.pairs > 0, "surfel sphere sdf: not a distance field");
    float sc = at(sdf, 0, 0, 0), ss = at(sdf, 0, 0.6, 0.8), so = at(sdf, 0, 0, 1.0 + 3 * h);
    fprintf(stderr, "  sdf: centre %+.3f, on the shell %+.3f, 3 voxels out %+.3f; %zu band voxels\n", sc, ss, so, r.active);
    CHECK(sc > 0 && ss < 0 && so > 0);
    /* both faces of the sheet lie within two voxels of the shell (overlapping surfels sum to
       alpha ~1.5: {A = 0.5} lies ~1.4 of their thickness sqrt(1/2) h off the sheet) */
    double o[3] = {0, 0, 0}, dir[3] = {0.48, -0.6, 0.64};
    double t_in = vt_ray_zero(sdf, o, dir, 0.5, 1.0), t_out = vt_ray_zero(sdf, o, dir, 1.0, 1.5);
    fprintf(stderr, "  ray: zero crossings at %.4f and %.4f (shell at 1, voxel %.2f)\n", t_in, t_out, h);
    CHECK(fabs(t_in - 1) < 2 * h && fabs(t_out - 1) < 2 * h && t_out > t_in);
  }
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(a);
  /* no low-pass filter: the surfels' own half-voxel thickness keeps the sheet; the same
     rows read as 3D Gaussians 1e-6 thick fall between the voxel centres */
  a = alpha_of(g, h, MGS_VDB_SMALL_NONE);
  g->kind = MGS_MODEL_3DGS;
  mgs_vdb_grid *a3 = alpha_of(g, h, MGS_VDB_SMALL_NONE);
  if (a && a3) {
    double m2 = 0, m3 = 0;
    for (int k = 0; k < 40; k++) {
      double t = 0.37 * k, d[3] = {cos(t) * sin(0.8 * t + 0.3), sin(t) * sin(0.8 * t + 0.3), cos(0.8 * t + 0.3)};
      m2 += at(a, d[0], d[1], d[2]) / 40;
      m3 += at(a3, d[0], d[1], d[2]) / 40;
    }
    fprintf(stderr, "  no filter: mean alpha on the shell %.3g as surfels, %.3g as 1e-6-thick Gaussians\n", m2, m3);
    CHECK(m2 > 0.5 && m3 < 0.05);
  }
  mgs_vdb_grid_destroy(a);
  mgs_vdb_grid_destroy(a3);
  mgs_gaussians_destroy(g);
  mgs_gaussians_destroy(g0);
}

int main(void) {
  RUN(test_sphere);
  return mgs_test_finish();
}
