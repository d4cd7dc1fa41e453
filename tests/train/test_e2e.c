/* End to end through the CLI: a synthetic NeRF-synthetic dataset (rendered by our own
 * rasterizer from a known Gaussian model), `morsegs train` for a few hundred iterations at
 * low resolution, `morsegs eval` on the held-out views: test PSNR must clear a threshold
 * that the same run with parameter updates disabled (--freeze, i.e. a zero gradient)
 * cannot reach. Also: run layout, render, refusal to overwrite, the dataset untouched,
 * resume, and refused MorseGS flags. */
#include <dirent.h>
#include <limits.h>
#include <stdlib.h>
#include <math.h>
#include <stdarg.h>
#include <sys/wait.h>
#include <cjson/cJSON.h>
#include "mgs_test.h"
#include "run_results.h"
#include "synth.h"

/* threshold calibrated on this scene (see bench/RESULTS-train.md): trained ~26-28 dB,
   frozen (initial model) ~12 dB */
#define PSNR_THRESHOLD 20.0

static const char *cli;


static int count_entries(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return -1;
  int n = 0;
  struct dirent *e;
  while ((e = readdir(d))) n += e->d_name[0] != '.';
  closedir(d);
  return n;
}

int main(void) {
  cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 2; }
  const char *tmp = mgs_test_tmpdir("e2e");
  char data[4200], run[4200], frozen[4200], renders[4200], path[8800];
  snprintf(data, sizeof data, "%s/data", tmp);
  snprintf(run, sizeof run, "%s/run", tmp);
  snprintf(frozen, sizeof frozen, "%s/frozen", tmp);
  snprintf(renders, sizeof renders, "%s/renders", tmp);
  mgs_gaussians *gt = synth_model(150, 21);
  mgs_dataset *ds = synth_dataset(gt, 40, 8, 64, 64);
  CHECK(synth_write_nerf(ds, data));
  mgs_dataset_destroy(ds);
  mgs_gaussians_destroy(gt);
  int data_files = count_entries(data), train_files = 0;
  snprintf(path, sizeof path, "%s/train", data);
  train_files = count_entries(path);

  const char *common = "--iters 400 --black --random-points 5000 --seed 1 --quiet --checkpoint-every 100";
  CHECK(mgs_test_sh("%s train %s -o %s %s", cli, data, run, common) == 0);
  CHECK(mgs_test_sh("%s eval %s --no-images > %s/eval.txt", cli, run, tmp) == 0);
  double psnr = mgs_test_results_psnr(run, 400, NULL);
  CHECK(mgs_test_sh("%s train %s -o %s %s --freeze", cli, data, frozen, common) == 0);
  CHECK(mgs_test_sh("%s eval %s --no-images > /dev/null", cli, frozen) == 0);
  double psnr_frozen = mgs_test_results_psnr(frozen, 400, NULL);
  fprintf(stderr, "test PSNR: trained %.2f dB, frozen %.2f dB, threshold %.1f\n", psnr, psnr_frozen, PSNR_THRESHOLD);
  CHECK(psnr > PSNR_THRESHOLD);
  CHECK(psnr_frozen > 0 && psnr_frozen < PSNR_THRESHOLD); /* the threshold can fail */

  /* a model trained elsewhere (here: this run's .ply) made a run folder by eval --data: the
     same figures as the run's own eval; never into a folder that holds something */
  char imported[4400];
  snprintf(imported, sizeof imported, "%s/imported", tmp);
  snprintf(path, sizeof path, "%s/point_cloud/iteration_400/point_cloud.ply", run);
  CHECK(mgs_test_sh("%s eval %s --data %s --background black -o %s --no-images > /dev/null", cli, path, data, imported) == 0);
  CHECK_NEAR(mgs_test_results_psnr(imported, 0, NULL), psnr, 1e-9);
  /* the run folder itself as MODEL (the reference's output layout): its latest iteration */
  char imported_dir[4400];
  snprintf(imported_dir, sizeof imported_dir, "%s/imported_dir", tmp);
  CHECK(mgs_test_sh("%s eval %s --data %s --background black -o %s --no-images > /dev/null", cli, run, data, imported_dir) == 0);
  CHECK_NEAR(mgs_test_results_psnr(imported_dir, 0, NULL), psnr, 1e-9);
  CHECK(mgs_test_sh("%s eval %s --data %s --background black -o %s --no-images 2>/dev/null", cli, path, data, imported) == 1);
  CHECK(mgs_test_sh("%s eval %s --data %s --no-images 2>/dev/null", cli, path, data) == 2); /* -o missing */
  CHECK(mgs_test_sh("%s eval %s/nothing.spz --data %s -o %s/imp2 2>/dev/null", cli, tmp, data, tmp) == 1);
  CHECK(mgs_test_sh("%s eval %s --data %s -o %s/inside 2>/dev/null", cli, path, data, data) == 1); /* never into the dataset */
  snprintf(imported, sizeof imported, "%s/inside", data);
  CHECK(!mgs_path_exists(imported));
  snprintf(path, sizeof path, "%s/imp2/cfg_args", tmp);
  CHECK(!mgs_path_exists(path));
  /* with the dataset's default background (white for NeRF-synthetic) the figures differ */
  snprintf(path, sizeof path, "%s/point_cloud/iteration_400/point_cloud.ply", run);
  snprintf(imported, sizeof imported, "%s/imported_white", tmp);
  CHECK(mgs_test_sh("%s eval %s --data %s -o %s --no-images > /dev/null", cli, path, data, imported) == 0);
  CHECK(fabs(mgs_test_results_psnr(imported, 0, NULL) - psnr) > 0.01);
  /* at half size (a model trained at the reference's --resolution 2): recorded, and other figures */
  snprintf(imported, sizeof imported, "%s/imported_half", tmp);
  CHECK(mgs_test_sh("%s eval %s --data %s --background black --downscale 2 -o %s --no-images > /dev/null", cli, path, data, imported) == 0);
  CHECK(mgs_test_sh("grep -q 'downscale=2' %s/cfg_args", imported) == 0);
  CHECK(mgs_test_results_psnr(imported, 0, NULL) > 0 && fabs(mgs_test_results_psnr(imported, 0, NULL) - psnr) > 0.01);
  CHECK(mgs_test_sh("%s eval %s --downscale 2 2>/dev/null", cli, run) == 2); /* only with --data */
  /* a run folder the reference wrote (its cfg_args: resolution, no downscale key) trained at
     -r 2: evaluated at half size, the figures of --data --downscale 2 */
  {
    char inria[4400];
    snprintf(inria, sizeof inria, "%s/inria_r2", tmp);
    CHECK(mgs_test_sh("mkdir -p %s/point_cloud/iteration_400 && cp %s %s/point_cloud/iteration_400/ && cp %s/cameras.json %s/",
                      inria, path, inria, run, inria) == 0);
    char abs_data[PATH_MAX];
    CHECK(realpath(data, abs_data) != NULL);
    snprintf(path, sizeof path, "%s/cfg_args", inria);
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (f) {
      fprintf(f, "Namespace(data_device='cuda', eval=True, images='images', model_path='./output/3f1c2b', resolution=2, "
                 "sh_degree=3, source_path='%s', white_background=False)", abs_data);
      fclose(f);
    }
    CHECK(mgs_test_sh("%s eval %s --no-images > /dev/null", cli, inria) == 0);
    CHECK_NEAR(mgs_test_results_psnr(inria, 400, NULL), mgs_test_results_psnr(imported, 0, NULL), 1e-9);
    snprintf(path, sizeof path, "%s/point_cloud/iteration_400/point_cloud.ply", run);
  }

  /* run layout of the reference */
  snprintf(path, sizeof path, "%s/point_cloud/iteration_400/point_cloud.ply", run);
  CHECK(mgs_path_exists(path));
  snprintf(path, sizeof path, "%s/cameras.json", run);
  CHECK(mgs_path_exists(path));
  snprintf(path, sizeof path, "%s/cfg_args", run);
  CHECK(mgs_path_exists(path));
  mgs_gaussians *g = NULL;
  snprintf(path, sizeof path, "%s/point_cloud/iteration_400/point_cloud.ply", run);
  CHECK_OK(mgs_ply_read_gaussians(path, &g, NULL), (mgs_error *)NULL);
  if (g) { CHECK(g->n > 0 && g->sh_degree == 3); mgs_gaussians_destroy(g); }

  /* render writes one PNG per test view */
  CHECK(mgs_test_sh("%s render %s --split test -o %s", cli, run, renders) == 0);
  CHECK(count_entries(renders) == 8);
  CHECK(mgs_test_sh("%s render %s --split test -o %s 2>/dev/null", cli, run, renders) != 0); /* not empty, no --force */
  /* the reference's render.py layout (its metrics.py reads it): RUN/test/ours_400/{renders,gt},
     00000.png ... in view order; the PSNR of those 8-bit files is eval's within rounding */
  CHECK(mgs_test_sh("%s render %s --reference-layout > /dev/null", cli, run) == 0);
  {
    double sum = 0;
    int n = 0;
    for (;; n++) {
      char rp[4400], gp[4400];
      snprintf(rp, sizeof rp, "%s/test/ours_400/renders/%05d.png", run, n);
      snprintf(gp, sizeof gp, "%s/test/ours_400/gt/%05d.png", run, n);
      if (!mgs_path_exists(rp)) break;
      mgs_image *a = NULL, *b = NULL;
      CHECK_OK(mgs_image_read(rp, &a, NULL), (mgs_error *)NULL);
      CHECK_OK(mgs_image_read(gp, &b, NULL), (mgs_error *)NULL);
      if (a && b && a->width == b->width && a->height == b->height && a->channels == 3 && b->channels == 3) {
        double mse = 0;
        const size_t m = (size_t)a->width * a->height * 3;
        for (size_t k = 0; k < m; k++) mse += (a->data[k] - b->data[k]) * (a->data[k] - b->data[k]);
        sum += 10 * log10(1.0 / (mse / m));
      } else {
        CHECK_MSG(0, "view %d: render and gt differ in size", n);
      }
      mgs_image_destroy(a);
      mgs_image_destroy(b);
    }
    CHECK(n == 8);
    fprintf(stderr, "reference layout: %d test views, PSNR of the PNGs %.4f dB, eval %.4f dB\n", n, n ? sum / n : 0, psnr);
    CHECK(n > 0 && fabs(sum / n - psnr) < 0.05);
    CHECK(mgs_test_sh("%s render %s --reference-layout 2>/dev/null", cli, run) == 1); /* kept without --force */
    CHECK(mgs_test_sh("%s render %s --reference-layout --depth 2>/dev/null", cli, run) == 2);
  }

  /* never overwrite, never write into the dataset */
  CHECK(mgs_test_sh("%s train %s -o %s %s 2>/dev/null", cli, data, run, common) != 0);
  snprintf(path, sizeof path, "%s/inner_run", data);
  CHECK(mgs_test_sh("%s train %s -o %s %s 2>/dev/null", cli, data, path, common) != 0);
  CHECK(!mgs_path_exists(path));
  CHECK(count_entries(data) == data_files);
  snprintf(path, sizeof path, "%s/train", data);
  CHECK(count_entries(path) == train_files);

  /* resume extends the finished run (final checkpoint at 400) to a longer one */
  CHECK(mgs_test_sh("%s train %s -o %s --iters 500 --black --random-points 5000 --seed 1 --quiet --resume", cli, data, run) == 0);
  snprintf(path, sizeof path, "%s/point_cloud/iteration_500/point_cloud.ply", run);
  CHECK(mgs_path_exists(path));

  /* eval with side-by-side images: render | ground truth | error, one PNG per test view */
  CHECK(mgs_test_sh("%s eval %s > /dev/null", cli, run) == 0);
  snprintf(path, sizeof path, "%s/eval", run);
  CHECK(count_entries(path) == 8);
  CHECK(mgs_test_results_psnr(run, 500, NULL) > PSNR_THRESHOLD);

  /* Ctrl-C: a long run gets SIGINT once training started; it writes a checkpoint and the
     current .ply and exits with 130 */
  char sig[4400];
  snprintf(sig, sizeof sig, "%s/sigint", tmp);
  CHECK(mgs_test_sh("%s train %s -o %s --iters 1000000 --black --random-points 5000 --quiet --checkpoint-every 0 > /dev/null 2>&1 & pid=$!; "
           "for i in $(seq 1 600); do [ -f %s/cameras.json ] && break; sleep 0.1; done; sleep 1; kill -INT $pid; wait $pid; exit $?",
           cli, data, sig, sig) == 130);
  snprintf(path, sizeof path, "%s/checkpoint.mgsckpt", sig);
  CHECK(mgs_path_exists(path));
  CHECK(mgs_test_sh("ls %s/point_cloud/iteration_*/point_cloud.ply > /dev/null", sig) == 0);

  /* MorseGS and Topology-GS flags out of range are refused clearly, before anything is
     written (usage error; tests/train/test_morse_cli.c and tests/topogs check them in detail) */
  CHECK(mgs_test_sh("%s train %s -o %s/x --strategy morse --morse-every 0 2>/dev/null", cli, data, tmp) == 2);
  CHECK(mgs_test_sh("%s train %s -o %s/x --topo-loss --beta -1 2>/dev/null", cli, data, tmp) == 2);
  CHECK(mgs_test_sh("%s train %s -o %s/x --init nope 2>/dev/null", cli, data, tmp) == 2);
  snprintf(path, sizeof path, "%s/x", tmp);
  CHECK(!mgs_path_exists(path));
  return mgs_test_finish();
}
