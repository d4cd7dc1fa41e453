/* `morsegs train --mpi DATA -o RUN [options]` under `mpirun -np K` (Open MPI): the scene's
 * initial points are cut into K compact blocks along a Morton curve of tiles
 * (train/mgs_partition.h); each rank trains its block plus ghost copies of the points
 * within a margin of it, on the training views that see it, on its own until densification
 * ends (--densify-until). There it hands off (apps/train_mpi_ghosts.c): each rank keeps the
 * Gaussians its block holds and receives read-only ghosts of its neighbours' Gaussians
 * whose support reaches it, refreshed by their owners every --exchange-every steps through
 * MPI neighbourhood collectives (--independent: no hand-off, blocks independent to the
 * end). Rank 0 merges the Gaussians each rank owns into one model (point-to-point, so a
 * rank whose block never comes is named and the run ended: --mpi-timeout). One process
 * (-np 1) runs the serial trainer unchanged: the same model as `morsegs train`.
 *
 * Every --migrate-every steps after the hand-off, Gaussians whose means have left their
 * block move to the block that holds them with their Adam moments. Blocks are balanced by
 * points, or by points plus the pixels that see them (--split-by pixels). Not done: at the hand-off the copies a
 * rank trained of a neighbour's region are dropped (the owner's kept); ghosts are
 * owner-computed read-only copies, or averaged with their owners at each exchange
 * (--ghosts average); no ADMM consensus.
 * Each rank checkpoints its block (RUN/ranks/rank_K.mgsckpt); --resume continues every
 * rank. A failing rank ends the whole run (MPI_Abort) with its message; a rank that dies
 * is named by mpirun, which ends the others. */
#include <limits.h>
#include <dirent.h>
#include <signal.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include "core/mgs_core.h"
#include "render/mgs_visibility.h"
#include "train/mgs_train.h"
#include "train/mgs_strategy.h"
#include "train/mgs_partition.h"
#include <mpi.h>
#include "dist/dist_internal.h"
#include "dist/mgs_dist.h"

void mgs_mpi_die(int rank, const char *what) {
  fprintf(stderr, "morsegs train --mpi: rank %d: %s\n", rank, what);
  fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, 1);
  exit(1);
}

enum { TAG_HEAD = 11, TAG_BLOCK = 12 };

void mgs_mpi_wait_all(MPI_Request *rq, int n, double limit, const char *what, int explicit_limit) {
  double t0 = MPI_Wtime();
  for (;;) {
    int done = 0;
    MPI_Testall(n, rq, &done, MPI_STATUSES_IGNORE);
    if (done) return;
    if (MPI_Wtime() - t0 > limit) break;
    struct timespec ts = {0, 2000000}; /* 2 ms: no busy loop while the others train */
    nanosleep(&ts, NULL);
  }
  char msg[1024];
  size_t len = (size_t)snprintf(msg, sizeof msg, "no %s from rank", what);
  int missing = 0;
  for (int r = 1; r < n && len < sizeof msg - 32; r++) {
    int flag = 0;
    if (rq[r] != MPI_REQUEST_NULL) MPI_Test(&rq[r], &flag, MPI_STATUS_IGNORE);
    else flag = 1;
    if (!flag) len += (size_t)snprintf(msg + len, sizeof msg - len, "%s %d", missing++ ? "," : "", r);
  }
  snprintf(msg + len, sizeof msg - len, " within %.0f s after this rank's block%s: the run is ended", limit,
           explicit_limit ? " (--mpi-timeout)" : " (600 s + twice this rank's training time; --mpi-timeout S sets it)");
  mgs_mpi_die(0, msg);
}

/* A rank that crashes says so before it goes (mpirun then ends the others); only
   async-signal-safe calls here. A rank killed outright (SIGKILL, the OOM killer) is named
   by mpirun alone, as process [[job,1],K]. */
static int crash_rank = -1;
static void on_crash(int sig) {
  char msg[96] = "morsegs train --mpi: rank ";
  size_t n = sizeof "morsegs train --mpi: rank " - 1;
  char num[16];
  int k = 0, v = crash_rank < 0 ? 0 : crash_rank;
  do { num[k++] = (char)('0' + v % 10); v /= 10; } while (v && k < 15);
  while (k) msg[n++] = num[--k];
  const char *tail = sig == SIGSEGV ? ": crashed (SIGSEGV)\n" : sig == SIGBUS ? ": crashed (SIGBUS)\n" :
                     sig == SIGFPE ? ": crashed (SIGFPE)\n" : sig == SIGILL ? ": crashed (SIGILL)\n" : ": crashed (SIGABRT)\n";
  for (const char *t = tail; *t && n < sizeof msg; t++) msg[n++] = *t;
  ssize_t w = write(2, msg, n);
  (void)w;
  signal(sig, SIG_DFL);
  raise(sig);
}
static void name_crashes(int rank) {
  crash_rank = rank;
  const int sigs[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT};
  for (size_t i = 0; i < sizeof sigs / sizeof *sigs; i++) signal(sigs[i], on_crash);
}

/* Fault injection for the tests (as SQLite tests its error paths): MGS_MPI_FAULT=hang:K
   makes rank K never send its block; exit:K makes it die without a word; segv:K crash. */
static void fault_point(int rank) {
  const char *f = getenv("MGS_MPI_FAULT");
  if (!f) return;
  int k = -1;
  if (sscanf(f, "hang:%d", &k) == 1 && k == rank)
    for (;;) { struct timespec ts = {1, 0}; nanosleep(&ts, NULL); }
  if (sscanf(f, "exit:%d", &k) == 1 && k == rank) _exit(3);
  if (sscanf(f, "segv:%d", &k) == 1 && k == rank) raise(SIGSEGV);
}
/* MGS_MPI_FAULT=exit-at:K:N: rank K dies once iteration N is complete (0: no fault). */
static int fault_iteration(int rank) {
  const char *f = getenv("MGS_MPI_FAULT");
  int k = -1, n = 0;
  if (f && sscanf(f, "exit-at:%d:%d", &k, &n) == 2 && k == rank && n > 0) return n;
  return 0;
}

static int train_blocks(const mgs_train_config *mo, const char *data, int rank, int size) {
  mgs_error err;
  mgs_error_clear(&err);
  double t_start = MPI_Wtime();
  name_crashes(rank);
  mgs_dataset_options dopt;
  mgs_dataset_options_default(&dopt);
  mgs_config_dataset_options(mo, &dopt);
  dopt.load_images = 0; /* each rank decodes only the views it trains on */
  mgs_dataset *ds = NULL;
  if (mgs_dataset_load(data, &dopt, &ds, &err)) mgs_mpi_die(rank, err.msg);
  if (!ds->init_points || ds->init_points->n == 0) mgs_mpi_die(rank, "the dataset has no initial points (points3d.ply / SfM points): needed to partition the scene");
  const mgs_point_cloud *pc = ds->init_points;
  mgs_partition *part = NULL;
  if (mgs_partition_for_dataset(ds, size, mo->split_pixels, &part, &err)) mgs_mpi_die(rank, err.msg);
  /* owned points and ghosts within the margin of the block's box */
  double m = mo->ghost_margin * part->tile;
  const double *lo = part->lo[rank], *hi = part->hi[rank];
  size_t n_local = 0, n_owned = 0;
  float *xyz = malloc(pc->n * 3 * sizeof(float)), *rgb = malloc(pc->n * 3 * sizeof(float));
  if (!xyz || !rgb) mgs_mpi_die(rank, "out of memory");
  for (size_t i = 0; i < pc->n; i++) {
    const float *p = pc->xyz + 3 * i;
    int own = mgs_partition_owner(part, p) == rank;
    int near = p[0] >= lo[0] - m && p[0] <= hi[0] + m && p[1] >= lo[1] - m && p[1] <= hi[1] + m && p[2] >= lo[2] - m &&
               p[2] <= hi[2] + m;
    if (!own && !near) continue;
    memcpy(xyz + 3 * n_local, p, 3 * sizeof(float));
    memcpy(rgb + 3 * n_local, pc->rgb + 3 * i, 3 * sizeof(float));
    n_local++;
    n_owned += own;
  }
  if (n_owned == 0) mgs_mpi_die(rank, "the partition gave this rank no points (fewer tiles than ranks?)");
  mgs_gaussians *g0 = NULL;
  if (mgs_init_from_points(xyz, rgb, n_local, mo->sh_degree, &g0, &err)) mgs_mpi_die(rank, err.msg);
  free(xyz); free(rgb);
  /* the training views that see this block: its Gaussians' tiles in their frustum */
  mgs_visibility *vis = mgs_visibility_create(part->tile);
  mgs_raster_settings rs;
  mgs_raster_settings_default(&rs);
  size_t nv = ds->n_views[MGS_SPLIT_TRAIN], kept = 0;
  mgs_view *views = malloc((nv ? nv : 1) * sizeof *views);
  if (!vis || !views) mgs_mpi_die(rank, "out of memory");
  for (size_t v = 0; v < nv; v++) {
    const uint32_t *idx;
    size_t n_idx;
    if (mgs_visibility_query(vis, g0, &ds->views[MGS_SPLIT_TRAIN][v].cam, &rs, &idx, &n_idx, &err)) mgs_mpi_die(rank, err.msg);
    if (n_idx > 0) views[kept++] = ds->views[MGS_SPLIT_TRAIN][v];
  }
  mgs_visibility_destroy(vis);
  if (!kept) mgs_mpi_die(rank, "no training view sees this rank's block");
  /* a dataset holding those views (borrowed, so never destroyed as a whole) */
  mgs_dataset sub = *ds;
  sub.views[MGS_SPLIT_TRAIN] = views;
  sub.n_views[MGS_SPLIT_TRAIN] = kept;
  mgs_train_options o;
  mgs_config_train_options(mo, &o);
  o.seed = mo->seed + (uint64_t)rank;
  /* each rank checkpoints its own block: RUN/ranks/rank_K.mgsckpt */
  char ck_name[64];
  snprintf(ck_name, sizeof ck_name, "ranks/rank_%d.mgsckpt", rank);
  char *ckpt = mgs_path_join(mo->output, ck_name);
  if (!ckpt) mgs_mpi_die(rank, "out of memory");
  o.checkpoint_path = ckpt;
  o.adc.white_background = ds->white_background; /* by format, as the serial trainer */
  /* after densification: ownership by position and read-only ghosts kept up to date */
  mgs_mpi_ghosts *gh = NULL;
  int handoff = o.adc.densify_until;
  if (!mo->independent && handoff < mo->iters) {
    char gname[64];
    snprintf(gname, sizeof gname, "ranks/rank_%d.ghosts", rank);
    char *side = mgs_path_join(mo->output, gname);
    gh = side ? mgs_mpi_ghosts_create(part, rank, size, handoff, mo->exchange_every, mo->migrate_every, mo->checkpoint_every, m,
                                      side, mo->mpi_timeout) : NULL;
    free(side);
    if (!gh) mgs_mpi_die(rank, "out of memory");
    mgs_mpi_ghosts_set_average(gh, mo->ghosts_average);
    o.after_step = mgs_mpi_ghosts_after_step;
    o.after_step_user = gh;
  }
  mgs_trainer *t = NULL;
  if (mgs_trainer_create(&sub, &o, g0, mo->strategy == MGS_STRAT_ADC ? mgs_strategy_adc_create(&o.adc) : NULL, &t, &err)) mgs_mpi_die(rank, err.msg);
  if (!mo->quiet)
    mgs_info("rank %d of %d: %zu owned + %zu ghost Gaussians, %zu of %zu training views", rank, size, n_owned,
             n_local - n_owned, kept, nv);
  if (mo->resume) {
    if (!mgs_path_exists(ckpt)) {
      char m2[1200];
      snprintf(m2, sizeof m2, "%s: no checkpoint of this rank to resume from", ckpt);
      mgs_mpi_die(rank, m2);
    }
    if (mgs_trainer_load_checkpoint(t, ckpt, &err)) mgs_mpi_die(rank, err.msg);
    if (gh && mgs_mpi_ghosts_resume(gh, t, &err)) mgs_mpi_die(rank, err.msg);
    fprintf(stderr, "morsegs train --mpi: rank %d: resumed from %s at iteration %d\n", rank, ckpt, mgs_trainer_iteration(t));
  } else if (mo->checkpoint_every > 0 && mgs_trainer_save_checkpoint(t, ckpt, &err)) {
    mgs_mpi_die(rank, err.msg); /* from here on a run killed at any moment can --resume */
  }
  double t0 = MPI_Wtime();
  int stop_at = fault_iteration(rank);
  if (stop_at > 0) {
    if (mgs_trainer_run_until(t, stop_at, &err)) mgs_mpi_die(rank, err.msg);
    _exit(3);
  }
  if (mgs_trainer_run(t, &err)) mgs_mpi_die(rank, err.msg);
  double train_s = MPI_Wtime() - t0;
  /* the Gaussians this rank owns by their final means, packed group by group */
  const mgs_gaussians *g = mgs_trainer_model(t);
  size_t n_keep = 0;
  uint8_t *keep = malloc(g->n ? g->n : 1);
  if (!keep) mgs_mpi_die(rank, "out of memory");
  /* after the hand-off the owned rows are fixed (a Gaussian that drifted out of its block
     since stays with its owner); before it, ownership is by position */
  int handed = mgs_mpi_ghosts_active(gh);
  double lag = 0;
  if (handed && mgs_mpi_ghosts_lag(gh, t, &lag, &err)) mgs_mpi_die(rank, err.msg);
  for (size_t i = 0; i < g->n; i++)
    n_keep += keep[i] = handed ? (uint8_t)(i < mgs_mpi_ghosts_owned(gh)) : (uint8_t)(mgs_partition_owner(part, g->mean + 3 * i) == rank);
  int dims = 0;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) dims += mgs_param_dim((mgs_param_group)k);
  float *pack = malloc((n_keep ? n_keep : 1) * (size_t)dims * sizeof(float));
  if (!pack) mgs_mpi_die(rank, "out of memory");
  size_t off = 0;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    int d = mgs_param_dim((mgs_param_group)k);
    const float *src = mgs_gaussians_group((mgs_gaussians *)g, (mgs_param_group)k);
    for (size_t i = 0; i < g->n; i++)
      if (keep[i]) { memcpy(pack + off, src + i * (size_t)d, (size_t)d * sizeof(float)); off += (size_t)d; }
  }
  free(keep);
  if (n_keep * (size_t)dims > INT_MAX) mgs_mpi_die(rank, "too many Gaussians for one MPI message");
  fault_point(rank); /* test hook: MGS_MPI_FAULT */
  /* the merge, point to point: rank 0 knows which rank it still waits for, and names it
     when its message does not come (a collective would only hang) */
  int cnt = (int)(n_keep * (size_t)dims);
  double loss = mgs_trainer_last_loss(t);
  enum { NHEAD = 12, NROW = 6 };
  unsigned long long mig_out = 0, mig_in = 0;
  mgs_mpi_ghosts_migrated(gh, &mig_out, &mig_in);
  double head[NHEAD] = {(double)cnt, loss, train_s, (double)n_owned, (double)(n_local - n_owned), (double)kept, (double)n_keep,
                        handed ? (double)mgs_mpi_ghosts_count(gh) : 0.0, (double)mgs_mpi_ghosts_bytes(gh), lag,
                        (double)mig_out, (double)mig_in};
  int *counts = rank == 0 ? calloc((size_t)size, sizeof(int)) : NULL, *displs = rank == 0 ? calloc((size_t)size, sizeof(int)) : NULL;
  double *heads = rank == 0 ? calloc((size_t)size * NHEAD, sizeof(double)) : NULL;
  float *all = NULL;
  long long total = 0;
  if (rank != 0) {
    MPI_Request rq[2];
    MPI_Isend(head, NHEAD, MPI_DOUBLE, 0, TAG_HEAD, MPI_COMM_WORLD, &rq[0]);
    MPI_Isend(pack, cnt, MPI_FLOAT, 0, TAG_BLOCK, MPI_COMM_WORLD, &rq[1]);
    MPI_Waitall(2, rq, MPI_STATUSES_IGNORE); /* rank 0 gone: mpirun ends this rank */
  } else {
    if (!counts || !displs || !heads) mgs_mpi_die(rank, "out of memory");
    memcpy(heads, head, sizeof head);
    double limit = mo->mpi_timeout > 0 ? mo->mpi_timeout : 600.0 + 2.0 * train_s;
    MPI_Request *rq = malloc((size_t)size * sizeof *rq);
    if (!rq) mgs_mpi_die(rank, "out of memory");
    rq[0] = MPI_REQUEST_NULL;
    for (int r = 1; r < size; r++) MPI_Irecv(heads + NHEAD * r, NHEAD, MPI_DOUBLE, r, TAG_HEAD, MPI_COMM_WORLD, &rq[r]);
    mgs_mpi_wait_all(rq, size, limit, "block summary", mo->mpi_timeout > 0);
    for (int r = 0; r < size; r++) {
      counts[r] = (int)heads[NHEAD * r];
      displs[r] = (int)total;
      total += counts[r];
    }
    if (total > INT_MAX) mgs_mpi_die(rank, "the merged model is too large for one MPI message");
    all = malloc((size_t)(total ? total : 1) * sizeof(float));
    if (!all) mgs_mpi_die(rank, "out of memory for the merged model");
    memcpy(all, pack, (size_t)cnt * sizeof(float));
    for (int r = 1; r < size; r++) MPI_Irecv(all + displs[r], counts[r], MPI_FLOAT, r, TAG_BLOCK, MPI_COMM_WORLD, &rq[r]);
    mgs_mpi_wait_all(rq, size, limit, "block of Gaussians", mo->mpi_timeout > 0);
    free(rq);
  }
  free(pack);
  /* scalars: loss mean, time balance (from the summaries) */
  double loss_sum = 0, tmax = 0, tsum = 0;
  unsigned long long *rows = rank == 0 ? calloc((size_t)size * NROW, sizeof *rows) : NULL;
  if (rank == 0) {
    if (!rows) mgs_mpi_die(rank, "out of memory");
    for (int r = 0; r < size; r++) {
      loss_sum += heads[NHEAD * r + 1];
      tmax = fmax(tmax, heads[NHEAD * r + 2]);
      tsum += heads[NHEAD * r + 2];
      for (int k = 0; k < NROW; k++) rows[NROW * r + k] = (unsigned long long)heads[NHEAD * r + 3 + k];
    }
  }
  int rc = 0;
  mgs_gaussians *merged = NULL;
  if (rank == 0) {
    size_t n_all = (size_t)total / (size_t)dims;
    merged = mgs_gaussians_create(n_all ? n_all : 1, g->sh_degree);
    size_t first;
    if (!merged || mgs_gaussians_append(merged, n_all, &first, &err)) mgs_mpi_die(rank, "out of memory for the merged model");
    memcpy(merged->origin, ds->origin, sizeof merged->origin); /* every rank's frame: the same load of the same folder */
    /* unpack rank by rank: each block is its ranks' rows, group by group */
    size_t row0 = 0;
    for (int r = 0; r < size; r++) {
      size_t nr = (size_t)counts[r] / (size_t)dims;
      const float *src = all + displs[r];
      for (int k = 0; k < MGS_PARAM_COUNT; k++) {
        size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
        memcpy(mgs_gaussians_group(merged, (mgs_param_group)k) + row0 * d, src, nr * d * sizeof(float));
        src += nr * d;
      }
      row0 += nr;
    }
    mgs_status st = mgs_mkdir_p(mo->output, &err);
    if (!st) st = mgs_run_write_ply(mo->output, mo->iters, merged, &err);
    if (!st) st = mgs_run_write_cameras(mo->output, ds, &err);
    if (!st) {
      char abs_data[PATH_MAX];
      if (!realpath(data, abs_data)) snprintf(abs_data, sizeof abs_data, "%s", data);
      mgs_settings s;
      mgs_settings_init(&s);
      mgs_train_config rec = *mo;
      rec.background = ds->white_background ? MGS_BG_WHITE : MGS_BG_BLACK; /* recorded as resolved */
      mgs_settings_set(&s, "source_path", abs_data, 1);
      mgs_settings_set(&s, "model_path", mo->output, 1);
      mgs_settings_set(&s, "white_background", ds->white_background ? "True" : "False", 0);
      mgs_settings_seti(&s, "mpi_ranks", size);
      mgs_config_record(&rec, &s);
      mgs_run_record_origin(&s, ds);
      char *cfg = mgs_path_join(mo->output, "cfg_args");
      st = mgs_settings_write(cfg, &s, &err);
      free(cfg);
      mgs_settings_free(&s);
    }
    if (!st) {
      /* per-rank figures */
      char *path = mgs_path_join(mo->output, "mpi_stats.json");
      size_t cap = 1024 + (size_t)size * 300, len = 0;
      char *text = malloc(cap);
      if (!path || !text) mgs_mpi_die(rank, "out of memory");
      unsigned long long xbytes = 0;
      double lag_max = 0;
      for (int r = 0; r < size; r++) { xbytes += rows[NROW * r + 5]; lag_max = fmax(lag_max, heads[NHEAD * r + 9]); }
      int steps_after = handed ? mo->iters - handoff : 0;
      len += (size_t)snprintf(text + len, cap - len, "{\n  \"handoff\": %d,\n  \"exchange_every\": %d,\n  \"bytes_exchanged\": %llu,\n"
                              "  \"bytes_exchanged_per_step\": %.1f,\n  \"ghost_lag_max\": %.9g,\n", handed ? handoff : -1,
                              handed ? mo->exchange_every : 0, xbytes, steps_after > 0 ? (double)xbytes / steps_after : 0.0, lag_max);
      double mo_sum = 0, mi_sum = 0;
      for (int r = 0; r < size; r++) mo_sum += heads[NHEAD * r + 10], mi_sum += heads[NHEAD * r + 11];
      len += (size_t)snprintf(text + len, cap - len, "  \"migrate_every\": %d,\n  \"migrated_out\": %.0f,\n  \"migrated_in\": %.0f,\n",
                              handed ? mo->migrate_every : 0, mo_sum, mi_sum);
      double sl = 0, sg = 0;
      int si = mgs_mpi_ghosts_sums(gh, &sl, &sg);
      if (si > 0)
        len += (size_t)snprintf(text + len, cap - len, "  \"allreduce\": {\"iteration\": %d, \"gaussians\": %.0f, \"mean_loss\": %.6f},\n",
                                si, sg, sl);
      len += (size_t)snprintf(text + len, cap - len, "  \"ranks\": %d,\n  \"gaussians\": %zu,\n  \"mean_final_loss\": %.6f,\n"
                              "  \"train_seconds_max\": %.3f,\n  \"load_imbalance\": %.3f,\n  \"bytes_gathered\": %lld,\n"
                              "  \"seconds\": %.3f,\n  \"per_rank\": [\n", size, n_all, loss_sum / size, tmax,
                              tsum > 0 ? tmax / (tsum / size) : 1.0, total * (long long)sizeof(float), MPI_Wtime() - t_start);
      for (int r = 0; r < size; r++)
        len += (size_t)snprintf(text + len, cap - len, "    {\"owned_init\": %llu, \"ghosts_init\": %llu, \"views\": %llu, \"merged\": %llu, "
                                "\"ghosts\": %llu, \"bytes_sent\": %llu, \"migrated_out\": %.0f, \"migrated_in\": %.0f}%s\n",
                                rows[NROW * r], rows[NROW * r + 1], rows[NROW * r + 2], rows[NROW * r + 3], rows[NROW * r + 4],
                                rows[NROW * r + 5], heads[NHEAD * r + 10], heads[NHEAD * r + 11], r + 1 < size ? "," : "");
      len += (size_t)snprintf(text + len, cap - len, "  ]\n}\n");
      st = mgs_write_file_atomic(path, text, len, &err);
      free(path); free(text);
    }
    if (st) mgs_mpi_die(rank, err.msg); /* the others wait in the .vdb step otherwise */
    if (!mo->quiet)
      printf("trained %d blocks on %d ranks (%d iterations each): %zu Gaussians merged -> %s/point_cloud/iteration_%d/point_cloud.ply\n",
             size, size, mo->iters, n_all, mo->output, mo->iters);
  }
  if (mo->vdb_resolution > 0) {
    char name[96];
    snprintf(name, sizeof name, "point_cloud/iteration_%d/point_cloud.vdb", mo->iters);
    char *vdb = mgs_path_join(mo->output, name);
    if (!vdb) mgs_mpi_die(rank, "out of memory");
    double t_vdb = MPI_Wtime();
    unsigned long long mine_vox = 0, all_vox = 0;
    mgs_mpi_merged_vdb(merged, part, rank, size, mo->vdb_resolution, mo->mpi_timeout > 0 ? mo->mpi_timeout : 600.0, mo->mpi_timeout > 0,
                       vdb, &mine_vox);
    MPI_Reduce(&mine_vox, &all_vox, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, 0, MPI_COMM_WORLD);
    if (rank == 0 && !mo->quiet)
      printf("merged .vdb by blocks: %llu alpha voxels from %d ranks, %.2f s -> %s\n", all_vox, size, MPI_Wtime() - t_vdb, vdb);
    free(vdb);
  }
  mgs_gaussians_destroy(merged);
  free(all); free(counts); free(displs); free(rows); free(heads);
  mgs_trainer_destroy(t);
  mgs_mpi_ghosts_destroy(gh);
  free(ckpt);
  free(views);
  mgs_partition_destroy(part);
  mgs_dataset_destroy(ds);
  return rc;
}

static int has_entries(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return 0;
  struct dirent *e;
  int any = 0;
  while (!any && (e = readdir(d))) any = strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
  closedir(d);
  return any;
}

/* Rank 0 decides whether RUN may be used (nothing a user had is overwritten without
   --force; --resume needs the same number of ranks) and records the layout; every rank
   learns the verdict. Returns 0 to go on, else the message is in msg (all ranks). */
static int check_run(const mgs_train_config *mo, int rank, int size, char *msg, size_t cap) {
  int bad = 0;
  msg[0] = 0;
  if (rank == 0) {
    mgs_error err;
    char *ranks = mgs_path_join(mo->output, "ranks"), *layout = mgs_path_join(mo->output, "ranks/layout.txt");
    if (!ranks || !layout) { snprintf(msg, cap, "out of memory"); bad = 1; }
    else if (mo->resume) {
      char *text = NULL;
      size_t n = 0;
      int was = 0;
      if (mgs_read_file(layout, &text, &n, &err)) { snprintf(msg, cap, "%.2047s: nothing to resume (%.1023s)", mo->output, err.msg); bad = 1; }
      else if (sscanf(text, "ranks %d", &was) != 1 || was < 1) { snprintf(msg, cap, "%s: not a layout file", layout); bad = 1; }
      else if (was != size) { snprintf(msg, cap, "%s was trained on %d ranks: resume it with mpirun -np %d (not %d)", mo->output, was, was, size); bad = 1; }
      free(text);
    } else if (mgs_is_dir(mo->output) && has_entries(mo->output) && !mo->force) {
      snprintf(msg, cap, "%s: run folder exists and is not empty (use --force to replace it or --resume to continue)", mo->output);
      bad = 1;
    } else {
      char text[64];
      int len = snprintf(text, sizeof text, "ranks %d\n", size);
      if (mgs_mkdir_p(ranks, &err) || mgs_write_file_atomic(layout, text, (size_t)len, &err)) { snprintf(msg, cap, "%s", err.msg); bad = 1; }
    }
    free(ranks); free(layout);
  }
  MPI_Bcast(&bad, 1, MPI_INT, 0, MPI_COMM_WORLD);
  MPI_Bcast(msg, (int)cap, MPI_CHAR, 0, MPI_COMM_WORLD);
  return bad;
}

int mgs_dist_train(const mgs_train_config *c, const char *data, int rank, int size) {
  char msg[MGS_CFG_PATH + 256];
  if (check_run(c, rank, size, msg, sizeof msg)) {
    if (rank == 0) fprintf(stderr, "morsegs train --mpi: %s\n", msg);
    return 2;
  }
  int rc = train_blocks(c, data, rank, size), any = 0;
  MPI_Allreduce(&rc, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return any;
}
