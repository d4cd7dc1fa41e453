/* morsegs experiment DATA... -o DIR: every dataset x variant x seed trained at the same
 * iterations by `morsegs train`, evaluated at several points by `morsegs eval` and the
 * topology measures of measure/mgs_measure.h, then the H1–H4 verdicts (stats/mgs_stats.h), curves and
 * tables of apps/cmd_experiment_report.c (SPEC §7, issue 10).
 *
 * Each run is a worker process (--jobs of them at a time, default 1) whose train and eval
 * are child processes of this same binary (/proc/self/exe): a run that crashes, aborts on a numerical error or leaks cannot take the harness
 * or the next run with it; its output goes to RUN/train.log and RUN/eval.log; Ctrl-C
 * reaches it as it would reach `morsegs train`; and the child is killed with the harness
 * (PR_SET_PDEATHSIG, worker and child alike), so a killed experiment never leaves a run
 * training behind while the next invocation starts. The worker's verdict comes back as its
 * exit code, its reason through a pipe, its record through RUN/result.json. DIR/.lock (flock) refuses a second experiment on the same DIR.
 *
 * Resume: a run is finished when RUN/result.json exists (written atomically, last);
 * running again on the same DIR keeps finished runs and continues an interrupted one from
 * its last checkpoint when its folder was made by the same command (else starts it again). --reevaluate evaluates
 * the finished runs another build evaluated (result.json's evaluator: a fingerprint of the
 * binary) again from their saved models: never trained again, refused for a folder that is
 * not this command's, previous records kept.
 *
 * Variants are `morsegs train` flag sets (table below). A variant whose flags `morsegs
 * train` rejects (exit code 2, a usage error, before any training) is reported "not
 * available" with train's message; its rows appear once the trainer accepts the flags. */
#define _GNU_SOURCE
#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <limits.h>
#include <stdint.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cjson/cJSON.h>
#include "apps/mgs_cli.h"
#include "apps/mgs_experiment.h"
#include "core/mgs_core.h"
#include "train/mgs_train.h"
#include "topo/mgs_diagram_plot.h"

/* ---------------------------------------------------------------- the variant table */
typedef struct variant_def {
  const char *name;
  const char *args[9];      /* extra `morsegs train` arguments, NULL-terminated */
  const char *knob;         /* densification knob flag, swept for H3 */
  double knob_default;
  int sweep_by_default;     /* one of the densification strategies (ADC, Morse) */
} variant_def;

/* The H3 knob of each family is the one that changes its spawning: ADC's gradient threshold;
 * MorseGS-D's gaps rule spawns at dimension-1/2 pairs of radius <= gap_max (train/
 * strategy_morse.c; tests/train/test_morse_gaps.c shows x0.5 and x2 spawn differently); the
 * literal rules read eps_p (default 0.01, train/morse_analysis.c). morse-i has no literal
 * form that differs (`--literal` changes spawn, prune and L_topo, none of which morse-i
 * uses), so there is no morse-i-literal row. */
static const variant_def VARIANTS[] = {
  {"baseline", {NULL}, "--grad-threshold", 2e-4, 1},
  {"morse-d", {"--preset", "morse-d", NULL}, "--gap-max", 0.05, 1},
  {"morse-r", {"--preset", "morse-r", NULL}, "--grad-threshold", 2e-4, 0},
  {"morse-i", {"--preset", "morse-i", NULL}, "--grad-threshold", 2e-4, 0},
  {"morse-full", {"--preset", "morse-full", NULL}, "--gap-max", 0.05, 1},
  {"morse-d-literal", {"--preset", "morse-d", "--literal", NULL}, "--eps-p", 0.01, 0},
  {"morse-r-literal", {"--preset", "morse-r", "--literal", NULL}, "--grad-threshold", 2e-4, 0},
  {"morse-full-literal", {"--preset", "morse-full", "--literal", NULL}, "--eps-p", 0.01, 0},
  {"topology-gs", {"--preset", "topology-gs", NULL}, "--grad-threshold", 2e-4, 0},
};
#define N_VARIANTS (sizeof VARIANTS / sizeof VARIANTS[0])

static volatile sig_atomic_t g_stop = 0;
static void on_signal(int sig) { (void)sig; g_stop = 1; }

static void usage(FILE *f) {
  fprintf(f,
    "usage: morsegs experiment DATA... -o DIR [options]\n"
    "  Trains every DATA x variant x seed with `morsegs train` (one at a time), evaluates each at\n"
    "  several points with `morsegs eval` plus topology measures against the GT mesh, and writes\n"
    "  DIR/RESULTS.md, DIR/RESULTS.json (H1-H4 verdicts), DIR/curves.csv, DIR/h3.csv and plots\n"
    "  DIR/plots/*.{png,svg}. Running again on the same DIR keeps finished runs.\n"
    "  DATA: a dataset folder (NeRF-synthetic, nerfstudio, COLMAP); GT mesh: its gt_mesh.ply or --mesh\n"
    "  -o, --output DIR       experiment folder (created; reused to resume)\n"
    "      --variants LIST    comma-separated (default: all):\n"
    "                         ");
  for (size_t i = 0; i < N_VARIANTS; i++) fprintf(f, "%s%s", VARIANTS[i].name, i + 1 < N_VARIANTS ? "," : "\n");
  fprintf(f,
    "      --seeds N          seeds 0..N-1 per variant (3)\n"
    "      --iters N          training iterations of every run (30000)\n"
    "      --evals N          evaluation points, evenly spaced, the last at --iters (4)\n"
    "      --eval-at LIST     evaluation iterations instead (the final one is always added)\n"
    "      --mesh GT          ground-truth mesh (one DATA only; default: DATA/gt_mesh.ply)\n"
    "      --sweep LIST       H3: multipliers of each swept variant's densification knob (0.25,0.5,2,4;\n"
    "                         'none' = no sweep); the default run is the multiplier 1\n"
    "      --variant NAME=ARGS  an extra variant: NAME trained with `morsegs train ... ARGS` (ARGS split at\n"
    "                         spaces; listed in --variants when that is given)\n"
    "      --sweep-variants LIST  variants swept (default: baseline,morse-d,morse-full)\n"
    "      --sweep-of V=LIST  variant V's own multipliers instead of --sweep's (a knob with a bounded range:\n"
    "                         --knob mini-splatting=--simplify-fraction:0.5 --sweep-of mini-splatting=0.25,0.5,1.5,2)\n"
    "      --sweep-seeds N    seeds per sweep point (--seeds: H3's Pareto front uses every seed)\n"
    "      --base V=B         measure variant V's changes against variant B instead of baseline (MorseGS\n"
    "                         on another method: --variant 2dgs=--model 2dgs --base morse-2dgs=2dgs)\n"
    "      --knob V=FLAG:VAL  the knob of variant V is `FLAG` with default VAL (e.g. morse-d=--gap-max:0.05)\n"
    "      --train-arg ARG    extra argument for every `morsegs train` (repeatable, e.g. --train-arg=--sh-degree=1)\n"
    "      --eval-views N     evaluate at most N test views (all)\n"
    "      --topo-res N       topology measures: SDF voxel = GT bounding-box diagonal / N (256)\n"
    "      --report-from FROM re-analysis, no training: FROM's curves.csv and RESULTS.json -> the report in\n"
    "                         -o DIR (verdicts compared with FROM's; no DATA; --variants keeps some)\n"
    "      --jobs N           runs at a time, each in its own worker process (1); give each one core:\n"
    "                         MGS_THREADS=1 --jobs 2 on a 2-core machine\n"
    "      --variant-seeds V=N  main runs of variant V with seeds 0..N-1 only (N <= --seeds; e.g. 3 for the\n"
    "                         baselines no MorseGS variant is measured against)\n"
    "      --first LIST       in each seed, these variants' runs on every dataset come before the others'\n"
    "                         (e.g. the baselines, so that a run stopped early compares them on every scene)\n"
    "      --plan             print the runs, how many are finished and the estimated time; train nothing\n"
    "      --reevaluate       the finished runs another build evaluated are evaluated again by this one (their\n"
    "                         saved models, never trained again; after the evaluation changed; resumable):\n"
    "                         the previous result.json and eval_N.json are kept as *.before-reevaluation.json;\n"
    "                         runs with no saved model here (records restored from git) keep their records\n"
    "  Environment: MGS_THREADS=N limits the worker threads of the harness and its children.\n"
    "  Variants whose flags `morsegs train` rejects are reported as not available.\n");
}

/* ---------------------------------------------------------------- small helpers */
typedef struct strlist { char **v; size_t n; } strlist;
static void sl_push(strlist *l, const char *s) {
  char **p = realloc(l->v, (l->n + 1) * sizeof *p);
  if (!p) return;
  l->v = p;
  l->v[l->n++] = mgs_strdup(s);
}
static void sl_free(strlist *l) {
  for (size_t i = 0; i < l->n; i++) free(l->v[i]);
  free(l->v);
  l->v = NULL; l->n = 0;
}
static void sl_split(strlist *l, const char *csv) {
  char *dup = mgs_strdup(csv), *save = NULL;
  for (char *t = strtok_r(dup, ",", &save); t; t = strtok_r(NULL, ",", &save))
    if (*t) sl_push(l, t);
  free(dup);
}

static void fmt_duration(double s, char *buf, size_t n) {
  if (!(s >= 0) || !isfinite(s)) { snprintf(buf, n, "?"); return; }
  long t = (long)(s + 0.5);
  if (t >= 3600) snprintf(buf, n, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else snprintf(buf, n, "%ldm%02lds", t / 60, t % 60);
}

static double load_avg(void) {
  double l = NAN;
  FILE *f = fopen("/proc/loadavg", "r");
  if (f) { if (fscanf(f, "%lf", &l) != 1) l = NAN; fclose(f); }
  return l;
}

static double mtime_of(const char *path) {
  struct stat sb;
  if (stat(path, &sb) != 0) return NAN;
  return (double)sb.st_mtim.tv_sec + 1e-9 * (double)sb.st_mtim.tv_nsec;
}

/* First line of a log that names the problem (train's own message, else getopt's). */
static void log_reason(const char *log, char *out, size_t n) {
  out[0] = 0;
  FILE *f = fopen(log, "r");
  if (!f) return;
  char line[1024], first[1024] = "";
  while (fgets(line, sizeof line, f)) {
    line[strcspn(line, "\n")] = 0;
    if (!first[0] && line[0]) snprintf(first, sizeof first, "%s", line);
    if (!strncmp(line, "morsegs", 7)) { snprintf(out, n, "%s", line); break; }
  }
  if (!out[0]) snprintf(out, n, "%s", first);
  fclose(f);
}

/* Temporary files of atomic writes that a killed experiment left in DIR and DIR/plots (only
 * names of the form <our output>.tmp-*; the folder is locked, so no writer is running). */
static void remove_stale_temps(const char *dir) {
  const char *sub[2] = {"", "plots"};
  for (int k = 0; k < 2; k++) {
    char *d = k ? mgs_path_join(dir, sub[k]) : mgs_strdup(dir);
    DIR *h = d ? opendir(d) : NULL;
    struct dirent *ent;
    while (h && (ent = readdir(h))) {
      if (!strstr(ent->d_name, ".tmp-")) continue;
      if (strncmp(ent->d_name, "RESULTS.", 8) && strncmp(ent->d_name, "curves.csv", 10) &&
          strncmp(ent->d_name, "h3.csv", 6) && strncmp(ent->d_name, "experiment.json", 15) && !k) continue;
      char *p = mgs_path_join(d, ent->d_name);
      if (p) unlink(p);
      free(p);
    }
    if (h) closedir(h);
    free(d);
  }
}

/* ---------------------------------------------------------------- child processes */
static char g_exe[PATH_MAX];

/* Runs `morsegs ARGS...` with stdout/stderr appended to log; returns its exit code (128+sig
 * when killed by a signal, -1 when it could not start). Forwards SIGINT on Ctrl-C/SIGTERM. */
static int run_child(char *const argv[], const char *log) {
  pid_t parent = getpid();
  fflush(stdout);
  fflush(stderr);
  pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    int fd = open(log, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd >= 0) { dup2(fd, 1); dup2(fd, 2); }
    execv(g_exe, argv);
    _exit(127);
  }
  int status = 0, forwarded = 0;
  for (;;) {
    pid_t r = waitpid(pid, &status, 0);
    if (r == pid) break;
    if (r < 0 && errno != EINTR) return -1;
    if (g_stop && !forwarded) { kill(pid, SIGINT); forwarded = 1; }
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

/* ---------------------------------------------------------------- the plan */
typedef struct plan_item {
  size_t ds, var;
  int seed;
  double factor;
  int sweep;
  char dir[PATH_MAX];
} plan_item;

typedef struct dataset_in {
  char name[EXP_NAME];
  char path[PATH_MAX];
  char mesh[PATH_MAX];
  exp_truth truth;
} dataset_in;

typedef struct variant_sel {
  const variant_def *def;
  char knob[64];
  double knob_default;
  int sweep;
  exp_variant_status status;
  int sweep_unavailable;
  char sweep_reason[1024];
  int seeds;                  /* main runs of this variant: seeds 0..seeds-1 (--variant-seeds; else --seeds) */
  int first;                  /* --first: its runs of a seed come before the others' */
  double sweep_of[16];        /* --sweep-of: this variant's multipliers instead of --sweep's */
  int n_sweep_of;             /* -1: --sweep's */
} variant_sel;

typedef struct experiment {
  const char *dir;
  int iters, seeds, sweep_seeds, eval_views, topo_res;
  int evals[EXP_MAX_POINTS];
  int n_evals;
  double sweep[16];
  int n_sweep;
  strlist train_args;
  dataset_in *ds;
  size_t n_ds;
  variant_sel *vars;
  size_t n_vars;
  exp_run *runs;
  size_t n_runs, cap_runs;
  char *command_line;
  double load_start;
  size_t planned;
  int failures, jobs;
  int reevaluate;             /* --reevaluate: finished runs evaluated by another binary are evaluated again, never trained */
  char evaluator[24];         /* this binary's fingerprint (exp_run.evaluator) */
} experiment;

/* FNV-1a 64 of this binary's bytes: which build evaluated a run (a rebuilt binary that
 * evaluates differently has other bytes; the same build anywhere has the same). */
static void binary_fingerprint(char out[24]) {
  uint64_t h = 1469598103934665603ull;
  FILE *f = fopen("/proc/self/exe", "rb");
  unsigned char buf[1 << 16];
  size_t n;
  while (f && (n = fread(buf, 1, sizeof buf, f)) > 0)
    for (size_t i = 0; i < n; i++) h = (h ^ buf[i]) * 1099511628211ull;
  if (f) fclose(f);
  snprintf(out, 24, "%016llx", (unsigned long long)h);
}

/* The run's final model and train_stats.json, which --reevaluate needs (records restored
 * from git have neither). */
static int run_trained(const char *dir, int iters) {
  char *stats = mgs_path_join(dir, "train_stats.json");
  const int ok = stats && isfinite(mgs_run_saved_seconds(dir, iters)) && mgs_path_exists(stats);
  free(stats);
  return ok;
}

static int has_saved_model(const char *dir, int iters) {
  char rel[64];
  snprintf(rel, sizeof rel, "point_cloud/iteration_%d/point_cloud.ply", iters);
  char *ply = mgs_path_join(dir, rel);
  const int ok = ply && mgs_path_exists(ply) && run_trained(dir, iters);
  free(ply);
  return ok;
}

/* --reevaluate: a finished run whose record another binary wrote. */
static int needs_reevaluation(const experiment *e, const exp_run *r) {
  return e->reevaluate && strcmp(r->evaluator, e->evaluator) != 0;
}

static exp_run *push_run(experiment *e) {
  if (e->n_runs == e->cap_runs) {
    size_t cap = e->cap_runs ? 2 * e->cap_runs : 16;
    exp_run *p = realloc(e->runs, cap * sizeof *p);
    if (!p) return NULL;
    e->runs = p;
    e->cap_runs = cap;
  }
  exp_run *r = &e->runs[e->n_runs++];
  memset(r, 0, sizeof *r);
  return r;
}

static mgs_status write_report(experiment *e, mgs_error *err) {
  const char **names = calloc(e->n_ds ? e->n_ds : 1, sizeof *names);
  exp_truth *truths = calloc(e->n_ds ? e->n_ds : 1, sizeof *truths);
  exp_variant_status *vs = calloc(e->n_vars ? e->n_vars : 1, sizeof *vs);
  if (!names || !truths || !vs) { free(names); free(truths); free(vs); return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); }
  for (size_t i = 0; i < e->n_ds; i++) { names[i] = e->ds[i].name; truths[i] = e->ds[i].truth; }
  char knobs[4096] = "";
  for (size_t v = 0; v < e->n_vars; v++) {
    vs[v] = e->vars[v].status;
    const variant_sel *sv = &e->vars[v];
    const int n_mult = sv->n_sweep_of >= 0 ? sv->n_sweep_of : e->n_sweep;
    const double *mult = sv->n_sweep_of >= 0 ? sv->sweep_of : e->sweep;
    if (sv->sweep && n_mult) {
      size_t l = strlen(knobs);
      snprintf(knobs + l, sizeof knobs - l, "%s%s: %s %g x {1", l ? "; " : "", e->vars[v].def->name, e->vars[v].knob,
               e->vars[v].knob_default);
      for (int k = 0; k < n_mult; k++) { l = strlen(knobs); snprintf(knobs + l, sizeof knobs - l, ", %g", mult[k]); }
      l = strlen(knobs);
      snprintf(knobs + l, sizeof knobs - l, "}%s%.300s", e->vars[v].sweep_unavailable ? " (not available: " : "",
               e->vars[v].sweep_unavailable ? e->vars[v].sweep_reason : "");
      if (e->vars[v].sweep_unavailable) { l = strlen(knobs); snprintf(knobs + l, sizeof knobs - l, ")"); }
    }
  }
  exp_report_in in = {.dir = e->dir, .command_line = e->command_line, .iters = e->iters, .seeds = e->seeds,
                      .knob_desc = knobs, .n_datasets = e->n_ds, .dataset_names = names, .truths = truths,
                      .n_variants = e->n_vars, .variants = vs, .n_runs = e->n_runs, .runs = e->runs,
                      .planned_runs = e->planned, .load_start = e->load_start};
  mgs_status st = exp_report_write(&in, err);
  free(names); free(truths); free(vs);
  return st;
}

/* One evaluation-phase command into log: 0 done, 3 interrupted, 1 failed (reason filled). */
static int run_step(const char **argv, const char *log, const char *what, char *reason, size_t reason_n) {
  int rc = run_child((char *const *)argv, log);
  if (g_stop || rc == 130) return 3;
  if (rc == 0) return 0;
  log_reason(log, reason, reason_n);
  if (!reason[0]) snprintf(reason, reason_n, "%s exited with code %d (see %s)", what, rc, log);
  return 1;
}

/* CPU seconds of this process and its waited-for children so far. */
static double cpu_with_children(void) {
  struct rusage s, c;
  if (getrusage(RUSAGE_SELF, &s) || getrusage(RUSAGE_CHILDREN, &c)) return NAN;
  return (double)(s.ru_utime.tv_sec + s.ru_stime.tv_sec + c.ru_utime.tv_sec + c.ru_stime.tv_sec) +
         1e-6 * (double)(s.ru_utime.tv_usec + s.ru_stime.tv_usec + c.ru_utime.tv_usec + c.ru_stime.tv_usec);
}

/* Trains and evaluates one run; returns 0 done, 1 failed (recorded), 2 variant not
 * available, 3 interrupted. */
static int do_run(experiment *e, const plan_item *it, exp_run *out, char *reason, size_t reason_n) {
  const double run_t0 = mgs_now();
  const variant_sel *vs = &e->vars[it->var];
  const dataset_in *ds = &e->ds[it->ds];
  mgs_error err;
  mgs_error_clear(&err);
  reason[0] = 0;
  /* train */
  char iters_s[32], seed_s[32], knob_s[64], save_s[512] = "", ckpt_s[32];
  snprintf(iters_s, sizeof iters_s, "%d", e->iters);
  /* a checkpoint every tenth of the run: a run killed part-way (the machine's session
     ended) continues from its last one, not from the start */
  snprintf(ckpt_s, sizeof ckpt_s, "%d", e->iters / 10 > 100 ? e->iters / 10 : 100);
  snprintf(seed_s, sizeof seed_s, "%d", it->seed);
  snprintf(knob_s, sizeof knob_s, "%.6g", vs->knob_default * it->factor);
  if (!it->sweep)
    for (int k = 0; k < e->n_evals; k++)
      if (e->evals[k] < e->iters) {
        size_t l = strlen(save_s);
        snprintf(save_s + l, sizeof save_s - l, "%s%d", l ? "," : "", e->evals[k]);
      }
  const char *argv[64];
  int a = 0;
  argv[a++] = "morsegs"; argv[a++] = "train"; argv[a++] = ds->path; argv[a++] = "-o"; argv[a++] = it->dir;
  argv[a++] = "--iters"; argv[a++] = iters_s; argv[a++] = "--seed"; argv[a++] = seed_s;
  if (save_s[0]) { argv[a++] = "--save-at"; argv[a++] = save_s; } /* else train's default (harmless) */
  argv[a++] = "--checkpoint-every"; argv[a++] = ckpt_s;
  argv[a++] = "--quiet";
  for (int k = 0; vs->def->args[k] && a < 40; k++) argv[a++] = vs->def->args[k];
  if (it->factor != 1.0) { argv[a++] = vs->knob; argv[a++] = knob_s; }
  for (size_t k = 0; k < e->train_args.n && a < 61; k++) argv[a++] = e->train_args.v[k];
  const int mode_at = a; /* --force (a new run) or --resume (an interrupted one) */
  argv[a++] = "--force";
  argv[a] = NULL;
  /* the run's command without its mode: a folder left by a run with the same command
     continues; anything else is started again */
  char sig[8192] = "";
  for (int k = 0; k < mode_at; k++) {
    size_t l = strlen(sig);
    snprintf(sig + l, sizeof sig - l, "%s\n", argv[k]);
  }
  char *sigp = mgs_path_join(it->dir, "experiment_args"), *ckpt = mgs_path_join(it->dir, "checkpoint.mgsckpt");
  int trained = 0, resume = 0;
  {
    char *text = NULL;
    size_t n = 0;
    if (mgs_is_dir(it->dir) && mgs_read_file(sigp, &text, &n, NULL) == MGS_OK && n == strlen(sig) && !memcmp(text, sig, n)) {
      trained = run_trained(it->dir, e->iters);
      resume = !trained && mgs_path_exists(ckpt);
    }
    free(text);
  }
  /* --reevaluate: a finished run keeps its model; its old records are kept beside it */
  char *prev_record = mgs_path_join(it->dir, "result.json");
  exp_run prev;
  const int reeval = e->reevaluate && prev_record && mgs_path_exists(prev_record) &&
                     exp_run_read(prev_record, &prev, &err) == MGS_OK && needs_reevaluation(e, &prev);
  free(prev_record);
  if (reeval && !trained) {
    snprintf(reason, reason_n, "%.700s: cannot evaluate again: its experiment_args differ from this command's, or its "
             "final model or train_stats.json is missing (nothing was changed)", it->dir);
    free(sigp); free(ckpt);
    return 1;
  }
  if (reeval) {
    char name[64], keep[96];
    for (int k = -1; k < e->n_evals; k++) {
      if (k < 0) snprintf(name, sizeof name, "result.json");
      else snprintf(name, sizeof name, "eval_%d.json", e->evals[k]);
      snprintf(keep, sizeof keep, "%.*s.before-reevaluation.json", (int)(strlen(name) - 5), name);
      char *from = mgs_path_join(it->dir, name), *to = mgs_path_join(it->dir, keep);
      if (from && to && mgs_path_exists(from) && rename(from, to)) {
        snprintf(reason, reason_n, "%.900s: cannot keep %s: %s", it->dir, name, strerror(errno));
        free(from); free(to); free(sigp); free(ckpt);
        return 1;
      }
      free(from); free(to);
    }
  }
  if (!trained && !resume) {
    if (mgs_is_dir(it->dir) && mgs_remove_tree(it->dir, &err)) { snprintf(reason, reason_n, "%s", err.msg); free(sigp); free(ckpt); return 1; }
    if (mgs_mkdir_p(it->dir, &err) || mgs_write_file_atomic(sigp, sig, strlen(sig), &err)) {
      snprintf(reason, reason_n, "%s", err.msg); free(sigp); free(ckpt); return 1;
    }
  }
  free(sigp);
  char *tlog = mgs_path_join(it->dir, "train.log"), *elog = mgs_path_join(it->dir, "eval.log");
  int rc = 0;
  if (resume) argv[mode_at] = "--resume";
  if (!trained) rc = run_child((char *const *)argv, tlog);
  int result = 0;
  if (g_stop || rc == 130) { result = 3; goto done; }
  if (rc == 2) {
    log_reason(tlog, reason, reason_n);
    result = 2;
    goto done;
  }
  if (rc != 0) {
    log_reason(tlog, reason, reason_n);
    if (!reason[0]) snprintf(reason, reason_n, "morsegs train exited with code %d (see %s)", rc, tlog);
    result = 1;
    goto done;
  }
  memset(out, 0, sizeof *out);
  snprintf(out->dataset, sizeof out->dataset, "%s", ds->name);
  snprintf(out->variant, sizeof out->variant, "%s", vs->def->name);
  out->seed = it->seed;
  out->factor = it->factor;
  out->iters = e->iters;
  out->train_seconds = out->analysis_seconds = out->train_cpu_seconds = NAN;
  const double eval_cpu0 = cpu_with_children(); /* the training child is waited for: not in the difference */
  {
    char *sp = mgs_path_join(it->dir, "train_stats.json"), *text = NULL;
    size_t n;
    if (sp && mgs_read_file(sp, &text, &n, NULL) == MGS_OK) {
      cJSON *j = cJSON_Parse(text);
      /* the trainer writes morse_analysis_seconds (MorseGS variants only) */
      const cJSON *t = cJSON_GetObjectItem(j, "train_seconds"), *an = cJSON_GetObjectItem(j, "morse_analysis_seconds");
      if (cJSON_IsNumber(t)) out->train_seconds = t->valuedouble;
      if (cJSON_IsNumber(an)) out->analysis_seconds = an->valuedouble;
      const cJSON *cpu = cJSON_GetObjectItem(j, "train_cpu_seconds");
      if (cJSON_IsNumber(cpu)) out->train_cpu_seconds = cpu->valuedouble;
      cJSON_Delete(j);
    }
    free(text);
    free(sp);
    if (!isfinite(out->train_seconds)) { snprintf(reason, reason_n, "%.900s: no train_seconds in train_stats.json", it->dir); result = 1; goto done; }
  }
  char fin_ply[PATH_MAX + 64];
  snprintf(fin_ply, sizeof fin_ply, "%s/point_cloud/iteration_%d/point_cloud.ply", it->dir, e->iters);
  const double t_final = mtime_of(fin_ply);
  /* SuGaR's surface is its mesh: made from the final model before the final evaluation
     point, which then reports it (geometry.sugar) */
  int sugar = 0;
  for (int k = 0; vs->def->args[k] && vs->def->args[k + 1]; k++)
    sugar |= !strcmp(vs->def->args[k], "--preset") && !strcmp(vs->def->args[k + 1], "sugar");
  /* evaluation points */
  for (int k = 0; k < e->n_evals; k++) {
    int iter = e->evals[k];
    if (it->sweep && iter != e->iters) continue;
    if (sugar && iter == e->iters) {
      const char *mv[] = {"morsegs", "vdb", it->dir, "--sugar-mesh", "--force", NULL}; /* an interrupted evaluation's mesh, or --reevaluate */
      if ((result = run_step(mv, elog, "morsegs vdb --sugar-mesh", reason, reason_n))) goto done;
    }
    char ply[PATH_MAX + 64];
    snprintf(ply, sizeof ply, "%s/point_cloud/iteration_%d/point_cloud.ply", it->dir, iter);
    if (!mgs_path_exists(ply)) continue;
    char iter_s[32], views_s[32];
    snprintf(iter_s, sizeof iter_s, "%d", iter);
    snprintf(views_s, sizeof views_s, "%d", e->eval_views);
    const char *ev[16];
    int b = 0;
    ev[b++] = "morsegs"; ev[b++] = "eval"; ev[b++] = it->dir; ev[b++] = "--iteration"; ev[b++] = iter_s;
    ev[b++] = "--no-images";
    if (ds->mesh[0]) { ev[b++] = "--mesh"; ev[b++] = ds->mesh; }
    if (e->eval_views > 0) { ev[b++] = "--max-views"; ev[b++] = views_s; }
    ev[b] = NULL;
    if ((result = run_step(ev, elog, "morsegs eval", reason, reason_n))) goto done;
    exp_point *p = &out->pt[out->n_points];
    memset(p, 0, sizeof *p);
    p->iteration = iter;
    const double m0 = mgs_now();
    if (exp_read_eval(it->dir, iter, p, &err)) { snprintf(reason, reason_n, "%s", err.msg); result = 1; goto done; }
    if (iter != e->iters) p->chamfer_mesh = p->fscore_mesh = NAN; /* a mesh left by an interrupted evaluation is the final model's */
    /* keep eval's own record of this point beside the run */
    {
      char *rp = mgs_path_join(it->dir, "results.json"), *text = NULL, name[64];
      size_t n;
      snprintf(name, sizeof name, "eval_%d.json", iter);
      char *cp = mgs_path_join(it->dir, name);
      if (rp && cp && mgs_read_file(rp, &text, &n, NULL) == MGS_OK) mgs_write_file_atomic(cp, text, n, NULL);
      free(text); free(rp); free(cp);
    }
    /* training wall time at this save: the trainer's total minus the time between this
       .ply and the final one (the final .ply is written right after the last iteration) */
    double tn = mtime_of(ply), ts = mgs_run_saved_seconds(it->dir, iter);
    p->wall_seconds = isfinite(ts) ? ts : isfinite(t_final) && isfinite(tn) ? fmax(0.0, out->train_seconds - (t_final - tn)) : NAN;
    if (iter == e->iters) p->wall_seconds = out->train_seconds;
    for (int q = 0; q < 3; q++) p->betti[q] = p->betti_persistent[q] = -1;
    p->floater_mass = p->floater_mass_fraction = p->bottleneck = NAN;
    if (!it->sweep && exp_measure_topology(ply, &ds->truth, p, &err)) {
      snprintf(reason, reason_n, "topology of %.400s: %.600s", ply, err.msg);
      result = 1;
      goto done;
    }
    p->measure_seconds = mgs_now() - m0;
    out->n_points++;
  }
  if (out->n_points == 0) { snprintf(reason, reason_n, "%.900s: no saved model to evaluate", it->dir); result = 1; goto done; }
  snprintf(out->evaluator, sizeof out->evaluator, "%s", e->evaluator);
  out->run_seconds = reeval ? prev.run_seconds : mgs_now() - run_t0; /* re-evaluated: the run's own wall time */
  out->eval_cpu_seconds = cpu_with_children() - eval_cpu0;
  {
    char *rp = mgs_path_join(it->dir, "result.json");
    if (exp_run_write(rp, out, &err)) { snprintf(reason, reason_n, "%s", err.msg); result = 1; }
    else remove(ckpt); /* a finished run is never resumed: its checkpoint is only disk */
    free(rp);
  }
done:
  free(ckpt);
  free(tlog);
  free(elog);
  return result;
}


/* ---------------------------------------------------------------- workers (--jobs) */
typedef struct job {
  pid_t pid;
  int fd;           /* read end of the worker's reason pipe */
  size_t item, idx;
  double t0;
  char label[512];
} job;

/* Forks a worker that runs plan item `it` (do_run) and exits with its result code. */
static pid_t start_job(experiment *e, const plan_item *it, int *fd_out) {
  int p[2];
  if (pipe2(p, O_CLOEXEC)) return -1;
  pid_t parent = getpid();
  fflush(stdout);
  fflush(stderr);
  pid_t pid = fork();
  if (pid < 0) { close(p[0]); close(p[1]); return -1; }
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(3);
    close(p[0]);
    exp_run r;
    char reason[1024];
    int res = do_run(e, it, &r, reason, sizeof reason);
    size_t n = strlen(reason);
    if (n && write(p[1], reason, n) < 0) res = res ? res : 1;
    _exit(res);
  }
  close(p[1]);
  *fd_out = p[0];
  return pid;
}

/* The worker's result: 0 done, 1 failed, 2 not available, 3 interrupted (as do_run). */
static int finish_job(job *j, int status, char *reason, size_t reason_n) {
  size_t got = 0;
  ssize_t r;
  while (got + 1 < reason_n && ((r = read(j->fd, reason + got, reason_n - 1 - got)) > 0 || (r < 0 && errno == EINTR)))
    if (r > 0) got += (size_t)r;
  reason[got] = 0;
  close(j->fd);
  if (WIFEXITED(status) && WEXITSTATUS(status) <= 3) return WEXITSTATUS(status);
  if (g_stop) return 3;
  if (!reason[0]) snprintf(reason, reason_n, "the run's worker process ended with status %d", status);
  return 1;
}

/* ---------------------------------------------------------------- --plan */
static double dataset_pixels(const dataset_in *d) {
  mgs_dataset_options o;
  mgs_dataset_options_default(&o);
  o.load_images = 0;
  mgs_dataset *ds = NULL;
  mgs_error err;
  double px = 800.0 * 800.0;
  if (mgs_dataset_load(d->path, &o, &ds, &err) == MGS_OK && ds->n_views[MGS_SPLIT_TRAIN] > 0) {
    const mgs_camera *c = &ds->views[MGS_SPLIT_TRAIN][0].cam;
    px = (double)c->width * (double)c->height;
  }
  mgs_dataset_destroy(ds);
  return px;
}

/* One core's seconds a finished run took: its CPU time (training, across resumes, plus its
   evaluation points) where recorded; else its wall time, which on a shared machine and for a
   run resumed after a stop (only its last part is timed) says less. */
static double run_cost(const exp_run *r) {
  if (isfinite(r->train_cpu_seconds) && isfinite(r->eval_cpu_seconds)) return r->train_cpu_seconds + r->eval_cpu_seconds;
  return r->run_seconds;
}

/* The mean one-core cost of the finished runs of `variant`, NAN when none has finished. */
static double variant_cost(const experiment *e, const char *variant) {
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < e->n_runs; i++)
    if (!strcmp(e->runs[i].variant, variant) && isfinite(run_cost(&e->runs[i]))) { sum += run_cost(&e->runs[i]); n++; }
  return n ? sum / n : NAN;
}

/* One core's seconds plan item i is expected to take: its variant's finished runs, else the
   baseline's times the variant's cost factor, else the prior from bench figures (px: the
   datasets' pixels per view). *from (may be NULL) says which. */
static double item_estimate(const experiment *e, const plan_item *plan, size_t i, const double *px, const char **from) {
  const variant_sel *vs = &e->vars[plan[i].var];
  double est = variant_cost(e, vs->def->name);
  const char *src = "its finished runs";
  if (!isfinite(est)) {
    const double base = variant_cost(e, "baseline");
    if (isfinite(base)) {
      est = base * exp_variant_cost_factor(vs->def->args);
      src = "baseline's finished runs × factor";
    } else {
      est = exp_run_cost_prior(vs->def->args, e->iters, px[plan[i].ds], plan[i].sweep ? 1 : e->n_evals);
      src = "prior (bench figures)";
    }
  }
  if (from) *from = src;
  return est;
}

static double *datasets_pixels(const experiment *e) {
  double *px = calloc(e->n_ds ? e->n_ds : 1, sizeof *px);
  if (px)
    for (size_t d = 0; d < e->n_ds; d++) px[d] = dataset_pixels(&e->ds[d]);
  return px;
}

/* Prints the plan and its estimated time; nothing is trained or written. */
static void print_plan(const experiment *e, const plan_item *plan, size_t np, const unsigned char *done) {
  double *px = datasets_pixels(e);
  if (!px) return;
  printf("plan for %s: %zu runs, %d iterations each, %d evaluation points\n", e->dir, np, e->iters, e->n_evals);
  printf("| variant | runs | finished | to run | estimated s per run (one core) | from |\n|---|---|---|---|---|---|\n");
  double total = 0;
  size_t todo_all = 0;
  for (size_t v = 0; v < e->n_vars; v++) {
    size_t runs = 0, fin = 0, todo = 0;
    double est_sum = 0;
    const char *from = NULL;
    for (size_t i = 0; i < np; i++) {
      if (plan[i].var != v) continue;
      runs++;
      if (done[i]) { fin++; continue; }
      todo++;
      est_sum += item_estimate(e, plan, i, px, &from);
    }
    if (!from) from = isfinite(variant_cost(e, e->vars[v].def->name)) ? "its finished runs" : "-";
    total += est_sum;
    todo_all += todo;
    printf("| %s | %zu | %zu | %zu | %.0f | %s |\n", e->vars[v].def->name, runs, fin, todo, todo ? est_sum / (double)todo : 0.0, from);
  }
  char a[32], b[32];
  fmt_duration(total, a, sizeof a);
  fmt_duration(total / (e->jobs > 0 ? e->jobs : 1), b, sizeof b);
  printf("to run: %zu runs, about %s on one core; with --jobs %d (MGS_THREADS=1 each, one core per job) about %s of wall "
         "time on an otherwise idle machine\n", todo_all, a, e->jobs, b);
  printf("next:");
  int shown = 0;
  for (size_t i = 0; i < np && shown < 8; i++) {
    if (done[i]) continue;
    const char *rel = plan[i].dir + strlen(e->dir);
    printf("%s %s", shown ? "," : "", !strncmp(rel, "/runs/", 6) ? rel + 6 : plan[i].dir);
    shown++;
  }
  printf("%s\n", shown ? (todo_all > (size_t)shown ? ", ..." : "") : " nothing");
  free(px);
}

/* ---------------------------------------------------------------- the command */
static int parse_int(const char *s, const char *name, int lo, int *out) {
  char *end;
  long v = strtol(s, &end, 10);
  if (!*s || *end || v < lo || v > INT_MAX) {
    fprintf(stderr, "morsegs experiment: %s needs an integer >= %d (got '%s')\n", name, lo, s);
    return 0;
  }
  *out = (int)v;
  return 1;
}

static int cmp_int(const void *a, const void *b) { return (*(const int *)a > *(const int *)b) - (*(const int *)a < *(const int *)b); }

/* DIR/experiment.json: the settings every run of DIR must share. */
static int check_settings(experiment *e, mgs_error *err) {
  char *path = mgs_path_join(e->dir, "experiment.json"), *text = NULL;
  size_t n;
  int ok = 1;
  if (mgs_path_exists(path)) {
    if (mgs_read_file(path, &text, &n, err) != MGS_OK) { free(path); return 0; }
    cJSON *j = cJSON_Parse(text);
    const cJSON *it = cJSON_GetObjectItem(j, "iterations"), *ev = cJSON_GetObjectItem(j, "evaluations");
    const cJSON *tr = cJSON_GetObjectItem(j, "topo_res");
    int same = cJSON_IsNumber(it) && it->valueint == e->iters && cJSON_IsArray(ev) && cJSON_GetArraySize(ev) == e->n_evals &&
               cJSON_IsNumber(tr) && tr->valueint == e->topo_res;
    for (int k = 0; same && k < e->n_evals; k++) same = cJSON_GetArrayItem(ev, k)->valueint == e->evals[k];
    if (!same) {
      mgs_error_set(err, MGS_ERR_ARG, "%s: this folder holds an experiment with other iterations or evaluation points (%s); "
                    "use another -o DIR or the same --iters/--evals/--topo-res", e->dir, text);
      ok = 0;
    }
    cJSON_Delete(j);
    free(text);
  } else {
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "format", "morsegs-experiment");
    cJSON_AddNumberToObject(j, "iterations", e->iters);
    cJSON_AddItemToObject(j, "evaluations", cJSON_CreateIntArray(e->evals, e->n_evals));
    cJSON_AddNumberToObject(j, "topo_res", e->topo_res);
    char *t = cJSON_PrintUnformatted(j);
    cJSON_Delete(j);
    ok = t && mgs_write_file_atomic(path, t, strlen(t), err) == MGS_OK;
    free(t);
  }
  free(path);
  return ok;
}

int mgs_cmd_experiment(int argc, char **argv) {
  enum { O_VARIANTS = 1000, O_SEEDS, O_ITERS, O_EVALS, O_EVAL_AT, O_MESH, O_SWEEP, O_SWEEP_VARS, O_SWEEP_SEEDS, O_KNOB,
         O_TRAIN_ARG, O_EVAL_VIEWS, O_TOPO_RES, O_VARIANT, O_REPORT_FROM, O_BASE, O_JOBS, O_PLAN, O_VARIANT_SEEDS, O_FIRST, O_SWEEP_OF, O_REEVALUATE, O_HELP };
  static const struct option opts[] = {
    {"output", required_argument, 0, 'o'}, {"variants", required_argument, 0, O_VARIANTS},
    {"seeds", required_argument, 0, O_SEEDS}, {"iters", required_argument, 0, O_ITERS},
    {"evals", required_argument, 0, O_EVALS}, {"eval-at", required_argument, 0, O_EVAL_AT},
    {"mesh", required_argument, 0, O_MESH}, {"sweep", required_argument, 0, O_SWEEP},
    {"sweep-variants", required_argument, 0, O_SWEEP_VARS}, {"sweep-seeds", required_argument, 0, O_SWEEP_SEEDS},
    {"knob", required_argument, 0, O_KNOB}, {"train-arg", required_argument, 0, O_TRAIN_ARG},
    {"eval-views", required_argument, 0, O_EVAL_VIEWS}, {"topo-res", required_argument, 0, O_TOPO_RES},
    {"variant", required_argument, 0, O_VARIANT}, {"report-from", required_argument, 0, O_REPORT_FROM},
    {"base", required_argument, 0, O_BASE}, {"jobs", required_argument, 0, O_JOBS}, {"plan", no_argument, 0, O_PLAN}, {"reevaluate", no_argument, 0, O_REEVALUATE},
    {"variant-seeds", required_argument, 0, O_VARIANT_SEEDS}, {"first", required_argument, 0, O_FIRST},
    {"sweep-of", required_argument, 0, O_SWEEP_OF},
    {"help", no_argument, 0, O_HELP}, {0, 0, 0, 0}};
  experiment e;
  memset(&e, 0, sizeof e);
  e.iters = 30000; e.seeds = 3; e.sweep_seeds = 0; e.topo_res = EXP_TOPO_RES; /* sweep_seeds 0: as --seeds */
  int n_evals = 4, rc = 1, lock_fd = -1, plan_only = 0;
  e.jobs = 1;
  binary_fingerprint(e.evaluator);
  const char *variants = NULL, *eval_at = NULL, *mesh = NULL, *sweep = "0.25,0.5,2,4", *sweep_vars = NULL, *report_from = NULL;
  strlist knobs = {0}, vlist = {0}, svlist = {0}, custom = {0}, bases = {0}, vseeds = {0}, firsts = {0}, sweep_ofs = {0};
  variant_def custom_defs[16];
  char custom_buf[16][512];
  size_t n_custom = 0;
  int c;
  optind = 1;
  while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
    switch (c) {
      case 'o': e.dir = optarg; break;
      case O_VARIANTS: variants = optarg; break;
      case O_VARIANT: sl_push(&custom, optarg); break;
      case O_BASE: sl_push(&bases, optarg); break;
      case O_VARIANT_SEEDS: sl_push(&vseeds, optarg); break;
      case O_FIRST: sl_split(&firsts, optarg); break;
      case O_SWEEP_OF: sl_push(&sweep_ofs, optarg); break;
      case O_SEEDS: if (!parse_int(optarg, "--seeds", 1, &e.seeds) || e.seeds > 64) { fprintf(stderr, "morsegs experiment: --seeds must be 1..64\n"); return 2; } break;
      case O_ITERS: if (!parse_int(optarg, "--iters", 1, &e.iters)) return 2; break;
      case O_EVALS: if (!parse_int(optarg, "--evals", 1, &n_evals) || n_evals > EXP_MAX_POINTS) { fprintf(stderr, "morsegs experiment: --evals must be 1..%d\n", EXP_MAX_POINTS); return 2; } break;
      case O_EVAL_AT: eval_at = optarg; break;
      case O_MESH: mesh = optarg; break;
      case O_SWEEP: sweep = optarg; break;
      case O_SWEEP_VARS: sweep_vars = optarg; break;
      case O_SWEEP_SEEDS: if (!parse_int(optarg, "--sweep-seeds", 1, &e.sweep_seeds) || e.sweep_seeds > 64) { fprintf(stderr, "morsegs experiment: --sweep-seeds must be 1..64\n"); return 2; } break;
      case O_KNOB: sl_push(&knobs, optarg); break;
      case O_TRAIN_ARG: sl_push(&e.train_args, optarg); break;
      case O_REPORT_FROM: report_from = optarg; break;
      case O_JOBS: if (!parse_int(optarg, "--jobs", 1, &e.jobs) || e.jobs > 64) { fprintf(stderr, "morsegs experiment: --jobs must be 1..64\n"); return 2; } break;
      case O_PLAN: plan_only = 1; break;
      case O_REEVALUATE: e.reevaluate = 1; break;
      case O_EVAL_VIEWS: if (!parse_int(optarg, "--eval-views", 1, &e.eval_views)) return 2; break;
      case O_TOPO_RES: if (!parse_int(optarg, "--topo-res", 16, &e.topo_res) || e.topo_res > 4096) { fprintf(stderr, "morsegs experiment: --topo-res must be 16..4096\n"); return 2; } break;
      case 'h': case O_HELP: usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (!e.dir) { fprintf(stderr, "morsegs experiment: -o DIR is required\n"); usage(stderr); return 2; }
  if (report_from) { /* re-analysis only: nothing is trained */
    if (optind < argc) { fprintf(stderr, "morsegs experiment: --report-from takes no DATA (got '%s')\n", argv[optind]); goto usage_fail; }
    char a[PATH_MAX], b[PATH_MAX];
    if (realpath(report_from, a) && realpath(e.dir, b) && !strcmp(a, b)) {
      fprintf(stderr, "morsegs experiment: --report-from %s: -o must be another folder (the earlier report is kept)\n", report_from);
      goto usage_fail;
    }
    mgs_error rerr;
    mgs_error_clear(&rerr);
    if (exp_report_from_results(report_from, e.dir, variants, &rerr)) { mgs_cli_fail("experiment", &rerr); goto fail; }
    printf("wrote %s/RESULTS.md, %s/RESULTS.json, %s/curves.csv, %s/h3.csv, %s/plots/ (re-analysis of %s)\n", e.dir, e.dir, e.dir,
           e.dir, e.dir, report_from);
    rc = 0;
    goto fail;
  }
  if (!e.sweep_seeds) e.sweep_seeds = e.seeds;
  if (optind >= argc) { fprintf(stderr, "morsegs experiment: at least one DATA folder is expected\n"); usage(stderr); return 2; }
  if (mesh && argc - optind != 1) { fprintf(stderr, "morsegs experiment: --mesh applies to one DATA (with several, each dataset's gt_mesh.ply is used)\n"); return 2; }
  if (mesh && !mgs_path_exists(mesh)) { fprintf(stderr, "morsegs experiment: --mesh %s: file not found\n", mesh); return 2; }
  /* evaluation points */
  if (eval_at) {
    strlist l = {0};
    sl_split(&l, eval_at);
    for (size_t i = 0; i < l.n; i++) {
      int v;
      if (!parse_int(l.v[i], "--eval-at", 1, &v)) { sl_free(&l); return 2; }
      if (v < e.iters && e.n_evals < EXP_MAX_POINTS - 1) e.evals[e.n_evals++] = v;
    }
    sl_free(&l);
    e.evals[e.n_evals++] = e.iters;
  } else {
    for (int k = 1; k <= n_evals; k++) {
      int v = (int)((long long)e.iters * k / n_evals);
      if (v >= 1) e.evals[e.n_evals++] = v;
    }
  }
  qsort(e.evals, (size_t)e.n_evals, sizeof(int), cmp_int);
  { int m = 0; for (int k = 0; k < e.n_evals; k++) if (!m || e.evals[k] != e.evals[m - 1]) e.evals[m++] = e.evals[k]; e.n_evals = m; }
  /* sweep multipliers */
  if (strcmp(sweep, "none") && *sweep) {
    strlist l = {0};
    sl_split(&l, sweep);
    for (size_t i = 0; i < l.n; i++) {
      char *end;
      double f = strtod(l.v[i], &end);
      if (*end || !(f > 0) || !isfinite(f)) { fprintf(stderr, "morsegs experiment: --sweep needs positive multipliers (got '%s')\n", l.v[i]); sl_free(&l); return 2; }
      if (f != 1.0 && e.n_sweep < 16) e.sweep[e.n_sweep++] = f;
    }
    sl_free(&l);
  }
  /* variants */
  /* --variant NAME=ARGS: a variant of the user's (ARGS split at spaces, at most 8) */
  for (size_t i = 0; i < custom.n; i++) {
    char *eq = strchr(custom.v[i], '=');
    if (!eq || eq == custom.v[i] || n_custom == 16 || eq - custom.v[i] >= 64) { fprintf(stderr, "morsegs experiment: --variant needs NAME=ARGS (got '%s', at most 16)\n", custom.v[i]); goto usage_fail; }
    variant_def *d = &custom_defs[n_custom];
    memset(d, 0, sizeof *d);
    snprintf(custom_buf[n_custom], sizeof custom_buf[n_custom], "%s", custom.v[i]);
    char *b = custom_buf[n_custom], *save = NULL;
    b[eq - custom.v[i]] = 0;
    d->name = b;
    int na = 0;
    for (char *tok = strtok_r(b + (eq - custom.v[i]) + 1, " ", &save); tok && na < 8; tok = strtok_r(NULL, " ", &save)) d->args[na++] = tok;
    d->knob = "--grad-threshold";
    d->knob_default = 2e-4;
    for (size_t k = 0; k < N_VARIANTS; k++) if (!strcmp(VARIANTS[k].name, d->name)) { fprintf(stderr, "morsegs experiment: --variant %s: a built-in variant has that name\n", d->name); goto usage_fail; }
    n_custom++;
  }
  if (variants) sl_split(&vlist, variants);
  else for (size_t i = 0; i < N_VARIANTS; i++) sl_push(&vlist, VARIANTS[i].name);
  if (!variants) for (size_t i = 0; i < n_custom; i++) sl_push(&vlist, custom_defs[i].name);
  if (sweep_vars) sl_split(&svlist, sweep_vars);
  e.vars = calloc(vlist.n + 1, sizeof *e.vars);
  int have_baseline = 0;
  for (size_t i = 0; i < vlist.n; i++) {
    const variant_def *d = NULL;
    for (size_t k = 0; k < N_VARIANTS; k++) if (!strcmp(vlist.v[i], VARIANTS[k].name)) d = &VARIANTS[k];
    for (size_t k = 0; k < n_custom; k++) if (!strcmp(vlist.v[i], custom_defs[k].name)) d = &custom_defs[k];
    if (!d) { fprintf(stderr, "morsegs experiment: unknown variant '%s' (see --help)\n", vlist.v[i]); goto usage_fail; }
    for (size_t k = 0; k < e.n_vars; k++) if (e.vars[k].def == d) d = NULL;
    if (!d) continue;
    variant_sel *s = &e.vars[e.n_vars++];
    s->def = d;
    snprintf(s->knob, sizeof s->knob, "%s", d->knob);
    s->knob_default = d->knob_default;
    s->sweep = d->sweep_by_default;
    if (sweep_vars) { s->sweep = 0; for (size_t k = 0; k < svlist.n; k++) if (!strcmp(svlist.v[k], d->name)) s->sweep = 1; }
    snprintf(s->status.name, sizeof s->status.name, "%s", d->name);
    snprintf(s->status.status, sizeof s->status.status, "pending");
    if (!strcmp(d->name, "baseline")) have_baseline = 1;
  }
  if (!have_baseline) { fprintf(stderr, "morsegs experiment: --variants must include baseline (every change is measured against it)\n"); goto usage_fail; }
  for (size_t i = 0; i < svlist.n; i++) {
    int found = 0;
    for (size_t k = 0; k < e.n_vars; k++) found |= !strcmp(svlist.v[i], e.vars[k].def->name);
    if (!found) { fprintf(stderr, "morsegs experiment: --sweep-variants: '%s' is not among --variants\n", svlist.v[i]); goto usage_fail; }
  }
  /* --base V=B: V's changes are measured against B (a method MorseGS sits on), not baseline */
  for (size_t i = 0; i < bases.n; i++) {
    char *eq = strchr(bases.v[i], '=');
    if (!eq || eq == bases.v[i] || !eq[1]) { fprintf(stderr, "morsegs experiment: --base needs VARIANT=BASE (got '%s')\n", bases.v[i]); goto usage_fail; }
    *eq = 0;
    variant_sel *v = NULL;
    int base_found = 0;
    for (size_t k = 0; k < e.n_vars; k++) {
      if (!strcmp(e.vars[k].def->name, bases.v[i])) v = &e.vars[k];
      base_found |= !strcmp(e.vars[k].def->name, eq + 1);
    }
    if (!v || !base_found) { fprintf(stderr, "morsegs experiment: --base %s=%s: '%s' is not among --variants\n", bases.v[i], eq + 1, v ? eq + 1 : bases.v[i]); goto usage_fail; }
    if (!strcmp(bases.v[i], eq + 1) || !strcmp(bases.v[i], "baseline")) { fprintf(stderr, "morsegs experiment: --base %s=%s: a variant cannot be its own base, nor can baseline have one\n", bases.v[i], eq + 1); goto usage_fail; }
    snprintf(v->status.base, sizeof v->status.base, "%s", eq + 1);
  }
  for (size_t k = 0; k < e.n_vars; k++) e.vars[k].seeds = e.seeds;
  for (size_t i = 0; i < vseeds.n; i++) {
    char *eq = strchr(vseeds.v[i], '=');
    int n = 0;
    if (!eq || eq == vseeds.v[i] || !parse_int(eq + 1, "--variant-seeds", 1, &n) || n > e.seeds) {
      fprintf(stderr, "morsegs experiment: --variant-seeds needs VARIANT=N with 1 <= N <= --seeds (got '%s')\n", vseeds.v[i]);
      goto usage_fail;
    }
    *eq = 0;
    int found = 0;
    for (size_t k = 0; k < e.n_vars; k++)
      if (!strcmp(e.vars[k].def->name, vseeds.v[i])) { e.vars[k].seeds = n; found = 1; }
    if (!found) { fprintf(stderr, "morsegs experiment: --variant-seeds: '%s' is not among --variants\n", vseeds.v[i]); goto usage_fail; }
  }
  for (size_t k = 0; k < e.n_vars; k++) e.vars[k].n_sweep_of = -1;
  for (size_t i = 0; i < sweep_ofs.n; i++) {
    char *eq = strchr(sweep_ofs.v[i], '=');
    variant_sel *v = NULL;
    if (eq) {
      *eq = 0;
      for (size_t k = 0; k < e.n_vars; k++) if (!strcmp(e.vars[k].def->name, sweep_ofs.v[i])) v = &e.vars[k];
    }
    if (!eq || !v) { fprintf(stderr, "morsegs experiment: --sweep-of needs VARIANT=LIST with VARIANT among --variants (got '%s')\n", sweep_ofs.v[i]); goto usage_fail; }
    strlist l = {0};
    sl_split(&l, eq + 1);
    v->n_sweep_of = 0;
    for (size_t j = 0; j < l.n; j++) {
      char *end;
      double f = strtod(l.v[j], &end);
      if (*end || !(f > 0) || !isfinite(f)) { fprintf(stderr, "morsegs experiment: --sweep-of %s: multipliers must be positive (got '%s')\n", sweep_ofs.v[i], l.v[j]); sl_free(&l); goto usage_fail; }
      if (f != 1.0 && v->n_sweep_of < 16) v->sweep_of[v->n_sweep_of++] = f;
    }
    sl_free(&l);
  }
  for (size_t i = 0; i < firsts.n; i++) {
    int found = 0;
    for (size_t k = 0; k < e.n_vars; k++)
      if (!strcmp(e.vars[k].def->name, firsts.v[i])) { e.vars[k].first = 1; found = 1; }
    if (!found) { fprintf(stderr, "morsegs experiment: --first: '%s' is not among --variants\n", firsts.v[i]); goto usage_fail; }
  }
  for (size_t i = 0; i < knobs.n; i++) {
    char *eq = strchr(knobs.v[i], '='), *colon = eq ? strrchr(eq, ':') : NULL;
    double val = colon ? strtod(colon + 1, NULL) : 0;
    if (!eq || !colon || strncmp(eq + 1, "--", 2) || !(val > 0)) { fprintf(stderr, "morsegs experiment: --knob needs VARIANT=--FLAG:VALUE (got '%s')\n", knobs.v[i]); goto usage_fail; }
    *eq = 0; *colon = 0;
    int found = 0;
    for (size_t k = 0; k < e.n_vars; k++)
      if (!strcmp(e.vars[k].def->name, knobs.v[i])) { snprintf(e.vars[k].knob, sizeof e.vars[k].knob, "%s", eq + 1); e.vars[k].knob_default = val; found = 1; }
    if (!found) { fprintf(stderr, "morsegs experiment: --knob: '%s' is not among --variants\n", knobs.v[i]); goto usage_fail; }
  }
  /* datasets */
  e.n_ds = (size_t)(argc - optind);
  e.ds = calloc(e.n_ds, sizeof *e.ds);
  {
    size_t cl = 16;
    for (int i = 0; i < argc; i++) cl += strlen(argv[i]) + 3;
    e.command_line = malloc(cl);
    strcpy(e.command_line, "morsegs");
    for (int i = 0; i < argc; i++) { strcat(e.command_line, " "); strcat(e.command_line, argv[i]); }
  }
  mgs_error err;
  mgs_error_clear(&err);
  for (size_t i = 0; i < e.n_ds; i++) {
    const char *p = argv[optind + (int)i];
    dataset_in *d = &e.ds[i];
    if (!mgs_is_dir(p)) { fprintf(stderr, "morsegs experiment: %s: dataset folder not found\n", p); goto fail; }
    if (!realpath(p, d->path)) snprintf(d->path, sizeof d->path, "%s", p);
    mgs_dataset_options o;
    mgs_dataset_options_default(&o);
    o.load_images = 0;
    mgs_dataset *dd = NULL;
    if (mgs_dataset_load(p, &o, &dd, &err)) { mgs_cli_fail("experiment", &err); goto fail; }
    const char *m = mesh ? mesh : dd->mesh_path;
    if (m && !realpath(m, d->mesh)) snprintf(d->mesh, sizeof d->mesh, "%s", m);
    mgs_dataset_destroy(dd);
    const char *base = strrchr(d->path, '/');
    snprintf(d->name, sizeof d->name, "%.100s", base && base[1] ? base + 1 : d->path);
    for (char *q = d->name; *q; q++) if (!(isalnum((unsigned char)*q) || *q == '-' || *q == '_' || *q == '.')) *q = '_';
    for (size_t k = 0; k < i; k++)
      if (!strcmp(e.ds[k].name, d->name)) { size_t l = strlen(d->name); snprintf(d->name + (l > 100 ? 100 : l), 20, "_%d", (int)(i % 10000) + 1); }
  }
  /* the folder, its lock and its settings (--plan writes nothing and takes no lock) */
  if (mgs_path_exists(e.dir) && !mgs_is_dir(e.dir)) { fprintf(stderr, "morsegs experiment: %s: exists and is not a folder\n", e.dir); goto fail; }
  if (!plan_only) {
  if (mgs_mkdir_p(e.dir, &err)) { mgs_cli_fail("experiment", &err); goto fail; }
  {
    char *lp = mgs_path_join(e.dir, ".lock");
    lock_fd = open(lp, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    free(lp);
    if (lock_fd < 0 || flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
      fprintf(stderr, "morsegs experiment: %s: another experiment is running in this folder (it is locked)\n", e.dir);
      goto fail;
    }
  }
  if (!check_settings(&e, &err)) { mgs_cli_fail("experiment", &err); goto fail; }
  remove_stale_temps(e.dir);
  ssize_t nl = readlink("/proc/self/exe", g_exe, sizeof g_exe - 1);
  if (nl <= 0) { fprintf(stderr, "morsegs experiment: cannot find its own executable (/proc/self/exe)\n"); goto fail; }
  g_exe[nl] = 0;
  e.load_start = load_avg();
  } /* !plan_only */
  /* ground truth per dataset */
  for (size_t i = 0; i < e.n_ds && !plan_only; i++) {
    dataset_in *d = &e.ds[i];
    char sub[EXP_NAME + 16];
    snprintf(sub, sizeof sub, "datasets/%s", d->name);
    char *sd = mgs_path_join(e.dir, sub);
    if (mgs_mkdir_p(sd, &err) || exp_truth_build(d->mesh[0] ? d->mesh : NULL, e.topo_res, sd, &d->truth, &err)) {
      free(sd);
      fprintf(stderr, "morsegs experiment: %s: ground truth: %s\n", d->name, err.msg);
      goto fail;
    }
    free(sd);
    if (d->mesh[0])
      printf("%s: GT mesh %s: Betti (%d, %d, %d), persisting over %.4g: (%d, %d, %d)\n", d->name, d->mesh, d->truth.betti[0],
             d->truth.betti[1], d->truth.betti[2], d->truth.pers_threshold, d->truth.betti_persistent[0],
             d->truth.betti_persistent[1], d->truth.betti_persistent[2]);
    else
      printf("%s: no GT mesh: geometry and topology measures are skipped\n", d->name);
  }
  /* the plan: main runs seed by seed over every dataset (so results that stop early cover
     every dataset and variant with the first seeds), in a seed the --first variants on every
     dataset before the others, then the sweeps */
  size_t cap = e.n_ds * e.n_vars * ((size_t)e.seeds + (size_t)16 * (size_t)e.sweep_seeds) + 1;
  plan_item *plan = calloc(cap, sizeof *plan);
  double *px = NULL; /* the datasets' pixels per view, for the ETA's estimates */
  size_t np = 0;
  for (int s = 0; s < e.seeds; s++)
    for (int pass = 1; pass >= 0; pass--)
      for (size_t d = 0; d < e.n_ds; d++)
        for (size_t v = 0; v < e.n_vars; v++) {
          if (s >= e.vars[v].seeds || e.vars[v].first != pass) continue;
          plan_item *p = &plan[np++];
          p->ds = d; p->var = v; p->seed = s; p->factor = 1.0;
          snprintf(p->dir, sizeof p->dir, "%s/runs/%s/%s/seed_%d", e.dir, e.ds[d].name, e.vars[v].def->name, s);
        }
  for (size_t d = 0; d < e.n_ds; d++) {
    for (size_t v = 0; v < e.n_vars; v++) {
      if (!e.vars[v].sweep) continue;
      const int n_mult = e.vars[v].n_sweep_of >= 0 ? e.vars[v].n_sweep_of : e.n_sweep;
      const double *mult = e.vars[v].n_sweep_of >= 0 ? e.vars[v].sweep_of : e.sweep;
      for (int k = 0; k < n_mult; k++)
        for (int s = 0; s < e.sweep_seeds; s++) {
          plan_item *p = &plan[np++];
          p->ds = d; p->var = v; p->seed = s; p->factor = mult[k]; p->sweep = 1;
          snprintf(p->dir, sizeof p->dir, "%s/runs/%s/%s/sweep_x%g_seed_%d", e.dir, e.ds[d].name, e.vars[v].def->name, mult[k], s);
        }
    }
  }
  e.planned = np;
  struct sigaction sa, old_int, old_term;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  /* finished runs first (their count sets the ETA's denominator) */
  unsigned char *done = calloc(np + 1, 1), *again = calloc(np + 1, 1); /* again: --reevaluate's */
  size_t kept = 0, kept_no_model = 0;
  for (size_t i = 0; i < np; i++) {
    char *rp = mgs_path_join(plan[i].dir, "result.json");
    exp_run r;
    const int exists = mgs_path_exists(rp), readable = exists && exp_run_read(rp, &r, &err) == MGS_OK;
    /* --reevaluate: evaluated again by do_run (which never trains it); --plan only counts it */
    if (readable && again && needs_reevaluation(&e, &r)) {
      /* records restored on another machine (experiment_records.sh) have no model to evaluate:
         kept as they are, and the report says which builds evaluated what */
      if (has_saved_model(plan[i].dir, e.iters)) again[i] = 1;
      else kept_no_model++;
    }
    if (readable && !(again && again[i] && !plan_only)) {
      exp_run *dst = push_run(&e);
      if (dst) { *dst = r; done[i] = 1; kept++; snprintf(e.vars[plan[i].var].status.status, 16, "available"); }
    } else if (exists && !readable) {
      fprintf(stderr, "morsegs experiment: note: %s: %s; the run is redone\n", rp, err.msg);
    }
    free(rp);
  }
  if (kept_no_model)
    printf("--reevaluate: %zu finished run(s) another build evaluated have no saved model here (their records were restored "
           "or their models removed): their records are kept as that build wrote them\n", kept_no_model);
  if (plan_only) {
    print_plan(&e, plan, np, done);
    if (e.reevaluate) {
      size_t na = 0;
      double cpu = 0;
      for (size_t i = 0; i < np; i++)
        if (again && again[i]) {
          na++;
          for (size_t k = 0; k < e.n_runs; k++)
            if (!strcmp(e.runs[k].dataset, e.ds[plan[i].ds].name) && !strcmp(e.runs[k].variant, e.vars[plan[i].var].def->name) &&
                e.runs[k].seed == plan[i].seed && e.runs[k].factor == plan[i].factor && isfinite(e.runs[k].eval_cpu_seconds))
              cpu += e.runs[k].eval_cpu_seconds;
        }
      printf("--reevaluate: %zu finished run(s) another build evaluated are evaluated again (their last evaluations "
             "took %.0f CPU s)\n", na, cpu);
    }
    rc = 0;
    goto fail_plan;
  }
  size_t n_sweep_runs = 0;
  for (size_t i = 0; i < np; i++) n_sweep_runs += plan[i].sweep != 0;
  printf("experiment %s: %zu runs planned (%zu datasets x %zu variants x up to %d seeds + %zu sweep runs), %zu finished before, "
         "%d iterations each, evaluated at", e.dir, np, e.n_ds, e.n_vars, e.seeds, n_sweep_runs, kept, e.iters);
  for (int k = 0; k < e.n_evals; k++) printf(" %d", e.evals[k]);
  printf("\n");
  if (write_report(&e, &err)) { mgs_cli_fail("experiment", &err); goto fail_plan; }
  px = datasets_pixels(&e);
  size_t idx = 0, todo = np - kept, next = 0;
  int interrupted = 0, n_running = 0, forwarded = 0;
  job *running = calloc((size_t)e.jobs, sizeof *running);
  if (!running) { fprintf(stderr, "morsegs experiment: out of memory\n"); goto fail_plan; }
  for (;;) {
    /* start runs while there are free jobs */
    while (!g_stop && !interrupted && n_running < e.jobs) {
      while (next < np && done[next]) next++;
      if (next >= np) break;
      const size_t i = next++;
      plan_item *it = &plan[i];
      variant_sel *vs = &e.vars[it->var];
      idx++;
      char label[512];
      if (it->sweep) snprintf(label, sizeof label, "%s / %s / %s x%g (seed %d)", e.ds[it->ds].name, vs->def->name, vs->knob, it->factor, it->seed);
      else snprintf(label, sizeof label, "%s / %s / seed %d", e.ds[it->ds].name, vs->def->name, it->seed);
      if (!strcmp(vs->status.status, "not available") || (it->sweep && vs->sweep_unavailable)) {
        printf("[%zu/%zu] %s: skipped (not available)\n", idx, todo, label);
        continue;
      }
      /* the plan's estimate (finished runs' CPU costs) of this run and those not started, over the jobs:
         the wall time of runs finished here says little when they were resumed from an earlier session */
      double left = 0;
      for (size_t q = i; q < np; q++)
        if (!done[q]) left += item_estimate(&e, plan, q, px, NULL);
      char eta[32];
      fmt_duration(px ? left / (double)e.jobs : NAN, eta, sizeof eta);
      if (again && again[i])
        printf("[%zu/%zu] %s: evaluating its saved models again (--reevaluate) ...\n", idx, todo, label);
      else
        printf("[%zu/%zu] %s: training %d iterations ... (ETA for the remaining %zu runs: %s)\n", idx, todo, label, e.iters,
               todo - idx + 1, eta);
      fflush(stdout);
      job *j = &running[n_running];
      j->pid = start_job(&e, it, &j->fd);
      if (j->pid < 0) { fprintf(stderr, "morsegs experiment: cannot start a worker process: %s\n", strerror(errno)); interrupted = 1; break; }
      j->item = i; j->idx = idx; j->t0 = mgs_now();
      snprintf(j->label, sizeof j->label, "%s", label);
      n_running++;
    }
    if (n_running == 0) break;
    /* wait for one of them */
    int status = 0;
    pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno != EINTR) break;
      if (g_stop && !forwarded) { for (int k = 0; k < n_running; k++) kill(running[k].pid, SIGINT); forwarded = 1; }
      continue;
    }
    int k = 0;
    while (k < n_running && running[k].pid != pid) k++;
    if (k == n_running) continue;
    job jb = running[k];
    running[k] = running[--n_running];
    plan_item *it = &plan[jb.item];
    variant_sel *vs = &e.vars[it->var];
    char reason[1024];
    int res = finish_job(&jb, status, reason, sizeof reason);
    const double dt = mgs_now() - jb.t0;
    exp_run *r = NULL;
    if (res == 0) {
      char *rp = mgs_path_join(it->dir, "result.json");
      r = push_run(&e);
      if (!r) { fprintf(stderr, "morsegs experiment: out of memory\n"); free(rp); free(running); goto fail_plan; }
      if (exp_run_read(rp, r, &err)) { snprintf(reason, sizeof reason, "%s", err.msg); e.n_runs--; res = 1; }
      free(rp);
    }
    if (res == 0) {
      snprintf(vs->status.status, sizeof vs->status.status, "available");
      const exp_point *p = &r->pt[r->n_points - 1];
      printf("[%zu/%zu] %s: done in %.1f s (train %.1f s): PSNR %.3f dB, %.0f Gaussians, Chamfer %.6g\n", jb.idx, todo, jb.label,
             dt, r->train_seconds, p->psnr, p->gaussians, p->chamfer);
    } else if (res == 2) {
      mgs_error e2;
      mgs_remove_tree(it->dir, &e2);
      char *parent = mgs_path_dirname(it->dir);
      if (parent) rmdir(parent); /* the variant's folder, when this was its only run */
      free(parent);
      if (it->sweep && it->factor != 1.0 && strcmp(vs->status.status, "not available")) {
        vs->sweep_unavailable = 1;
        snprintf(vs->sweep_reason, sizeof vs->sweep_reason, "%s", reason);
        printf("[%zu/%zu] %s: the knob %s is not available: %s\n", jb.idx, todo, jb.label, vs->knob, reason);
      } else {
        snprintf(vs->status.status, sizeof vs->status.status, "not available");
        snprintf(vs->status.reason, sizeof vs->status.reason, "%s", reason);
        printf("[%zu/%zu] %s: variant not available: %s\n", jb.idx, todo, jb.label, reason);
      }
    } else if (res == 3) {
      interrupted = 1;
    } else {
      e.failures++;
      if (strcmp(vs->status.status, "available")) {
        snprintf(vs->status.status, sizeof vs->status.status, "failed");
        snprintf(vs->status.reason, sizeof vs->status.reason, "%s", reason);
      }
      printf("[%zu/%zu] %s: FAILED: %s\n", jb.idx, todo, jb.label, reason);
    }
    fflush(stdout);
    if (write_report(&e, &err)) { mgs_cli_fail("experiment", &err); free(running); goto fail_plan; }
  }
  free(running);
  if (g_stop) interrupted = 1;
  sigaction(SIGINT, &old_int, NULL);
  sigaction(SIGTERM, &old_term, NULL);
  if (interrupted) {
    fprintf(stderr, "morsegs experiment: interrupted; finished runs are kept, run the same command again to continue\n");
    rc = 130;
  } else {
    printf("wrote %s/RESULTS.md, %s/RESULTS.json, %s/curves.csv, %s/h3.csv, %s/plots/\n", e.dir, e.dir, e.dir, e.dir, e.dir);
    if (e.failures) fprintf(stderr, "morsegs experiment: %d run(s) failed (see RESULTS.md); run again to retry them\n", e.failures);
    rc = e.failures ? 1 : 0;
  }
fail_plan:
  free(px);
  free(done);
  free(again);
  free(plan);
fail:
  for (size_t i = 0; i < e.n_ds; i++) exp_truth_free(&e.ds[i].truth);
  free(e.ds);
  free(e.vars);
  free(e.runs);
  free(e.command_line);
  sl_free(&e.train_args);
  sl_free(&knobs); sl_free(&vlist); sl_free(&svlist); sl_free(&custom); sl_free(&bases); sl_free(&vseeds); sl_free(&firsts); sl_free(&sweep_ofs);
  if (lock_fd >= 0) close(lock_fd);
  mgs_diagram_plot_release(); /* cairo's and fontconfig's caches (the report's plots) */
  return rc;
usage_fail:
  rc = 2;
  goto fail;
}
