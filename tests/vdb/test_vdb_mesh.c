/* Mesh side of the vdb layer: Embree point-to-mesh distances against the analytic torus
 * distance; area-uniform sampling; a torus surface sampled into small flat Gaussians gives
 * an SDF whose zero level set (extracted with volumeToMesh) is within 1 voxel of the torus
 * (Chamfer); mesh extraction is closed and outward-oriented; signed distances and the
 * signed offset of a thicker or thinner torus, whatever the reference's winding. */
#include <math.h>
#include <stdlib.h>
#include "core/mgs_math.h"
#include "core/mgs_mesh.h"
#include "core/mgs_rng.h"
#include "mgs_test.h"
#include "render/mgs_mesh_distance.h"
#include "vdb_test_util.h"

static const double TR = 1.0, Tr = 0.4; /* torus radii, axis z */

static mgs_mesh *torus_mesh(int nu, int nv) { return vt_torus_mesh(TR, Tr, nu, nv); }

static double torus_signed_distance(const float p[3]) {
  double q = sqrt((double)p[0] * p[0] + (double)p[1] * p[1]) - TR;
  return sqrt(q * q + (double)p[2] * p[2]) - Tr;
}

static double torus_distance(const float p[3]) { return fabs(torus_signed_distance(p)); }


static void test_embree_distance(void) {
  mgs_mesh *m = torus_mesh(128, 48);
  mgs_mesh_distance *d = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_mesh_distance_create(m, &d, &err), &err);
  if (!d) return;
  enum { N = 2000 };
  float *p = malloc(N * 3 * sizeof(float)), dist[N], *cl = malloc(N * 3 * sizeof(float));
  mgs_rng rng;
  mgs_rng_init(&rng, 3, 0);
  for (int i = 0; i < 3 * N; i++) p[i] = (float)(3.2 * mgs_rng_uniform(&rng) - 1.6);
  mgs_mesh_distance_query(d, N, p, dist, cl);
  double worst = 0, worst_cl = 0;
  for (int i = 0; i < N; i++) {
    double e = fabs(dist[i] - torus_distance(p + 3 * i));
    if (e > worst) worst = e;
    double dc = sqrt((cl[3*i]-p[3*i])*(cl[3*i]-p[3*i]) + (cl[3*i+1]-p[3*i+1])*(cl[3*i+1]-p[3*i+1]) + (cl[3*i+2]-p[3*i+2])*(cl[3*i+2]-p[3*i+2]));
    if (fabs(dc - dist[i]) > worst_cl) worst_cl = fabs(dc - dist[i]);
  }
  CHECK_NEAR(worst, 0, 2.5e-3); /* tessellation sagitta of the 128x48 torus */
  CHECK_NEAR(worst_cl, 0, 1e-5);
  /* Sampling: every sample on the surface; area-uniform -> half of the samples on the
   * outer half (x² + y² > R²) would be wrong: the outer half holds (R + 2r/π)/(2R) of the area. */
  float *s = malloc(N * 3 * sizeof(float));
  CHECK_OK(mgs_mesh_sample_surface(m, N, 11, s, NULL, &err), &err);
  int outer = 0;
  double on = 0;
  for (int i = 0; i < N; i++) {
    on = fmax(on, torus_distance(s + 3 * i));
    outer += (s[3 * i] * s[3 * i] + s[3 * i + 1] * s[3 * i + 1]) > TR * TR;
  }
  CHECK_NEAR(on, 0, 2.5e-3);
  CHECK_NEAR((double)outer / N, (TR + 2 * Tr / M_PI) / (2 * TR), 0.035);
  /* Identical surfaces compare to Chamfer ~0, F-score 1. */
  mgs_geometry_metrics gm;
  CHECK_OK(mgs_mesh_compare(m, m, 5000, 0.01, 5, &gm, &err), &err);
  CHECK_NEAR(gm.chamfer, 0, 1e-5);
  CHECK_NEAR(gm.fscore, 1, 1e-9);
  CHECK_NEAR(gm.offset, 0, 1e-6);
  /* Signed distances: the analytic torus' (outside +) up to the sagitta, with the mesh's
   * winding taken outward by its signed volume; a flipped winding flips every sign. */
  const double orient = mgs_mesh_signed_volume(m) < 0 ? -1 : 1;
  CHECK(fabs(mgs_mesh_signed_volume(m) - 2 * M_PI * M_PI * TR * Tr * Tr) < 0.01 * 2 * M_PI * M_PI * TR * Tr * Tr);
  float *sd = malloc(N * sizeof(float));
  mgs_mesh_distance_query_signed(d, N, p, sd);
  double worst_s = 0;
  int flips = 0;
  for (int i = 0; i < N; i++) {
    double a = torus_signed_distance(p + 3 * i);
    worst_s = fmax(worst_s, fabs(orient * sd[i] - a));
    flips += fabs(a) > 2.5e-3 && (orient * sd[i] < 0) != (a < 0);
  }
  CHECK_NEAR(worst_s, 0, 2.5e-3);
  CHECK(flips == 0);
  /* offset: a tube thicker by delta lies outside (+delta), the thinner one inside (-delta),
   * whatever the reference's winding; Chamfer cannot tell the two apart. */
  const double delta = 0.02;
  mgs_mesh *fat = vt_torus_mesh(TR, Tr + delta, 128, 48), *rev = torus_mesh(128, 48);
  for (size_t i = 0; i < rev->nt; i++) {
    uint32_t t1 = rev->t[3 * i + 1];
    rev->t[3 * i + 1] = rev->t[3 * i + 2], rev->t[3 * i + 2] = t1;
  }
  CHECK(mgs_mesh_signed_volume(rev) * mgs_mesh_signed_volume(m) < 0);
  mgs_geometry_metrics out, in, out_rev;
  CHECK_OK(mgs_mesh_compare(fat, m, 8000, 0.01, 5, &out, &err), &err);
  CHECK_OK(mgs_mesh_compare(m, fat, 8000, 0.01, 5, &in, &err), &err);
  CHECK_OK(mgs_mesh_compare(fat, rev, 8000, 0.01, 5, &out_rev, &err), &err);
  CHECK_NEAR(out.offset, delta, 2e-3);
  CHECK_NEAR(in.offset, -delta, 2e-3);
  CHECK_NEAR(out_rev.offset, out.offset, 1e-9);
  CHECK_NEAR(out.accuracy, delta, 2e-3);
  CHECK_NEAR(in.accuracy, delta, 2e-3);
  mgs_mesh_destroy(fat);
  mgs_mesh_destroy(rev);
  free(sd);
  free(p); free(cl); free(s);
  mgs_mesh_distance_destroy(d);
  mgs_mesh_destroy(m);
}

static void test_surface_gaussians_sdf(void) {
  /* Sheet peak P = K α σn/σn' ≈ 0.85 with σn' = sqrt(σn² + h²/4): the level set {A = 0.5} is a shell
   * at ±σn'·sqrt(2 ln(P/τ)) ≈ 0.73 voxel around the surface. */
  const double h = 0.04, sig_t = 2 * h, sig_n = 0.5 * h, K = 8, alpha = 0.15;
  mgs_mesh *m = torus_mesh(256, 96);
  const double area = 4 * M_PI * M_PI * TR * Tr;
  const size_t n = (size_t)(K / (2 * M_PI * sig_t * sig_t) * area);
  float *pts = malloc(n * 3 * sizeof(float)), *nrm = malloc(n * 3 * sizeof(float));
  mgs_error err = {0};
  CHECK_OK(mgs_mesh_sample_surface(m, n, 42, pts, nrm, &err), &err);
  mgs_gaussians *g = mgs_gaussians_create(n, 0);
  for (size_t i = 0; i < n; i++) {
    /* Local frame: two tangents and the normal (axis 2 carries the thin scale). */
    double nz[3] = {nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]}, t1[3], t2[3];
    double a[3] = {fabs(nz[0]) < 0.9 ? 1 : 0, fabs(nz[0]) < 0.9 ? 0 : 1, 0};
    mgs_cross3d(nz, a, t1);
    mgs_normalize3d(t1);
    mgs_cross3d(nz, t1, t2);
    double R[9] = {t1[0], t2[0], nz[0], t1[1], t2[1], nz[1], t1[2], t2[2], nz[2]}, q[4];
    mgs_mat3_to_quatd(R, q);
    const double s[3] = {sig_t, sig_t, sig_n};
    vt_add(g, pts[3 * i], pts[3 * i + 1], pts[3 * i + 2], s, q, alpha);
  }
  mgs_vdb_alpha_params p;
  mgs_vdb_alpha_params_default(&p);
  p.voxel_size = h;
  p.small = MGS_VDB_SMALL_MASS; /* the shell thickness above is computed for this mode */
  mgs_vdb_grid *a = NULL, *sdf = NULL;
  mgs_mesh *ext = NULL;
  CHECK_OK(mgs_vdb_alpha_field(g, &p, &a, NULL, &err), &err);
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  if (a) CHECK_OK(mgs_vdb_sdf_from_alpha(a, &sp, &sdf, &err), &err);
  if (sdf) CHECK_OK(mgs_vdb_extract_mesh(sdf, 0, 0, &ext, &err), &err);
  if (ext) {
    mgs_geometry_metrics gm;
    CHECK_OK(mgs_mesh_compare(ext, m, 20000, h, 9, &gm, &err), &err);
    fprintf(stderr, "  %zu surface Gaussians, voxel %.3f: Chamfer %.4f (%.2f voxel), acc %.4f comp %.4f, F@1voxel %.3f\n", n,
            h, gm.chamfer, gm.chamfer / h, gm.accuracy, gm.completeness, gm.fscore);
    CHECK(gm.chamfer < h);
    CHECK(gm.fscore > 0.9);
    /* The extracted mesh is a closed shell (outer + inner side of the sheet), oriented
     * outward overall: positive enclosed volume. */
    CHECK(mgs_mesh_signed_volume(ext) > 0);
    CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(ext) == 0);
  }
  mgs_mesh_destroy(ext);
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(a);
  mgs_gaussians_destroy(g);
  free(pts);
  free(nrm);
  mgs_mesh_destroy(m);
}

/* A solid sphere's level set extracted with and without adaptivity: outward, closed,
 * volume 4/3 π R³ within 3 % (no adaptivity); adaptivity reduces the triangle count. */
static void test_extract_sphere(void) {
  const double h = 0.05, R = 0.6;
  const int32_t n = 40, origin[3] = {-20, -20, -20}, dims[3] = {n, n, n};
  float *v = malloc((size_t)n * n * n * sizeof(float));
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++)
      for (int k = 0; k < n; k++) {
        double x = (i - 20) * h, y = (j - 20) * h, z = (k - 20) * h;
        v[((size_t)i * n + j) * n + k] = (float)(sqrt(x * x + y * y + z * z) - R);
      }
  mgs_vdb_grid *g = NULL;
  mgs_error err = {0};
  CHECK_OK(mgs_vdb_grid_from_dense("sdf", MGS_VDB_CLASS_LEVEL_SET, h, NULL, (float)(3 * h), origin, dims, v, &g, &err), &err);
  mgs_mesh *m0 = NULL, *m1 = NULL;
  if (g) {
    CHECK_OK(mgs_vdb_extract_mesh(g, 0, 0, &m0, &err), &err);
    CHECK_OK(mgs_vdb_extract_mesh(g, 0, 0.2, &m1, &err), &err);
    mgs_mesh *bad = NULL;
    CHECK(mgs_vdb_extract_mesh(g, 0, 2.0, &bad, &err) == MGS_ERR_ARG && bad == NULL);
  }
  if (m0 && m1) {
    const double vol = 4.0 / 3.0 * M_PI * R * R * R;
    CHECK_NEAR(mgs_mesh_signed_volume(m0) / vol, 1, 0.03);
    /* OpenVDB's adaptivity merges aggressively on a 12-voxel sphere (measured: 0.2 keeps
     * ~150 polygons of ~2600 and loses ~9 % of the volume), so only the direction is checked. */
    CHECK(mgs_mesh_signed_volume(m1) / vol > 0.75);
    CHECK(m1->nt < m0->nt / 4);
    CHECK(mgs_mesh_count_boundary_or_nonmanifold_edges(m0) == 0);
  }
  mgs_mesh_destroy(m0);
  mgs_mesh_destroy(m1);
  mgs_vdb_grid_destroy(g);
  free(v);
}

int main(void) {
  RUN(test_embree_distance);
  RUN(test_surface_gaussians_sdf);
  RUN(test_extract_sphere);
  return mgs_test_finish();
}
