/* morsegs train DATA -o RUN: argument handling over the one option table
 * (train/mgs_config.h), the run folder's checks, the save points and the report. Never
 * writes into the dataset folder; refuses a non-empty RUN unless --force or --resume;
 * Ctrl-C writes a checkpoint and the current .ply. With --mpi the distributed trainer
 * takes the same config (apps/cmd_train_mpi.c). */
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <cjson/cJSON.h>
#include "apps/mgs_cli.h"
#include "core/mgs_core.h"
#include "train/mgs_config.h"

static volatile sig_atomic_t g_stop = 0; /* set by SIGINT: the only state a signal may touch */
static void on_sigint(int sig) { (void)sig; g_stop = 1; }

/* Test hook (as MGS_MPI_FAULT for --mpi): MGS_TRAIN_INTERRUPT_AT=N stops the run after
   iteration N as Ctrl-C would, so resume tests interrupt at a known point. */
static mgs_status interrupt_at(void *user, mgs_trainer *t, mgs_error *err) {
  (void)err;
  if (mgs_trainer_iteration(t) == *(const int *)user) g_stop = 1;
  return MGS_OK;
}

/* Non-empty directory? */
static int dir_has_entries(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return 0;
  struct dirent *e;
  int any = 0;
  while ((e = readdir(d)))
    if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) { any = 1; break; }
  closedir(d);
  return any;
}

/* Is `inner` (existing or about to be created) inside `outer`? Compares real paths of
 * the deepest existing ancestor. */
static int path_inside(const char *inner, const char *outer) {
  char ro[PATH_MAX], ri[PATH_MAX];
  if (!realpath(outer, ro)) return 0;
  char *probe = mgs_strdup(inner);
  if (!probe) return 0;
  int inside = 0;
  for (;;) {
    if (realpath(probe, ri)) {
      size_t lo = strlen(ro);
      inside = !strncmp(ri, ro, lo) && (ri[lo] == 0 || ri[lo] == '/');
      break;
    }
    char *slash = strrchr(probe, '/');
    if (!slash) { inside = realpath(".", ri) && !strncmp(ri, ro, strlen(ro)) && (ri[strlen(ro)] == 0 || ri[strlen(ro)] == '/'); break; }
    if (slash == probe) { slash[1] = 0; continue; }
    *slash = 0;
  }
  free(probe);
  return inside;
}

static mgs_status write_stats(const char *run, const mgs_train_setup *su, mgs_error *err) {
  const mgs_trainer *t = su->trainer;
  cJSON *o = cJSON_CreateObject();
  if (!o) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  if (su->morse) { /* MorseGS: analysis cost against the training wall time */
    cJSON_AddNumberToObject(o, "morse_analyses", (double)mgs_morse_ctx_analyses(su->morse));
    cJSON_AddNumberToObject(o, "morse_analysis_seconds", mgs_morse_ctx_seconds(su->morse));
    double ph[MGS_TRAIN_PHASES];
    mgs_trainer_phase_seconds(t, ph);
    /* every model term (L_topo, normal, PersLoss), including the Morse analyses L_topo triggers */
    cJSON_AddNumberToObject(o, "loss_term_seconds", ph[MGS_PHASE_TERMS]);
  }
  double tv[16];
  size_t nt = mgs_trainer_term_values(t, tv, 16);
  if (nt) { /* each loss term's weighted value at the last iteration: which terms acted */
    cJSON *terms = cJSON_AddObjectToObject(o, "terms");
    for (size_t k = 0; k < nt; k++) cJSON_AddNumberToObject(terms, mgs_trainer_term_name(t, k), tv[k]);
    double tsec[16];
    mgs_trainer_term_seconds(t, tsec, 16);
    cJSON *tso = cJSON_AddObjectToObject(o, "term_seconds"); /* analyses L_topo triggers included */
    for (size_t k = 0; tso && k < nt && k < 16; k++) cJSON_AddNumberToObject(tso, mgs_trainer_term_name(t, k), tsec[k]);
  }
  { /* wall seconds per phase of the iteration (the share of each stage, docs/notes/perf-morse.md) */
    static const char *const names[MGS_TRAIN_PHASES] = {"forward", "loss", "backward", "strategy", "adam", "terms"};
    double ph[MGS_TRAIN_PHASES];
    mgs_trainer_phase_seconds(t, ph);
    cJSON *po = cJSON_AddObjectToObject(o, "phase_seconds");
    for (int k = 0; po && k < MGS_TRAIN_PHASES; k++) cJSON_AddNumberToObject(po, names[k], ph[k]);
  }
  cJSON_AddNumberToObject(o, "iterations", mgs_trainer_iteration(t));
  cJSON_AddNumberToObject(o, "train_seconds", mgs_trainer_seconds(t));
  /* CPU seconds of the training steps (null after a resume from an older checkpoint):
     comparable between runs on a loaded machine, where wall seconds are not */
  cJSON_AddNumberToObject(o, "train_cpu_seconds", mgs_trainer_cpu_seconds(t));
  cJSON_AddNumberToObject(o, "gaussians", (double)mgs_trainer_model(t)->n);
  cJSON_AddNumberToObject(o, "final_loss", mgs_trainer_last_loss(t));
  cJSON_AddNumberToObject(o, "peak_rss_mb", (double)mgs_peak_rss() / (1024.0 * 1024.0));
  char *text = cJSON_Print(o);
  cJSON_Delete(o);
  char *path = mgs_path_join(run, "train_stats.json");
  mgs_status st = text && path ? mgs_write_file_atomic(path, text, strlen(text), err)
                               : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  free(text); free(path);
  return st;
}

/* Removes what an earlier run wrote (with --force), never anything else. */
static mgs_status clear_run(const char *run, mgs_error *err) {
  static const char *dirs[] = {"point_cloud", "eval", "renders"};
  static const char *files[] = {"checkpoint.mgsckpt", "cameras.json", "cfg_args", "results.json", "train_stats.json",
                                "morse_analysis.csv", "saves.csv"};
  for (size_t i = 0; i < sizeof dirs / sizeof *dirs; i++) {
    char *p = mgs_path_join(run, dirs[i]);
    mgs_status st = p && mgs_is_dir(p) ? mgs_remove_tree(p, err) : MGS_OK;
    free(p);
    if (st) return st;
  }
  for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
    char *p = mgs_path_join(run, files[i]);
    if (p) remove(p);
    free(p);
  }
  return MGS_OK;
}

/* --save-at: iterations below the run's end (the final save is always written). */
static int parse_saves(const char *list, int iterations, int *saves, int cap) {
  int n = 0;
  for (const char *p = list; *p && n < cap;) {
    char *end;
    long v = strtol(p, &end, 10);
    if (end == p || v < 1 || (*end && *end != ',')) {
      fprintf(stderr, "morsegs train: --save-at needs a comma-separated list of iterations (got '%s')\n", list);
      return -1;
    }
    if (v < iterations) saves[n++] = (int)v;
    p = *end == ',' ? end + 1 : end;
  }
  return n;
}

/* cfg_args: the reference's namespace keys (its viewers read source_path) and every
   recorded option of the table. */
static mgs_status write_record(const mgs_train_config *c, const char *data, const char *run, const mgs_dataset *ds,
                               const mgs_train_setup *su, mgs_error *err) {
  char abs_data[PATH_MAX];
  if (!realpath(data, abs_data)) snprintf(abs_data, sizeof abs_data, "%s", data);
  mgs_settings s;
  mgs_settings_init(&s);
  mgs_settings_set(&s, "source_path", abs_data, 1);
  mgs_settings_set(&s, "model_path", run, 1);
  mgs_settings_seti(&s, "resolution", c->downscale > 1 ? c->downscale : -1);
  mgs_settings_set(&s, "white_background", c->background == MGS_BG_WHITE ? "True" : "False", 0);
  mgs_settings_set(&s, "data_device", "cpu", 1);
  mgs_settings_set(&s, "eval", "True", 0);
  mgs_settings_set(&s, "init_used", su->init_used, 1);
  mgs_settings_seti(&s, "threads", mgs_parallel_max_threads());
  mgs_config_record(c, &s);
  mgs_run_record_origin(&s, ds); /* scene_origin: the frame the model trained in */
  char *cfg = mgs_path_join(run, "cfg_args");
  mgs_status st = cfg ? mgs_settings_write(cfg, &s, err) : mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  free(cfg);
  mgs_settings_free(&s);
  return st;
}

/* The serial trainer on a parsed config (also `--mpi` with one process). */
int mgs_cmd_train_config(mgs_train_config *c, const char *data) {
  const char *run = c->output;
  mgs_error err;
  mgs_error_clear(&err);
  if (mgs_config_validate(c, 1, &err)) { fprintf(stderr, "morsegs train: %s\n", err.msg); return 2; }
  int saves[64];
  int n_saves = parse_saves(c->save_at, c->iters, saves, 64);
  if (n_saves < 0) return 2;
  if (c->threads) mgs_parallel_set_threads(c->threads);
  if (!mgs_is_dir(data)) { fprintf(stderr, "morsegs train: %s: dataset folder not found\n", data); return 1; }
  if (path_inside(run, data)) {
    fprintf(stderr, "morsegs train: %s: the run folder is inside the dataset folder %s; choose another -o (the dataset is never written to)\n", run, data);
    return 2;
  }
  if (mgs_is_dir(run) && dir_has_entries(run) && !c->force && !c->resume) {
    fprintf(stderr, "morsegs train: %s: run folder exists and is not empty (use --force to replace it or --resume to continue)\n", run);
    return 1;
  }
  if (mgs_path_exists(run) && !mgs_is_dir(run)) { fprintf(stderr, "morsegs train: %s: exists and is not a folder\n", run); return 1; }
  char *ckpt = mgs_path_join(run, "checkpoint.mgsckpt");
  if (!ckpt) return 1;
  if (c->resume && !mgs_path_exists(ckpt)) {
    fprintf(stderr, "morsegs train: %s: no checkpoint to resume from (a run stopped before its first checkpoint has trained nothing: start it again with --force)\n", ckpt);
    free(ckpt);
    return 1;
  }
  mgs_dataset_options dopt;
  mgs_config_dataset_options(c, &dopt);
  mgs_dataset *ds = NULL;
  mgs_run_lock *lock = NULL;
  mgs_train_setup su;
  memset(&su, 0, sizeof su);
  int rc = 1;
  mgs_status st = mgs_dataset_load(data, &dopt, &ds, &err);
  if (st) goto done;
  c->background = ds->white_background ? MGS_BG_WHITE : MGS_BG_BLACK; /* recorded as resolved */
  mgs_train_options o;
  mgs_config_train_options(c, &o);
  o.checkpoint_path = ckpt;
  o.stop = &g_stop;
  const char *stop_env = getenv("MGS_TRAIN_INTERRUPT_AT");
  int stop_at = stop_env ? atoi(stop_env) : 0;
  if (stop_at > 0) { o.after_step = interrupt_at; o.after_step_user = &stop_at; }
  /* the lock before --force clears anything: a second trainer on RUN is refused */
  if ((st = mgs_run_lock_acquire(run, &lock, &err))) goto done;
  if (!c->resume && c->force && (st = clear_run(run, &err))) goto done;
  if ((st = mgs_train_setup_create(c, ds, &o, run, c->resume, &su, &err))) goto done;
  mgs_trainer *t = su.trainer;
  if (c->resume) {
    if ((st = mgs_trainer_load_checkpoint(t, ckpt, &err))) goto done;
    mgs_info("resuming %s at iteration %d with %zu Gaussians", run, mgs_trainer_iteration(t), mgs_trainer_model(t)->n);
  }
  /* settings record and cameras before training (a crash still leaves them), then a
     checkpoint: from there on a run killed at any moment can --resume; killed before it,
     the run has trained nothing and --resume says so (a checkpoint without the record
     could only resume with whatever flags are typed then) */
  if ((st = write_record(c, data, run, ds, &su, &err))) goto done;
  if ((st = mgs_run_write_cameras(run, ds, &err))) goto done;
  if (!c->resume && o.checkpoint_every > 0 && (st = mgs_trainer_save_checkpoint(t, ckpt, &err))) goto done;

  struct sigaction sa, old;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_sigint;
  sigemptyset(&sa.sa_mask);
  g_stop = 0;
  sigaction(SIGINT, &sa, &old);
  mgs_info("training %s: %zu train views, %zu Gaussians, %d iterations", data, ds->n_views[MGS_SPLIT_TRAIN],
           mgs_trainer_model(t)->n, o.iterations);
  /* each save is the model the reference writes at that iteration (mgs_trainer_run_to) */
  for (int i = 0; i <= n_saves && st == MGS_OK; i++) {
    int at = i < n_saves ? saves[i] : o.iterations;
    if (at < mgs_trainer_model_iteration(t) && i < n_saves) continue;
    st = mgs_trainer_run_to(t, at, &err);
    if (st == MGS_OK && i < n_saves) st = mgs_run_write_ply(run, at, mgs_trainer_model(t), &err);
    if (st == MGS_OK && i < n_saves) st = mgs_run_record_save(run, at, mgs_trainer_seconds(t), mgs_trainer_model(t)->n,
                                                        mgs_trainer_cpu_seconds(t), &err);
  }
  sigaction(SIGINT, &old, NULL);
  if (st == MGS_ERR_INTERRUPTED) {
    mgs_error e2;
    mgs_status s2 = mgs_run_write_ply(run, mgs_trainer_model_iteration(t), mgs_trainer_model(t), &e2);
    fprintf(stderr, "morsegs train: %s; %s\n", err.msg, s2 == MGS_OK ? "current model written" : e2.msg);
    write_stats(run, &su, &e2);
    if (su.morse) mgs_morse_ctx_flush_csv(su.morse, &e2);
    rc = 130;
    goto done;
  }
  if (st) goto done;
  if ((st = mgs_run_write_ply(run, mgs_trainer_iteration(t), mgs_trainer_model(t), &err))) goto done;
  if ((st = mgs_run_record_save(run, mgs_trainer_iteration(t), mgs_trainer_seconds(t), mgs_trainer_model(t)->n,
                                 mgs_trainer_cpu_seconds(t), &err))) goto done;
  if ((st = write_stats(run, &su, &err))) goto done;
  if (su.morse) {
    if ((st = mgs_morse_ctx_flush_csv(su.morse, &err))) goto done;
    mgs_info("Morse analyses: %zu, %.1f s (%.1f %% of the training wall time)", mgs_morse_ctx_analyses(su.morse),
             mgs_morse_ctx_seconds(su.morse), 100.0 * mgs_morse_ctx_seconds(su.morse) / (mgs_trainer_seconds(t) > 0 ? mgs_trainer_seconds(t) : 1));
  }
  /* a final checkpoint lets --resume extend the run with a larger --iters */
  if (o.checkpoint_every > 0 && (st = mgs_trainer_save_checkpoint(t, ckpt, &err))) goto done;
  printf("trained %d iterations in %.1f s: %zu Gaussians -> %s/point_cloud/iteration_%d/point_cloud.ply\n",
         mgs_trainer_iteration(t), mgs_trainer_seconds(t), mgs_trainer_model(t)->n, run, mgs_trainer_iteration(t));
  rc = 0;
done:
  if (rc == 1) mgs_cli_fail("train", &err);
  mgs_train_setup_destroy(&su);
  mgs_dataset_destroy(ds);
  mgs_run_lock_release(lock);
  free(ckpt);
  return rc;
}

int mgs_cmd_train(int argc, char **argv) {
  mgs_train_config c;
  const char *data = NULL;
  mgs_error err;
  if (mgs_config_parse(&c, argc, argv, &data, &err)) {
    fprintf(stderr, "morsegs train: %s\n", err.msg);
    return 2;
  }
  if (c.help) { mgs_config_usage(stdout); return 0; }
  if (c.mpi) return mgs_cmd_train_mpi(&c, data);
  return mgs_cmd_train_config(&c, data);
}
