/* Diagram queries (top-k, Betti numbers at t, total persistence, filters) and files
 * (GUDHI text, JSON) round trips and malformed input. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mgs_test.h"
#include "core/mgs_fs.h"
#include "topo/mgs_diagram_tools.h"

static void add(mgs_diagram *d, int dim, double b, double de) {
  mgs_pair p;
  memset(&p, 0, sizeof p);
  p.dim = dim; p.birth = b; p.death = de;
  mgs_diagram_push(d, &p, NULL);
}

/* A small hand-made diagram: a solid torus-like H0/H1 plus noise. */
static mgs_diagram *sample(void) {
  mgs_diagram *d = mgs_diagram_create();
  add(d, 0, -0.5, INFINITY);   /* 0: the component */
  add(d, 0, -0.1, 0.05);       /* 1: p 0.15 */
  add(d, 0, 0.2, 0.21);        /* 2: p 0.01 */
  add(d, 1, -0.2, 0.4);        /* 3: p 0.6 */
  add(d, 1, 0.0, 0.3);         /* 4: p 0.3 */
  add(d, 1, 0.1, 0.12);        /* 5: p 0.02 */
  add(d, 2, -0.05, 0.0);       /* 6: p 0.05, dies exactly at 0 */
  return d;
}

static void test_top_k(void) {
  mgs_diagram *d = sample();
  size_t idx[8];
  CHECK(mgs_diagram_top_k(d, 0, 2, idx) == 2);
  CHECK(idx[0] == 0 && idx[1] == 1);           /* essential first */
  CHECK(mgs_diagram_top_k(d, 1, 5, idx) == 3);  /* only 3 in dim 1 */
  CHECK(idx[0] == 3 && idx[1] == 4 && idx[2] == 5);
  CHECK(mgs_diagram_top_k(d, 2, 1, idx) == 1 && idx[0] == 6);
  CHECK(mgs_diagram_top_k(d, MGS_DIM_ALL, 3, idx) == 3);
  CHECK(idx[0] == 0 && idx[1] == 3 && idx[2] == 4);
  CHECK(mgs_diagram_top_k(d, 1, 0, idx) == 0);
  mgs_diagram_destroy(d);
}

static void test_betti(void) {
  mgs_diagram *d = sample();
  int b[3];
  mgs_diagram_betti(d, 0.0, b);
  /* t=0: H0: (-0.5,inf), (-0.1,0.05) → 2; H1: (-0.2,0.4), (0,0.3) → 2 (birth ≤ t);
   * H2: (-0.05, 0) dies AT 0 → not alive (t < death fails) */
  CHECK(b[0] == 2 && b[1] == 2 && b[2] == 0);
  mgs_diagram_betti(d, -0.05, b);
  CHECK(b[0] == 2 && b[1] == 1 && b[2] == 1);
  mgs_diagram_betti(d, 10.0, b);
  CHECK(b[0] == 1 && b[1] == 0 && b[2] == 0);
  mgs_diagram_betti(d, -1.0, b);
  CHECK(b[0] == 0 && b[1] == 0 && b[2] == 0);
  /* superlevel: negate the diagram (births above deaths) */
  mgs_diagram *s = mgs_diagram_create();
  for (size_t i = 0; i < d->n; i++) add(s, d->pairs[i].dim, -d->pairs[i].birth, -d->pairs[i].death);
  int bs[3];
  mgs_diagram_betti_superlevel(s, 0.05, bs);
  mgs_diagram_betti(d, -0.05, b);
  CHECK(bs[0] == b[0] && bs[1] == b[1] && bs[2] == b[2]);
  mgs_diagram_destroy(s);
  mgs_diagram_destroy(d);
}

static void test_total_persistence(void) {
  mgs_diagram *d = sample();
  CHECK_NEAR(mgs_diagram_total_persistence(d, 1, 1, INFINITY), 0.6 + 0.3 + 0.02, 1e-12);
  CHECK_NEAR(mgs_diagram_total_persistence(d, 1, 2, 0.5), 0.09 + 0.0004, 1e-12);
  CHECK_NEAR(mgs_diagram_total_persistence(d, MGS_DIM_ALL, 1, 0.1), 0.01 + 0.02 + 0.05, 1e-12);
  CHECK(mgs_diagram_total_persistence(d, 0, 1, 0.005) == 0.0);
  CHECK_NEAR(mgs_diagram_total_persistence(d, 2, 1, 0.05), 0.0, 0); /* strict threshold: p = 0.05 excluded */
  CHECK_NEAR(mgs_diagram_total_persistence(d, 0, 1, INFINITY), 0.16, 1e-12); /* essential excluded */
  mgs_diagram_destroy(d);
}

static void test_filter(void) {
  mgs_diagram *d = sample();
  for (size_t i = 0; i < d->n; i++) { d->pairs[i].b.pos[0] = (double)i; d->pairs[i].d.pos[0] = -(double)i; }
  mgs_diagram_filter f;
  mgs_diagram_filter_init(&f);
  size_t *idx, n;
  mgs_error e;
  CHECK_OK(mgs_diagram_select(d, &f, &idx, &n, &e), &e);
  CHECK(n == d->n);
  free(idx);
  f.dim = 1; f.min_persistence = 0.1;
  CHECK_OK(mgs_diagram_select(d, &f, &idx, &n, &e), &e);
  CHECK(n == 2 && idx[0] == 3 && idx[1] == 4);
  free(idx);
  mgs_diagram_filter_init(&f);
  f.death_min = 0; f.death_max = 0.25; /* finite deaths in [0, 0.25] */
  CHECK_OK(mgs_diagram_select(d, &f, &idx, &n, &e), &e);
  CHECK(n == 4); /* 1 (0.05), 2 (0.21), 5 (0.12), 6 (0.0) */
  free(idx);
  mgs_diagram_filter_init(&f);
  f.include_essential = 0; f.birth_max = 0.0;
  CHECK_OK(mgs_diagram_select(d, &f, &idx, &n, &e), &e);
  CHECK(n == 4); /* 1, 3, 4, 6 */
  free(idx);
  mgs_diagram_filter_init(&f);
  f.use_box = 1; f.box_min[0] = 2.5; f.box_max[0] = 4.5; /* birth positions 3, 4 */
  CHECK_OK(mgs_diagram_select(d, &f, &idx, &n, &e), &e);
  CHECK(n == 2 && idx[0] == 3 && idx[1] == 4);
  free(idx);
  f.box_end = 1; f.box_min[0] = -2.5; f.box_max[0] = 0.0; /* death positions 0 (essential: none), -1, -2 */
  mgs_diagram *g = mgs_diagram_filtered(d, &f, &e);
  CHECK(g && g->n == 2 && g->pairs[0].birth == -0.1 && g->pairs[1].birth == 0.2);
  mgs_diagram_destroy(g);
  size_t per[3], ess, tr;
  mgs_diagram_counts(d, per, &ess, &tr);
  CHECK(per[0] == 3 && per[1] == 3 && per[2] == 1 && ess == 1 && tr == 0);
  mgs_diagram_destroy(d);
}

static int same_pair(const mgs_pair *p, const mgs_pair *q, int with_cells) {
  if (p->dim != q->dim || p->birth != q->birth || p->death != q->death) return 0;
  if (!with_cells) return 1;
  if (p->truncated != q->truncated || memcmp(p->b.voxel, q->b.voxel, sizeof p->b.voxel) ||
      memcmp(p->b.pos, q->b.pos, sizeof p->b.pos) || p->b.cell != q->b.cell) return 0;
  if (isfinite(p->death) && (memcmp(p->d.voxel, q->d.voxel, sizeof p->d.voxel) ||
                             memcmp(p->d.pos, q->d.pos, sizeof p->d.pos) || p->d.cell != q->d.cell)) return 0;
  return 1;
}

static int same_diagram(const mgs_diagram *a, const mgs_diagram *b, int with_cells) {
  if (a->n != b->n) return 0;
  for (size_t i = 0; i < a->n; i++)
    if (!same_pair(&a->pairs[i], &b->pairs[i], with_cells)) {
      fprintf(stderr, "pair %zu differs: %.17g %.17g / %.17g %.17g\n", i, a->pairs[i].birth,
              a->pairs[i].death, b->pairs[i].birth, b->pairs[i].death);
      return 0;
    }
  return 1;
}

static void test_round_trip(void) {
  const char *dir = mgs_test_tmpdir("diagram_io");
  char txt[4200], js[4200];
  snprintf(txt, sizeof txt, "%s/d.txt", dir);
  snprintf(js, sizeof js, "%s/d.json", dir);
  mgs_diagram *d = sample();
  add(d, 0, 1.0 / 3.0, 2.0 / 3.0 + 1e-17);   /* values needing 17 digits */
  add(d, 1, -1e-300, 5e300);
  add(d, 0, 0.25, -INFINITY);                /* superlevel-style essential */
  for (size_t i = 0; i < d->n; i++) {
    mgs_pair *p = &d->pairs[i];
    for (int k = 0; k < 3; k++) { p->b.voxel[k] = (int32_t)(i * 3 + k) - 5; p->b.pos[k] = 0.1 * (double)i + k / 7.0; }
    for (int k = 0; k < 3; k++) { p->d.voxel[k] = -(int32_t)(i * 3 + k); p->d.pos[k] = -0.3 * (double)i - k / 9.0; }
    p->b.cell = (uint64_t)i * 1000003u;
    p->d.cell = i == 2 ? (1ull << 60) + 7 : (uint64_t)i; /* above 2^53: stored as string */
    p->truncated = (int)(i % 2);
  }
  d->n_cells = 12345; d->n_critical = 67; d->n_active_voxels = 890; d->seconds = 0.125;
  mgs_error e;
  CHECK_OK(mgs_diagram_write_text(txt, d, &e), &e);
  CHECK_OK(mgs_diagram_write_json(js, d, "{\"source\":\"test\",\"band\":0.3}", &e), &e);
  mgs_diagram *t = NULL, *j = NULL;
  CHECK_OK(mgs_diagram_read_text(txt, &t, &e), &e);
  CHECK_OK(mgs_diagram_read_json(js, &j, &e), &e);
  CHECK(t && same_diagram(d, t, 0));
  CHECK(j && same_diagram(d, j, 1));
  if (j) CHECK(j->n_cells == 12345 && j->n_critical == 67 && j->n_active_voxels == 890 && j->seconds == 0.125);
  /* the text is GUDHI's layout: first line "0 -0.5 inf" */
  char *data; size_t size;
  CHECK_OK(mgs_read_file(txt, &data, &size, &e), &e);
  CHECK(!strncmp(data, "0 -0.5 inf\n", 11));
  free(data);
  /* invalid metadata is refused and nothing is written */
  char js2[4200];
  snprintf(js2, sizeof js2, "%s/meta_bad.json", dir);
  CHECK(mgs_diagram_write_json(js2, d, "[1,2]", &e) == MGS_ERR_ARG);
  CHECK(!mgs_path_exists(js2));
  /* empty diagram round trip */
  mgs_diagram *em = mgs_diagram_create(), *em2 = NULL;
  CHECK_OK(mgs_diagram_write_text(txt, em, &e), &e);
  CHECK_OK(mgs_diagram_read_text(txt, &em2, &e), &e);
  CHECK(em2 && em2->n == 0);
  mgs_diagram_destroy(em); mgs_diagram_destroy(em2);
  mgs_diagram_destroy(d); mgs_diagram_destroy(t); mgs_diagram_destroy(j);
}

static void expect_bad(const char *dir, const char *name, const char *content, int json, const char *needle) {
  char path[4200];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  mgs_error e;
  CHECK_OK(mgs_write_file_atomic(path, content, strlen(content), &e), &e);
  mgs_diagram *d = NULL;
  mgs_status st = json ? mgs_diagram_read_json(path, &d, &e) : mgs_diagram_read_text(path, &d, &e);
  CHECK_MSG(st != MGS_OK && d == NULL, "%s accepted", name);
  if (st != MGS_OK) {
    CHECK_MSG(strstr(e.msg, name) != NULL, "message '%s' does not name the file", e.msg);
    CHECK_MSG(strstr(e.msg, needle) != NULL, "message '%s' lacks '%s'", e.msg, needle);
    CHECK(strchr(e.msg, '\n') == NULL);
  }
}

static void test_bad_files(void) {
  const char *dir = mgs_test_tmpdir("diagram_bad");
  expect_bad(dir, "two.txt", "0 0.1 0.2\n1 0.5\n", 0, ":2:");
  expect_bad(dir, "dim.txt", "3 0.1 0.2\n", 0, "dimension");
  expect_bad(dir, "frac.txt", "0.5 0.1 0.2\n", 0, "dimension");
  expect_bad(dir, "nan.txt", "0 nan 0.2\n", 0, ":1:");
  expect_bad(dir, "extra.txt", "# c\n\n0 0.1 0.2 7\n", 0, ":3:");
  expect_bad(dir, "word.txt", "0 0.1 abc\n", 0, ":1:");
  expect_bad(dir, "garbage.json", "{\"format\":", 1, "JSON");
  expect_bad(dir, "other.json", "{\"format\":\"x\",\"pairs\":[]}", 1, "morsegs");
  expect_bad(dir, "pdim.json", "{\"format\":\"morsegs-diagram\",\"pairs\":[{\"dim\":7,\"birth\":0,\"death\":1}]}", 1, "dim");
  expect_bad(dir, "pval.json", "{\"format\":\"morsegs-diagram\",\"pairs\":[{\"dim\":0,\"birth\":\"x\",\"death\":1}]}", 1, "birth");
  expect_bad(dir, "pvox.json", "{\"format\":\"morsegs-diagram\",\"pairs\":[{\"dim\":0,\"birth\":0,\"death\":1,\"birth_cell\":{\"voxel\":[1,2]}}]}", 1, "voxel");
  mgs_diagram *d = NULL;
  mgs_error e;
  CHECK(mgs_diagram_read_text("/nonexistent/x.txt", &d, &e) != MGS_OK && strstr(e.msg, "/nonexistent/x.txt"));
  CHECK(mgs_diagram_read_json("/nonexistent/x.json", &d, &e) != MGS_OK && strstr(e.msg, "/nonexistent/x.json"));
  /* comments, blank lines, CRLF-free whitespace and -inf are fine */
  char path[4200];
  snprintf(path, sizeof path, "%s/ok.txt", dir);
  const char *ok = "# GUDHI style\n\n  0 -1 inf\n1\t0.5\t0.75\n0 2 -inf\n";
  CHECK_OK(mgs_write_file_atomic(path, ok, strlen(ok), &e), &e);
  CHECK_OK(mgs_diagram_read_text(path, &d, &e), &e);
  CHECK(d && d->n == 3 && isinf(d->pairs[0].death) && d->pairs[1].dim == 1 && d->pairs[2].death == -INFINITY);
  mgs_diagram_destroy(d);
}

static void test_sort(void) {
  mgs_diagram *d = mgs_diagram_create();
  add(d, 2, 0, 1); add(d, 0, 0.5, INFINITY); add(d, 0, 0.5, 0.7); add(d, 1, -1, 0);
  mgs_diagram_sort(d);
  CHECK(d->pairs[0].dim == 0 && d->pairs[0].death == 0.7 && isinf(d->pairs[1].death));
  CHECK(d->pairs[2].dim == 1 && d->pairs[3].dim == 2);
  mgs_error e;
  CHECK(mgs_diagram_push(d, NULL, &e) == MGS_ERR_ARG);
  for (int i = 0; i < 1000; i++) add(d, i % 3, i, i + 1); /* growth */
  CHECK(d->n == 1004 && d->capacity >= 1004);
  mgs_diagram_destroy(d);
  mgs_diagram_destroy(NULL);
}

int main(void) {
  RUN(test_top_k);
  RUN(test_betti);
  RUN(test_total_persistence);
  RUN(test_filter);
  RUN(test_round_trip);
  RUN(test_bad_files);
  RUN(test_sort);
  return mgs_test_finish();
}
