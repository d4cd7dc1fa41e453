/* morsegs experiment end to end on a tiny built-in scene (sphere, 8 views of 48x48, 700
 * iterations, 2 seeds, one knob-sweep run, a variant train rejects): killed (SIGKILL) half-way
 * through its second run and started again, it keeps the finished run untouched, continues
 * the interrupted one from its checkpoint (to the model an uninterrupted training gives),
 * leaves no training process behind, and finishes with RESULTS.md, RESULTS.json, the CSVs, the plots and one
 * folder per run; the figures RESULTS.md shows for a run equal what `morsegs eval` reports
 * for it. The second invocation runs two runs at a time (--jobs 2). --plan lists the runs
 * and an estimate without creating the folder, and after the kill counts the finished run
 * and estimates from it. */
#include <dirent.h>
#include <signal.h>
#include <stdarg.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include <cjson/cJSON.h>
#include "mgs_test.h"
#include "core/mgs_fs.h"

static const char *cli;

static double mtime(const char *p) {
  struct stat sb;
  if (stat(p, &sb)) return -1;
  return (double)sb.st_mtim.tv_sec + 1e-9 * (double)sb.st_mtim.tv_nsec;
}

/* Processes whose command line mentions `needle` (other than this test). */
static int processes_with(const char *needle) {
  DIR *d = opendir("/proc");
  int n = 0;
  struct dirent *e;
  while (d && (e = readdir(d))) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9' || atoi(e->d_name) == getpid()) continue;
    char p[300], buf[8192];
    snprintf(p, sizeof p, "/proc/%s/cmdline", e->d_name);
    FILE *f = fopen(p, "rb");
    if (!f) continue;
    size_t len = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    for (size_t i = 0; i < len; i++) if (!buf[i]) buf[i] = ' ';
    buf[len] = 0;
    if (strstr(buf, needle) && strstr(buf, "morsegs")) n++;
  }
  if (d) closedir(d);
  return n;
}

/* The cells of the RESULTS.md runs-table row that starts with `prefix`. */
static int row_cells(const char *md, const char *prefix, char cells[20][64]) {
  const char *l = strstr(md, prefix);
  if (!l) return 0;
  int n = 0;
  const char *q = l + 1;
  while (*q && *q != '\n' && n < 20) {
    const char *bar = strchr(q, '|');
    if (!bar) break;
    const char *a = q, *b = bar;
    while (a < b && *a == ' ') a++;
    while (b > a && b[-1] == ' ') b--;
    snprintf(cells[n], 64, "%.*s", (int)(b - a), a);
    n++;
    q = bar + 1;
  }
  return n;
}

int main(void) {
  cli = getenv("MGS_CLI");
  if (!cli) { fprintf(stderr, "MGS_CLI not set\n"); return 2; }
  setenv("MGS_THREADS", "2", 0);
  const char *tmp = mgs_test_tmpdir("exp_e2e");
  char ds[512], out[512], log1[512], log2[512];
  snprintf(ds, sizeof ds, "%s/ds", tmp);
  snprintf(out, sizeof out, "%s/exp", tmp);
  snprintf(log1, sizeof log1, "%s/first.log", tmp);
  snprintf(log2, sizeof log2, "%s/second.log", tmp);
  CHECK(mgs_test_sh("'%s' scene --builtin sphere -o '%s' --views 8 --test-views 2 --width 48 --height 48 --spp 1 --init-points 1500 -q",
           cli, ds) == 0);
  char *const args[] = {(char *)"morsegs", (char *)"experiment", ds, (char *)"-o", out, (char *)"--iters", (char *)"700",
                        (char *)"--seeds", (char *)"2", (char *)"--evals", (char *)"2", (char *)"--sweep", (char *)"2", (char *)"--sweep-seeds", (char *)"1",
                        (char *)"--topo-res", (char *)"96", (char *)"--variants", (char *)"baseline,bogus",
                        (char *)"--variant", (char *)"bogus=--no-such-flag 1", NULL};
  /* --plan: the runs and an estimate, nothing written */
  char plan_log[600], cmd[4096] = "";
  snprintf(plan_log, sizeof plan_log, "%s/plan.log", tmp);
  for (int i = 1; args[i]; i++) {
    size_t l = strlen(cmd);
    snprintf(cmd + l, sizeof cmd - l, " '%s'", args[i]);
  }
  CHECK(mgs_test_sh("'%s'%s --plan > '%s'", cli, cmd, plan_log) == 0);
  char *plan = NULL;
  size_t pn;
  mgs_read_file(plan_log, &plan, &pn, NULL);
  CHECK_MSG(plan && strstr(plan, "5 runs") && strstr(plan, "| baseline | 3 | 0 | 3 |") && strstr(plan, "prior"),
            "plan: %s", plan ? plan : "(none)");
  CHECK_MSG(!mgs_path_exists(out), "--plan created %s", out);
  CHECK_MSG(strstr(plan, "next: ds/baseline/seed_0, ds/bogus/seed_0, ds/baseline/seed_1,"), "plan order: %s", plan);
  free(plan);
  plan = NULL;
  /* --first: in each seed, these variants' runs come first */
  CHECK(mgs_test_sh("'%s'%s '%s' --first bogus --plan > '%s'", cli, cmd, ds, plan_log) == 0); /* the dataset twice */
  mgs_read_file(plan_log, &plan, &pn, NULL);
  CHECK_MSG(plan && strstr(plan, "next: ds/bogus/seed_0, ds_2/bogus/seed_0, ds/baseline/seed_0, ds_2/baseline/seed_0, ds/bogus/seed_1,"),
            "plan order with --first: %s", plan ? plan : "(none)");
  free(plan);
  plan = NULL;
  CHECK(mgs_test_sh("'%s'%s --first nosuch --plan > /dev/null 2>&1", cli, cmd) == 2);
  /* --sweep-of: one variant's own multipliers (a knob with a bounded range) */
  CHECK(mgs_test_sh("'%s'%s --sweep-of baseline=3,1,0.5 --plan > '%s'", cli, cmd, plan_log) == 0);
  mgs_read_file(plan_log, &plan, &pn, NULL);
  CHECK_MSG(plan && strstr(plan, "6 runs") && strstr(plan, "ds/bogus/seed_1, ds/baseline/sweep_x3_seed_0, ds/baseline/sweep_x0.5_seed_0\n"),
            "plan with --sweep-of: %s", plan ? plan : "(none)");
  free(plan);
  plan = NULL;
  CHECK(mgs_test_sh("'%s'%s --sweep-of nosuch=2 --plan > /dev/null 2>&1", cli, cmd) == 2);
  CHECK(mgs_test_sh("'%s'%s --sweep-of baseline=-1 --plan > /dev/null 2>&1", cli, cmd) == 2);
  /* --variant-seeds: fewer seeds for one variant */
  CHECK(mgs_test_sh("'%s'%s --variant-seeds bogus=1 --plan > '%s'", cli, cmd, plan_log) == 0);
  mgs_read_file(plan_log, &plan, &pn, NULL);
  CHECK_MSG(plan && strstr(plan, "4 runs") && strstr(plan, "| bogus | 1 | 0 | 1 |"), "plan: %s", plan ? plan : "(none)");
  free(plan);
  plan = NULL;
  CHECK(mgs_test_sh("'%s'%s --variant-seeds bogus=3 --plan > /dev/null 2>&1", cli, cmd) == 2); /* more than --seeds */
  /* first invocation, killed once its first run is finished */
  pid_t pid = fork();
  if (pid == 0) {
    FILE *f = freopen(log1, "w", stdout);
    (void)f;
    execv(cli, args);
    _exit(127);
  }
  char first[700], first_ply[700], second_saves[700];
  snprintf(first, sizeof first, "%s/runs/ds/baseline/seed_0/result.json", out);
  snprintf(first_ply, sizeof first_ply, "%s/runs/ds/baseline/seed_0/point_cloud/iteration_700/point_cloud.ply", out);
  /* killed half-way through the second run (after its save at 350) */
  snprintf(second_saves, sizeof second_saves, "%s/runs/ds/baseline/seed_1/saves.csv", out);
  int waited = 0, status = 0, exited = 0;
  while (!mgs_path_exists(second_saves) && waited < 15000) {
    if (waitpid(pid, &status, WNOHANG) == pid) { exited = 1; break; }
    usleep(20000);
    waited++;
  }
  CHECK_MSG(!exited, "the experiment ended before it could be killed (status %d)", status);
  if (!exited) { kill(pid, SIGKILL); waitpid(pid, &status, 0); }
  CHECK(mgs_path_exists(first));
  char second_run[700], second_args[700], second_ckpt[700], second_ply[700];
  snprintf(second_run, sizeof second_run, "%s/runs/ds/baseline/seed_1/result.json", out);
  snprintf(second_args, sizeof second_args, "%s/runs/ds/baseline/seed_1/experiment_args", out);
  snprintf(second_ckpt, sizeof second_ckpt, "%s/runs/ds/baseline/seed_1/checkpoint.mgsckpt", out);
  snprintf(second_ply, sizeof second_ply, "%s/runs/ds/baseline/seed_1/point_cloud/iteration_700/point_cloud.ply", out);
  CHECK_MSG(!mgs_path_exists(second_run), "killed too late: the second run had finished");
  CHECK_MSG(mgs_path_exists(second_ckpt), "the interrupted run left no checkpoint to continue from");
  const double t_args = mtime(second_args);
  usleep(500000);
  CHECK_MSG(processes_with(out) == 0, "a child of the killed experiment is still running");
  char *before = NULL;
  size_t n;
  mgs_read_file(first, &before, &n, NULL);
  const double t_result = mtime(first), t_ply = mtime(first_ply);
  CHECK(mgs_test_sh("'%s'%s --plan > '%s'", cli, cmd, plan_log) == 0);
  mgs_read_file(plan_log, &plan, &pn, NULL);
  CHECK_MSG(plan && strstr(plan, "| baseline | 3 | 1 | 2 |") && strstr(plan, "its finished runs"), "plan: %s", plan ? plan : "(none)");
  free(plan);
  /* second invocation, two runs at a time: finishes without redoing the finished run */
  CHECK(mgs_test_sh("'%s'%s --jobs 2 > '%s'", cli, cmd, log2) == 0);
  char *after = NULL, *l2 = NULL;
  mgs_read_file(first, &after, &n, NULL);
  CHECK(before && after && !strcmp(before, after));
  CHECK(mtime(first) == t_result && mtime(first_ply) == t_ply);
  mgs_read_file(log2, &l2, &n, NULL);
  CHECK_MSG(l2 && strstr(l2, "1 finished before"), "second log: %s", l2 ? l2 : "(none)");
  /* the interrupted run continued from its checkpoint (its folder was not started again:
     a new start rewrites experiment_args) and ends with the model an uninterrupted
     training with the same command gives, byte for byte; its checkpoint is removed */
  CHECK_MSG(t_args > 0 && mtime(second_args) == t_args, "the interrupted run was started again, not continued");
  CHECK_MSG(!mgs_path_exists(second_ckpt), "a finished run kept its checkpoint");
  {
    char *argtext = NULL, fresh[600], tcmd[8192] = "";
    snprintf(fresh, sizeof fresh, "%s/fresh", tmp);
    mgs_read_file(second_args, &argtext, &n, NULL);
    CHECK(argtext != NULL);
    int k = 0, next_is_out = 0;
    for (char *tok = argtext ? strtok(argtext, "\n") : NULL; tok; tok = strtok(NULL, "\n"), k++) {
      if (k < 2) continue; /* "morsegs train" */
      size_t l = strlen(tcmd);
      snprintf(tcmd + l, sizeof tcmd - l, " '%s'", next_is_out ? fresh : tok);
      next_is_out = !strcmp(tok, "-o");
    }
    free(argtext);
    CHECK(mgs_test_sh("'%s' train%s --force > /dev/null 2>&1", cli, tcmd) == 0);
    char fresh_ply[700], *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    snprintf(fresh_ply, sizeof fresh_ply, "%s/point_cloud/iteration_700/point_cloud.ply", fresh);
    mgs_read_file(second_ply, &a, &na, NULL);
    mgs_read_file(fresh_ply, &b, &nb, NULL);
    CHECK_MSG(a && b && na == nb && !memcmp(a, b, na), "the continued run's model differs from an uninterrupted one (%zu / %zu bytes)", na, nb);
    free(a); free(b);
  }
  CHECK(l2 && strstr(l2, "bogus") && strstr(l2, "not available"));
  /* outputs: one folder per run, the report, the curves */
  static const char *files[] = {"RESULTS.md", "RESULTS.json", "curves.csv", "h3.csv", "experiment.json",
                                "plots/ds_psnr_time.png", "plots/ds_psnr_time.svg", "plots/ds_chamfer_time.png",
                                "plots/ds_chamfer_time.svg", "plots/ds_h3_count_psnr.png", "datasets/ds/gt_diagram.json",
                                "runs/ds/baseline/seed_0/result.json", "runs/ds/baseline/seed_1/result.json",
                                "runs/ds/baseline/sweep_x2_seed_0/result.json"};
  char path[1024];
  for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
    snprintf(path, sizeof path, "%s/%s", out, files[i]);
    CHECK_MSG(mgs_path_exists(path), "%s missing", path);
  }
  /* each finished run records its CPU time, training and evaluation (what --plan estimates from) */
  {
    char *rj = NULL;
    size_t rn = 0;
    snprintf(path, sizeof path, "%s/runs/ds/baseline/seed_0/result.json", out);
    mgs_read_file(path, &rj, &rn, NULL);
    cJSON *r = cJSON_Parse(rj ? rj : "");
    const cJSON *tc = cJSON_GetObjectItem(r, "train_cpu_seconds"), *ec = cJSON_GetObjectItem(r, "eval_cpu_seconds");
    CHECK_MSG(cJSON_IsNumber(tc) && tc->valuedouble > 0 && cJSON_IsNumber(ec) && ec->valuedouble > 0,
              "result.json without CPU seconds: %s", rj ? rj : "(none)");
    cJSON_Delete(r);
    free(rj);
  }
  /* no temporary file of an interrupted atomic write is left behind */
  for (int k = 0; k < 2; k++) {
    snprintf(path, sizeof path, "%s%s", out, k ? "/plots" : "");
    DIR *d = opendir(path);
    struct dirent *e;
    while (d && (e = readdir(d))) CHECK_MSG(!strstr(e->d_name, ".tmp-"), "stale temporary %s/%s", path, e->d_name);
    if (d) closedir(d);
  }
  snprintf(path, sizeof path, "%s/runs/ds/bogus", out);
  CHECK_MSG(!mgs_path_exists(path), "an unavailable variant left a run folder");
  char *md = NULL, *csv = NULL, *js = NULL;
  snprintf(path, sizeof path, "%s/RESULTS.md", out);
  mgs_read_file(path, &md, &n, NULL);
  CHECK(md && strstr(md, "| bogus | not available |") && strstr(md, "no-such-flag"));
  snprintf(path, sizeof path, "%s/curves.csv", out);
  mgs_read_file(path, &csv, &n, NULL);
  int lines = 0;
  for (char *q = csv; q && *q; q++) lines += *q == '\n';
  CHECK_MSG(lines == 1 + 2 + 2 + 1, "curves.csv has %d lines", lines); /* 2 points per main run, final only for the sweep */
  snprintf(path, sizeof path, "%s/RESULTS.json", out);
  mgs_read_file(path, &js, &n, NULL);
  cJSON *root = cJSON_Parse(js);
  CHECK(root && cJSON_GetObjectItem(root, "runs_finished")->valueint == 3);
  /* figures of one run equal what `morsegs eval` reports for it */
  char run[700];
  snprintf(run, sizeof run, "%s/runs/ds/baseline/seed_1", out);
  CHECK(mgs_test_sh("'%s' eval '%s' --no-images > /dev/null", cli, run) == 0);
  char *ev = NULL;
  snprintf(path, sizeof path, "%s/results.json", run);
  mgs_read_file(path, &ev, &n, NULL);
  cJSON *ej = cJSON_GetObjectItem(cJSON_Parse(ev), "ours_700");
  CHECK(ej != NULL);
  cJSON *geo = cJSON_GetObjectItem(ej, "geometry");
  char want[7][64];
  snprintf(want[0], 64, "%.3f", cJSON_GetObjectItem(ej, "PSNR")->valuedouble);
  snprintf(want[1], 64, "%.4f", cJSON_GetObjectItem(ej, "SSIM")->valuedouble);
  snprintf(want[2], 64, "%.0f", cJSON_GetObjectItem(ej, "gaussians")->valuedouble);
  snprintf(want[3], 64, "%.6g", cJSON_GetObjectItem(geo, "chamfer")->valuedouble);
  snprintf(want[4], 64, "%.4f", cJSON_GetObjectItem(geo, "fscore")->valuedouble);
  snprintf(want[5], 64, "%.0f", cJSON_GetObjectItem(geo, "floaters")->valuedouble);
  const cJSON *fu = cJSON_GetObjectItem(cJSON_GetObjectItem(geo, "fused"), "chamfer");
  snprintf(want[6], 64, "%.6g", cJSON_IsNumber(fu) ? fu->valuedouble : NAN);
  char cells[20][64];
  int nc = row_cells(md, "| ds | baseline | 1 | 700 |", cells);
  CHECK_MSG(nc >= 19, "no RESULTS.md row for baseline seed 1 (%d cells)", nc);
  static const char *what[7] = {"PSNR", "SSIM", "Gaussians", "Chamfer", "F-score", "floaters", "fused Chamfer"};
  static const int col[7] = {4, 5, 6, 7, 8, 9, 16};
  for (int k = 0; k < 7 && nc >= 19; k++)
    CHECK_MSG(!strcmp(cells[col[k]], want[k]), "%s: RESULTS.md %s, morsegs eval %s", what[k], cells[col[k]], want[k]);
  CHECK(cJSON_IsNumber(fu)); /* the fused surface is measured by every run */
  /* --reevaluate: the finished runs another build evaluated (here: records marked so) are
     evaluated again from their saved models, nothing is trained (the models,
     experiment_args and train.log are untouched), the previous records are kept beside the
     new ones; a second --reevaluate has nothing to do; a run whose folder is not this
     command's is refused, named, and left as it was */
  {
    char rs[700], rkeep[700], ekeep[700], tlog[700], *old_rec = NULL, *kept = NULL, *newr = NULL;
    snprintf(rs, sizeof rs, "%s/runs/ds/baseline/seed_1/result.json", out);
    snprintf(rkeep, sizeof rkeep, "%s/runs/ds/baseline/seed_1/result.before-reevaluation.json", out);
    snprintf(ekeep, sizeof ekeep, "%s/runs/ds/baseline/seed_1/eval_700.before-reevaluation.json", out);
    snprintf(tlog, sizeof tlog, "%s/runs/ds/baseline/seed_1/train.log", out);
    /* a run evaluated by this build is not evaluated again */
    const double t_rec = mtime(rs);
    CHECK(mgs_test_sh("'%s'%s --reevaluate > '%s'", cli, cmd, log2) == 0);
    CHECK_MSG(mtime(rs) == t_rec && !mgs_path_exists(rkeep), "--reevaluate redid a run this build had evaluated");
    CHECK(mgs_test_sh("sed -i 's/\"evaluator\":[^,]*,/\"evaluator\": \"0000000000000000\",/' '%s'", rs) == 0);
    mgs_read_file(rs, &old_rec, &n, NULL);
    CHECK_MSG(old_rec && strstr(old_rec, "0000000000000000"), "record without an evaluator: %s", old_rec ? old_rec : "(none)");
    /* --plan counts it */
    CHECK(mgs_test_sh("'%s'%s --reevaluate --plan > '%s'", cli, cmd, log2) == 0);
    char *lp = NULL;
    mgs_read_file(log2, &lp, &n, NULL);
    CHECK_MSG(lp && strstr(lp, "--reevaluate: 1 finished run(s) another build evaluated"), "plan: %s", lp ? lp : "(none)");
    free(lp);
    const double t_model = mtime(second_ply), t_a = mtime(second_args), t_log = mtime(tlog);
    CHECK(mgs_test_sh("'%s'%s --reevaluate > '%s'", cli, cmd, log2) == 0);
    CHECK_MSG(mtime(second_ply) == t_model && mtime(second_args) == t_a && mtime(tlog) == t_log,
              "--reevaluate touched the model, its arguments or its training log");
    char *l4 = NULL;
    mgs_read_file(log2, &l4, &n, NULL);
    CHECK_MSG(l4 && strstr(l4, "seed 1: evaluating its saved models again") && !strstr(l4, "seed 0: evaluating"),
              "log: %s", l4 ? l4 : "(none)");
    free(l4);
    mgs_read_file(rkeep, &kept, &n, NULL);
    mgs_read_file(rs, &newr, &n, NULL);
    CHECK_MSG(old_rec && kept && !strcmp(old_rec, kept), "the previous result.json was not kept");
    CHECK_MSG(mgs_path_exists(ekeep), "the previous eval_700.json was not kept");
    CHECK_MSG(newr && !strstr(newr, "0000000000000000"), "the run was not evaluated again");
    cJSON *a = cJSON_Parse(old_rec ? old_rec : ""), *b = cJSON_Parse(newr ? newr : "");
    const cJSON *ta = cJSON_GetObjectItem(a, "train_cpu_seconds"), *tb = cJSON_GetObjectItem(b, "train_cpu_seconds");
    CHECK(cJSON_IsNumber(ta) && cJSON_IsNumber(tb) && ta->valuedouble == tb->valuedouble);
    cJSON_Delete(a); cJSON_Delete(b);
    free(old_rec); free(kept); free(newr);
    /* records restored on a new machine (no model, no train_stats.json): --reevaluate keeps
       them as they are and says so; the report names the two builds that evaluated the runs */
    {
      char mdp[700], pc[700], pc_away[700], *md2 = NULL, *l5 = NULL, *before_rec = NULL, *after_rec = NULL;
      snprintf(mdp, sizeof mdp, "%s/RESULTS.md", out);
      snprintf(pc, sizeof pc, "%s/runs/ds/baseline/seed_1/point_cloud", out);
      snprintf(pc_away, sizeof pc_away, "%s/runs/ds/baseline/seed_1/point_cloud.away", out);
      CHECK(mgs_test_sh("sed -i 's/\"evaluator\":[^,]*,/\"evaluator\": \"1111111111111111\",/' '%s'", rs) == 0);
      CHECK(rename(pc, pc_away) == 0);
      mgs_read_file(rs, &before_rec, &n, NULL);
      CHECK(mgs_test_sh("'%s'%s --reevaluate > '%s' 2>&1", cli, cmd, log2) == 0);
      mgs_read_file(log2, &l5, &n, NULL);
      mgs_read_file(rs, &after_rec, &n, NULL);
      CHECK_MSG(l5 && strstr(l5, "--reevaluate: 1 finished run(s) another build evaluated have no saved model here") &&
                    !strstr(l5, "evaluating its saved models again") && !strstr(l5, "cannot evaluate again"),
                "log: %s", l5 ? l5 : "(none)");
      CHECK_MSG(before_rec && after_rec && !strcmp(before_rec, after_rec), "a record without its model was changed");
      mgs_read_file(mdp, &md2, &n, NULL);
      CHECK_MSG(md2 && strstr(md2, "evaluated by 2 builds") && strstr(md2, "1111111111111111: 1"),
                "RESULTS.md does not name the builds: %.300s", md2 ? md2 : "(none)");
      CHECK(rename(pc_away, pc) == 0);
      free(md2); free(l5); free(before_rec); free(after_rec);
    }
    char args0[700];
    snprintf(args0, sizeof args0, "%s/runs/ds/baseline/seed_0/experiment_args", out);
    CHECK(mgs_test_sh("echo --changed >> '%s' && sed -i 's/\"evaluator\":[^,]*,/\"evaluator\": \"x\",/' '%s'", args0, first) == 0);
    mgs_test_sh("'%s'%s --reevaluate > '%s' 2>&1", cli, cmd, log2);
    char *l3 = NULL;
    mgs_read_file(log2, &l3, &n, NULL);
    CHECK_MSG(l3 && strstr(l3, "seed_0: cannot evaluate again"), "log: %s", l3 ? l3 : "(none)");
    CHECK(mgs_path_exists(first_ply) && mgs_path_exists(first));
    free(l3);
  }
  free(before); free(after); free(l2); free(md); free(csv); free(js); free(ev);
  return mgs_test_finish();
}
