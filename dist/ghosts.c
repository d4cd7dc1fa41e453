/* Ghost copies between the blocks of `morsegs train --mpi` (apps/train_mpi.h).
 *
 * Until the hand-off (the end of densification) every rank trains its block plus a margin
 * on its own. At the hand-off ownership is decided by position: each Gaussian is kept by
 * the rank whose block holds its mean, and the copies a rank trained of its neighbours'
 * margins are dropped (the owners' own Gaussians cover those regions; moving them over
 * would double the content there). Then each rank receives read-only ghost copies of the
 * neighbours' Gaussians whose 3σ support, grown by the margin, reaches one of its tiles.
 * Densification is over, so no rows are born: every K iterations each owner sends the
 * current parameters of the rows it exports through one MPI_Neighbor_alltoallv on a
 * distributed-graph communicator of the ranks that share ghosts, and after every step the
 * ghosts are put back to the values last received, so only their owners' gradients move
 * them. Every M iterations (--migrate-every) the Gaussians whose means have left their
 * owner's block move to the block that now holds them, with their Adam moments, and the
 * ghost layout is made again.
 *
 * Each layout (rows, neighbours) is written to RUN/ranks/rank_K.ghosts with the iteration
 * it was made at, the older ones kept until a checkpoint has passed them, so a rank resumed
 * from any checkpoint (which holds the ghosts as last received: the hook runs before the
 * checkpoint) takes the layout in force there and continues exactly. */
#ifdef MGS_HAVE_MPI
#include <math.h>
#include <stdio.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>
#include "dist/dist_internal.h"
#include "core/mgs_core.h"
#include "train/mgs_train.h"

struct mgs_mpi_ghosts {
  int rank, size, handoff, every;
  const mgs_partition *part;
  double margin;          /* world units */
  char *sidecar;          /* RUN/ranks/rank_K.ghosts */
  int active, dims;
  size_t n_own, n_ghost;  /* rows [0, n_own) owned, [n_own, n_own + n_ghost) ghosts */
  MPI_Comm graph;
  int n_nb;
  int *nb, *srows, *rrows;           /* neighbours; rows sent to / received from each */
  int *scount, *sdispl, *rcount, *rdispl; /* the same in floats, for the collective */
  uint32_t *exp;          /* owned rows sent, neighbour after neighbour */
  size_t n_exp;
  float *vals, *sbuf;     /* ghost rows / rows to send, [row][dims] */
  unsigned long long bytes_sent;
  long exchanges;
  double limit;           /* seconds an exchange may take before the run is ended */
  int explicit_limit;     /* limit came from --mpi-timeout */
  int iteration;          /* of the exchange under way (for messages) */
  int migrate_every, ckpt_every;
  int average;            /* ghosts train too; at each exchange owner and copies are averaged */
  int sum_iteration;      /* the last MPI_Allreduce of the scalars (at a migration): its iteration, */
  double sum_loss, sum_count; /* the ranks' mean loss and their owned Gaussians in all */
  unsigned long long migrated_out, migrated_in;
  char *hist;             /* the layout records the sidecar holds (oldest first) */
  size_t hist_len;
};

mgs_mpi_ghosts *mgs_mpi_ghosts_create(const mgs_partition *part, int rank, int size, int handoff, int every,
                                      int migrate_every, int checkpoint_every, double margin, const char *sidecar,
                                      double timeout) {
  mgs_mpi_ghosts *gh = calloc(1, sizeof *gh);
  if (!gh) return NULL;
  gh->migrate_every = migrate_every > 0 ? migrate_every : 0;
  gh->ckpt_every = checkpoint_every > 0 ? checkpoint_every : 0;
  gh->limit = timeout > 0 ? timeout : 600.0;
  gh->explicit_limit = timeout > 0;
  gh->rank = rank; gh->size = size; gh->handoff = handoff; gh->every = every;
  gh->part = part; gh->margin = margin; gh->graph = MPI_COMM_NULL;
  gh->sidecar = strdup(sidecar);
  for (int k = 0; k < MGS_PARAM_COUNT; k++) gh->dims += mgs_param_dim((mgs_param_group)k);
  if (!gh->sidecar) { free(gh); return NULL; }
  return gh;
}

/* forgets the ghost layout (collective: the graph communicator is freed) */
static void free_layout(mgs_mpi_ghosts *gh) {
  if (gh->graph != MPI_COMM_NULL) MPI_Comm_free(&gh->graph);
  gh->graph = MPI_COMM_NULL;
  free(gh->nb); free(gh->srows); free(gh->rrows);
  free(gh->scount); free(gh->sdispl); free(gh->rcount); free(gh->rdispl);
  free(gh->exp); free(gh->vals); free(gh->sbuf);
  gh->nb = gh->srows = gh->rrows = gh->scount = gh->sdispl = gh->rcount = gh->rdispl = NULL;
  gh->exp = NULL; gh->vals = gh->sbuf = NULL;
  gh->n_nb = 0; gh->n_exp = gh->n_ghost = 0;
}

void mgs_mpi_ghosts_destroy(mgs_mpi_ghosts *gh) {
  if (!gh) return;
  free_layout(gh);
  free(gh->sidecar); free(gh->hist);
  free(gh);
}

void mgs_mpi_ghosts_set_average(mgs_mpi_ghosts *gh, int average) { gh->average = average != 0; }

int mgs_mpi_ghosts_sums(const mgs_mpi_ghosts *gh, double *mean_loss, double *gaussians) {
  if (!gh || !gh->sum_iteration) return -1;
  *mean_loss = gh->sum_loss;
  *gaussians = gh->sum_count;
  return gh->sum_iteration;
}

void mgs_mpi_ghosts_migrated(const mgs_mpi_ghosts *gh, unsigned long long *out, unsigned long long *in) {
  *out = gh ? gh->migrated_out : 0;
  *in = gh ? gh->migrated_in : 0;
}

int mgs_mpi_ghosts_active(const mgs_mpi_ghosts *gh) { return gh && gh->active; }
size_t mgs_mpi_ghosts_owned(const mgs_mpi_ghosts *gh) { return gh->n_own; }
size_t mgs_mpi_ghosts_count(const mgs_mpi_ghosts *gh) { return gh->n_ghost; }
unsigned long long mgs_mpi_ghosts_bytes(const mgs_mpi_ghosts *gh) { return gh ? gh->bytes_sent : 0; }
long mgs_mpi_ghosts_exchanges(const mgs_mpi_ghosts *gh) { return gh ? gh->exchanges : 0; }

/* rows of `g` -> [row][dims] */
static void pack_rows(const mgs_gaussians *g, const uint32_t *rows, size_t n, int dims, float *out) {
  size_t off = 0;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    const float *src = mgs_gaussians_group((mgs_gaussians *)g, (mgs_param_group)k);
    for (size_t j = 0; j < n; j++) memcpy(out + j * (size_t)dims + off, src + (size_t)rows[j] * d, d * sizeof(float));
    off += d;
  }
}

/* the ghosts back to the values last received */
static void restore(mgs_mpi_ghosts *gh, mgs_gaussians *g) {
  size_t off = 0;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    float *dst = mgs_gaussians_group(g, (mgs_param_group)k) + gh->n_own * d;
    for (size_t j = 0; j < gh->n_ghost; j++) memcpy(dst + j * d, gh->vals + j * (size_t)gh->dims + off, d * sizeof(float));
    off += d;
  }
}

static mgs_status set_counts(mgs_mpi_ghosts *gh, mgs_error *err) {
  size_t s = 0, r = 0;
  gh->scount = calloc((size_t)gh->n_nb + 1, sizeof(int)); gh->sdispl = calloc((size_t)gh->n_nb + 1, sizeof(int));
  gh->rcount = calloc((size_t)gh->n_nb + 1, sizeof(int)); gh->rdispl = calloc((size_t)gh->n_nb + 1, sizeof(int));
  if (!gh->scount || !gh->sdispl || !gh->rcount || !gh->rdispl) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  for (int i = 0; i < gh->n_nb; i++) {
    gh->sdispl[i] = (int)(s * (size_t)gh->dims); gh->scount[i] = gh->srows[i] * gh->dims; s += (size_t)gh->srows[i];
    gh->rdispl[i] = (int)(r * (size_t)gh->dims); gh->rcount[i] = gh->rrows[i] * gh->dims; r += (size_t)gh->rrows[i];
  }
  if ((s + r) * (size_t)gh->dims > (size_t)INT32_MAX)
    return mgs_error_set(err, MGS_ERR_ARG, "too many ghost Gaussians for one MPI exchange (%zu sent, %zu received)", s, r);
  gh->n_exp = s;
  gh->n_ghost = r;
  gh->vals = malloc((r ? r : 1) * (size_t)gh->dims * sizeof(float));
  gh->sbuf = malloc((s ? s : 1) * (size_t)gh->dims * sizeof(float));
  if (!gh->vals || !gh->sbuf) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory for %zu ghost Gaussians", r);
  /* weights as rows received (gcc takes Open MPI's MPI_UNWEIGHTED sentinel for an empty array) */
  int *w = malloc(((size_t)gh->n_nb + 1) * sizeof(int));
  if (!w) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  for (int i = 0; i < gh->n_nb; i++) w[i] = gh->rrows[i] + gh->srows[i];
  int rc = MPI_Dist_graph_create_adjacent(MPI_COMM_WORLD, gh->n_nb, gh->nb, w, gh->n_nb, gh->nb, w, MPI_INFO_NULL, 0, &gh->graph);
  free(w);
  if (rc != MPI_SUCCESS) return mgs_error_set(err, MGS_ERR_IO, "MPI_Dist_graph_create_adjacent failed");
  return MGS_OK;
}

/* sbuf -> recv through the neighbourhood, bounded in time: a neighbour that never joins
   (hung, or gone without mpirun noticing) ends the run with the candidates named, rather
   than a hang. */
static void wait_bounded(mgs_mpi_ghosts *gh, MPI_Request *rqp, const char *what, int all_ranks);
static mgs_status collective(mgs_mpi_ghosts *gh, float *recv, mgs_error *err) {
  MPI_Request rq;
  if (MPI_Ineighbor_alltoallv(gh->sbuf, gh->scount, gh->sdispl, MPI_FLOAT, recv, gh->rcount, gh->rdispl, MPI_FLOAT,
                              gh->graph, &rq) != MPI_SUCCESS)
    return mgs_error_set(err, MGS_ERR_IO, "MPI_Ineighbor_alltoallv of the ghosts failed");
  wait_bounded(gh, &rq, "ghost exchange", 0);
  return MGS_OK;
}

/* Waits for a non-blocking collective; past the limit, names who it waits on (the
   neighbours, or every other rank for a collective over all of them) and ends the run. */
static void wait_bounded(mgs_mpi_ghosts *gh, MPI_Request *rqp, const char *what, int all_ranks) {
  MPI_Request rq = *rqp;
  double t0 = MPI_Wtime();
  for (long spin = 0;; spin++) {
    int done = 0;
    MPI_Test(&rq, &done, MPI_STATUS_IGNORE);
    if (done) { *rqp = rq; return; }
    if (MPI_Wtime() - t0 > gh->limit) break;
    if (spin > 1000) { struct timespec ts = {0, 1000000}; nanosleep(&ts, NULL); } /* long waits: 1 ms naps */
  }
  char msg[1024];
  size_t len = (size_t)snprintf(msg, sizeof msg, "the %s after iteration %d did not complete within %.0f s%s: "
                                "no data from %s", what, gh->iteration, gh->limit,
                                gh->explicit_limit ? " (--mpi-timeout)" : " (600 s; --mpi-timeout S sets it)",
                                all_ranks ? "one of ranks" : "neighbour rank(s)");
  for (int i = 0, named = 0; i < (all_ranks ? gh->size : gh->n_nb) && len < sizeof msg - 16; i++) {
    int q = all_ranks ? i : gh->nb[i];
    if (q != gh->rank) len += (size_t)snprintf(msg + len, sizeof msg - len, "%s %d", named++ ? "," : "", q);
  }
  snprintf(msg + len, sizeof msg - len, "; the run is ended");
  mgs_mpi_die(gh->rank, msg);
}

/* Averaging (--ghosts average): the ghosts' current values go back to their owners (the
   neighbourhood collective with the directions swapped), and each owner sets a shared
   Gaussian to the mean of its own value and every copy's, so the neighbours' views train
   it too. The owner's Adam moments stay its own. The exchange that follows sends the means
   out. */
static mgs_status average_into_owners(mgs_mpi_ghosts *gh, mgs_gaussians *g, mgs_error *err) {
  const size_t dims = (size_t)gh->dims;
  uint32_t *rows = malloc((gh->n_ghost ? gh->n_ghost : 1) * sizeof(uint32_t));
  float *mine = malloc((gh->n_ghost ? gh->n_ghost : 1) * dims * sizeof(float));
  float *back = malloc((gh->n_exp ? gh->n_exp : 1) * dims * sizeof(float));
  int *slot = malloc((gh->n_own ? gh->n_own : 1) * sizeof(int));
  double *sum = calloc((gh->n_exp ? gh->n_exp : 1) * dims, sizeof(double));
  int *cnt = calloc(gh->n_exp ? gh->n_exp : 1, sizeof(int));
  uint32_t *who = malloc((gh->n_exp ? gh->n_exp : 1) * sizeof(uint32_t));
  if (!rows || !mine || !back || !slot || !sum || !cnt || !who) mgs_mpi_die(gh->rank, "out of memory for the ghost average");
  for (size_t j = 0; j < gh->n_ghost; j++) rows[j] = (uint32_t)(gh->n_own + j);
  pack_rows(g, rows, gh->n_ghost, gh->dims, mine);
  MPI_Request rq;
  if (MPI_Ineighbor_alltoallv(mine, gh->rcount, gh->rdispl, MPI_FLOAT, back, gh->scount, gh->sdispl, MPI_FLOAT, gh->graph, &rq) !=
      MPI_SUCCESS)
    mgs_mpi_die(gh->rank, "MPI_Ineighbor_alltoallv of the ghosts (to their owners) failed");
  wait_bounded(gh, &rq, "ghost average", 0);
  gh->bytes_sent += (unsigned long long)gh->n_ghost * dims * sizeof(float);
  /* one slot per exported row (a row several neighbours hold has one slot) */
  for (size_t i = 0; i < gh->n_own; i++) slot[i] = -1;
  size_t n_slots = 0;
  for (size_t j = 0; j < gh->n_exp; j++) {
    uint32_t r = gh->exp[j];
    if (slot[r] < 0) { slot[r] = (int)n_slots; who[n_slots++] = r; }
    int k = slot[r];
    cnt[k]++;
    for (size_t c = 0; c < dims; c++) sum[(size_t)k * dims + c] += back[j * dims + c];
  }
  size_t off = 0;
  for (int grp = 0; grp < MGS_PARAM_COUNT; grp++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)grp);
    float *dst = mgs_gaussians_group(g, (mgs_param_group)grp);
    for (size_t k = 0; k < n_slots; k++)
      for (size_t c = 0; c < d; c++) {
        float *v = dst + (size_t)who[k] * d + c;
        *v = (float)((*v + sum[k * dims + off + c]) / (1.0 + cnt[k]));
      }
    off += d;
  }
  free(rows); free(mine); free(back); free(slot); free(sum); free(cnt); free(who);
  (void)err;
  return MGS_OK;
}

static mgs_status exchange(mgs_mpi_ghosts *gh, const mgs_gaussians *g, mgs_error *err) {
  pack_rows(g, gh->exp, gh->n_exp, gh->dims, gh->sbuf);
  mgs_status st = collective(gh, gh->vals, err);
  if (st) return st;
  gh->bytes_sent += (unsigned long long)gh->n_exp * (unsigned long long)gh->dims * sizeof(float);
  gh->exchanges++;
  return MGS_OK;
}

/* the ranks other than this one whose tiles the box [lo, hi] touches (samples no farther
   apart than a tile hit every tile the box overlaps), as a bit set */
static void touched_ranks(const mgs_partition *p, const double lo[3], const double hi[3], uint8_t *hit) {
  int n[3];
  double step[3];
  for (int a = 0; a < 3; a++) {
    double ext = hi[a] - lo[a];
    n[a] = ext > 0 ? (int)ceil(ext / p->tile) + 1 : 1;
    if (n[a] > 64) n[a] = 64; /* a Gaussian far larger than a tile: coarse, still safe */
    step[a] = n[a] > 1 ? ext / (n[a] - 1) : 0;
  }
  for (int i = 0; i < n[0]; i++)
    for (int j = 0; j < n[1]; j++)
      for (int k = 0; k < n[2]; k++) {
        float x[3] = {(float)(lo[0] + i * step[0]), (float)(lo[1] + j * step[1]), (float)(lo[2] + k * step[2])};
        hit[mgs_partition_owner(p, x)] = 1;
      }
}

#define GHOST_MAGIC 0x3254534f4847ull /* "GHOST2": a record of the layout history */
enum { REC_HEAD = 6 };                  /* magic, iteration, hand-off, owned rows, neighbours, exported rows */

/* The record at buf[off...] (len bytes in all): its iteration and size; 0 if damaged. */
static size_t record_at(const char *buf, size_t len, size_t off, int size, uint64_t head[REC_HEAD]) {
  if (len - off < REC_HEAD * sizeof(uint64_t)) return 0;
  memcpy(head, buf + off, REC_HEAD * sizeof(uint64_t));
  if (head[0] != GHOST_MAGIC || head[4] > (uint64_t)size || head[5] > (uint64_t)UINT32_MAX) return 0;
  size_t n = REC_HEAD * sizeof(uint64_t) + 3 * (size_t)head[4] * sizeof(int) + (size_t)head[5] * sizeof(uint32_t);
  return n <= len - off ? n : 0;
}

/* Appends this layout to the history and writes the sidecar, dropping the records no
   checkpoint can need any more: the checkpoints run after this hook, so the last one surely
   on disk is the last multiple of the checkpoint interval before this iteration, and the
   record in force there (the newest not after it) is the oldest kept. */
static mgs_status write_sidecar(mgs_mpi_ghosts *gh, int iteration, mgs_error *err) {
  size_t rec = REC_HEAD * sizeof(uint64_t) + 3 * (size_t)gh->n_nb * sizeof(int) + gh->n_exp * sizeof(uint32_t);
  long safe = gh->ckpt_every > 0 ? (long)((iteration - 1) / gh->ckpt_every) * gh->ckpt_every : -1;
  size_t keep_from = gh->hist_len, off = 0;
  uint64_t head[REC_HEAD];
  for (size_t n; off < gh->hist_len && (n = record_at(gh->hist, gh->hist_len, off, gh->size, head)); off += n)
    if ((long)head[1] <= safe) keep_from = off;
  if (keep_from == gh->hist_len) keep_from = safe >= 0 ? 0 : gh->hist_len; /* none before it: keep all */
  size_t kept = gh->hist_len - keep_from;
  char *buf = malloc(kept + rec);
  if (!buf) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  if (kept) memcpy(buf, gh->hist + keep_from, kept);
  size_t len = kept;
  uint64_t h[REC_HEAD] = {GHOST_MAGIC, (uint64_t)iteration, (uint64_t)gh->handoff, (uint64_t)gh->n_own, (uint64_t)gh->n_nb,
                          (uint64_t)gh->n_exp};
  memcpy(buf + len, h, sizeof h); len += sizeof h;
  memcpy(buf + len, gh->nb, (size_t)gh->n_nb * sizeof(int)); len += (size_t)gh->n_nb * sizeof(int);
  memcpy(buf + len, gh->srows, (size_t)gh->n_nb * sizeof(int)); len += (size_t)gh->n_nb * sizeof(int);
  memcpy(buf + len, gh->rrows, (size_t)gh->n_nb * sizeof(int)); len += (size_t)gh->n_nb * sizeof(int);
  memcpy(buf + len, gh->exp, gh->n_exp * sizeof(uint32_t)); len += gh->n_exp * sizeof(uint32_t);
  mgs_status st = mgs_write_file_atomic(gh->sidecar, buf, len, err);
  if (st) { free(buf); return st; }
  free(gh->hist);
  gh->hist = buf;
  gh->hist_len = len;
  return MGS_OK;
}

/* The ghost layout of a model that holds only this rank's own rows: which of them each
   neighbour needs, the graph communicator, a first exchange, the ghosts appended. */
static mgs_status layout(mgs_mpi_ghosts *gh, mgs_trainer *t, int iteration, mgs_error *err) {
  const mgs_partition *p = gh->part;
  mgs_gaussians *g = mgs_trainer_model_mut(t);
  mgs_status st = MGS_OK;
  gh->n_own = g->n;
  /* which owned rows each other rank needs */
  int size = gh->size;
  uint8_t *hit = calloc((size_t)size, 1);
  int *sendn = calloc((size_t)size, sizeof(int)), *recvn = calloc((size_t)size, sizeof(int));
  uint32_t **lists = calloc((size_t)size, sizeof *lists);
  size_t *cap = calloc((size_t)size, sizeof *cap);
  if (!hit || !sendn || !recvn || !lists || !cap) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto done; }
  for (size_t i = 0; i < g->n && !st; i++) {
    const float *s = g->log_scale + 3 * i;
    double r = 3.0 * exp(fmax(s[0], fmax(s[1], s[2]))) + gh->margin, lo[3], hi[3];
    if (!isfinite(r)) r = gh->margin;
    for (int a = 0; a < 3; a++) { lo[a] = g->mean[3 * i + a] - r; hi[a] = g->mean[3 * i + a] + r; }
    memset(hit, 0, (size_t)size);
    touched_ranks(p, lo, hi, hit);
    for (int q = 0; q < size; q++) {
      if (q == gh->rank || !hit[q]) continue;
      if ((size_t)sendn[q] == cap[q]) {
        cap[q] = cap[q] ? 2 * cap[q] : 1024;
        uint32_t *nl = realloc(lists[q], cap[q] * sizeof(uint32_t));
        if (!nl) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); break; }
        lists[q] = nl;
      }
      lists[q][sendn[q]++] = (uint32_t)i;
    }
  }
  /* every rank must reach the collectives below, also one that failed above */
  int bad = st != MGS_OK, any_bad = 0;
  MPI_Request rq;
  MPI_Iallreduce(&bad, &any_bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD, &rq);
  wait_bounded(gh, &rq, "hand-off", 1);
  if (any_bad) { if (!st) st = mgs_error_set(err, MGS_ERR_IO, "another rank failed at the hand-off"); goto done; }
  MPI_Ialltoall(sendn, 1, MPI_INT, recvn, 1, MPI_INT, MPI_COMM_WORLD, &rq);
  wait_bounded(gh, &rq, "hand-off", 1);
  gh->nb = malloc((size_t)size * sizeof(int)); gh->srows = malloc((size_t)size * sizeof(int));
  gh->rrows = malloc((size_t)size * sizeof(int));
  size_t total = 0;
  for (int q = 0; q < size; q++) total += (size_t)sendn[q];
  gh->exp = malloc((total ? total : 1) * sizeof(uint32_t));
  if (!gh->nb || !gh->srows || !gh->rrows || !gh->exp) { st = mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); goto done; }
  total = 0;
  for (int q = 0; q < size; q++) {
    if (q == gh->rank || (!sendn[q] && !recvn[q])) continue;
    gh->nb[gh->n_nb] = q; gh->srows[gh->n_nb] = sendn[q]; gh->rrows[gh->n_nb] = recvn[q]; gh->n_nb++;
    if (sendn[q]) memcpy(gh->exp + total, lists[q], (size_t)sendn[q] * sizeof(uint32_t));
    total += (size_t)sendn[q];
  }
  if ((st = set_counts(gh, err))) goto done;
  if ((st = exchange(gh, g, err))) goto done;
  size_t first = 0;
  if ((st = mgs_trainer_edit_model(t, NULL, gh->n_ghost, &first, err))) goto done;
  gh->active = 1;
  restore(gh, mgs_trainer_model_mut(t));
  st = write_sidecar(gh, iteration, err);
done:
  if (lists) for (int q = 0; q < size; q++) free(lists[q]);
  free(lists); free(cap); free(hit); free(sendn); free(recvn);
  return st;
}

static mgs_status handoff(mgs_mpi_ghosts *gh, mgs_trainer *t, mgs_error *err) {
  mgs_gaussians *g = mgs_trainer_model_mut(t);
  uint8_t *keep = malloc(g->n ? g->n : 1);
  if (!keep) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  for (size_t i = 0; i < g->n; i++) keep[i] = (uint8_t)(mgs_partition_owner(gh->part, g->mean + 3 * i) == gh->rank);
  mgs_status st = mgs_trainer_edit_model(t, keep, 0, NULL, err);
  free(keep);
  return st ? st : layout(gh, t, gh->handoff, err);
}

/* Owned Gaussians whose means now lie in another block go there, parameters and Adam
   moments together (one MPI_Alltoallv); the ghosts are dropped and the layout is made
   again. Every rank takes part (collectives over all ranks, bounded in time). */
static mgs_status migrate(mgs_mpi_ghosts *gh, mgs_trainer *t, int iteration, mgs_error *err) {
  mgs_gaussians *g = mgs_trainer_model_mut(t);
  const int size = gh->size, row = (int)mgs_trainer_state_floats(t);
  const size_t n_own = gh->n_own;
  int *dest = malloc((n_own ? n_own : 1) * sizeof(int));
  int *sendn = calloc((size_t)size, sizeof(int)), *recvn = calloc((size_t)size, sizeof(int));
  int *sd = calloc((size_t)size, sizeof(int)), *rd = calloc((size_t)size, sizeof(int));
  uint8_t *keep = malloc(g->n ? g->n : 1);
  if (!dest || !sendn || !recvn || !sd || !rd || !keep) mgs_mpi_die(gh->rank, "out of memory for the migration");
  size_t out = 0;
  for (size_t i = 0; i < n_own; i++) {
    dest[i] = mgs_partition_owner(gh->part, g->mean + 3 * i);
    if (dest[i] != gh->rank) sendn[dest[i]]++, out++;
  }
  MPI_Request rq;
  MPI_Ialltoall(sendn, 1, MPI_INT, recvn, 1, MPI_INT, MPI_COMM_WORLD, &rq);
  wait_bounded(gh, &rq, "migration", 1);
  size_t in = 0;
  for (int q = 0; q < size; q++) in += (size_t)recvn[q];
  if ((out + in) * (size_t)row > (size_t)INT32_MAX) mgs_mpi_die(gh->rank, "too many Gaussians to migrate in one MPI message");
  float *sb = malloc((out ? out : 1) * (size_t)row * sizeof(float)), *rb = malloc((in ? in : 1) * (size_t)row * sizeof(float));
  if (!sb || !rb) mgs_mpi_die(gh->rank, "out of memory for the migration");
  /* rows grouped by destination: parameters, then first and second moments, group by group */
  size_t at = 0;
  for (int q = 0, s = 0, r = 0; q < size; q++) {
    sd[q] = s; rd[q] = r;
    s += sendn[q] * row; r += recvn[q] * row;
    if (!sendn[q]) continue;
    for (size_t i = 0; i < n_own; i++) {
      if (dest[i] != q) continue;
      mgs_trainer_get_state(t, i, sb + at * (size_t)row);
      at++;
    }
  }
  for (int q = 0; q < size; q++) { sendn[q] *= row; recvn[q] *= row; }
  MPI_Ialltoallv(sb, sendn, sd, MPI_FLOAT, rb, recvn, rd, MPI_FLOAT, MPI_COMM_WORLD, &rq);
  wait_bounded(gh, &rq, "migration", 1);
  for (size_t i = 0; i < g->n; i++) keep[i] = (uint8_t)(i < n_own && dest[i] == gh->rank);
  size_t first = 0;
  mgs_status st = mgs_trainer_edit_model(t, keep, in, &first, err);
  if (!st) {
    for (size_t j = 0; j < in; j++) mgs_trainer_set_state(t, first + j, rb + j * (size_t)row);
    gh->migrated_out += out;
    gh->migrated_in += in;
  }
  free(dest); free(sendn); free(recvn); free(sd); free(rd); free(keep); free(sb); free(rb);
  /* every rank must reach the layout's collectives, also one whose edit failed */
  free_layout(gh);
  mgs_status st2 = layout(gh, t, iteration, err);
  return st ? st : st2;
}

/* Test hook (as cmd_train_mpi.c's): MGS_MPI_FAULT=hang-at:K:N makes rank K stop answering
   after iteration N (alive, so mpirun does not notice). */
static void fault_hang(int rank, int it) {
  const char *f = getenv("MGS_MPI_FAULT");
  int k = -1, n = 0;
  if (f && sscanf(f, "hang-at:%d:%d", &k, &n) == 2 && k == rank && n == it)
    for (;;) { struct timespec ts = {1, 0}; nanosleep(&ts, NULL); }
}

mgs_status mgs_mpi_ghosts_after_step(void *user, mgs_trainer *t, mgs_error *err) {
  mgs_mpi_ghosts *gh = user;
  int it = mgs_trainer_iteration(t);
  gh->iteration = it;
  fault_hang(gh->rank, it);
  if (!gh->active) return it == gh->handoff ? handoff(gh, t, err) : MGS_OK;
  const int migrating = gh->migrate_every > 0 && (it - gh->handoff) % gh->migrate_every == 0;
  const int exchanging = gh->every > 0 && (it - gh->handoff) % gh->every == 0;
  mgs_status st;
  /* averaging: what the copies learnt reaches the owners before the ghosts are replaced */
  if (gh->average && (migrating || exchanging) && (st = average_into_owners(gh, mgs_trainer_model_mut(t), err))) return st;
  if (migrating) {
    if ((st = migrate(gh, t, it, err))) return st;
    /* the scalars of the whole run: mean loss and Gaussians over every block */
    double v[2] = {mgs_trainer_last_loss(t), (double)gh->n_own}, sum[2] = {0, 0};
    MPI_Request rq;
    MPI_Iallreduce(v, sum, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD, &rq);
    wait_bounded(gh, &rq, "loss and count sum", 1);
    gh->sum_iteration = it;
    gh->sum_loss = sum[0] / gh->size;
    gh->sum_count = sum[1];
    if (gh->rank == 0)
      mgs_info("iteration %d: %.0f Gaussians in %d blocks, mean loss %.5f", it, gh->sum_count, gh->size, gh->sum_loss);
    return MGS_OK;
  }
  if (exchanging && (st = exchange(gh, mgs_trainer_model(t), err))) return st;
  /* owner-computed ghosts are put back after every step; averaged ones train until the next exchange */
  if (!gh->average || exchanging) restore(gh, mgs_trainer_model_mut(t));
  return MGS_OK;
}

mgs_status mgs_mpi_ghosts_resume(mgs_mpi_ghosts *gh, mgs_trainer *t, mgs_error *err) {
  int it = mgs_trainer_iteration(t);
  if (it < gh->handoff) return MGS_OK; /* the hand-off is still to come */
  char *buf = NULL;
  size_t len = 0;
  mgs_status st = mgs_read_file(gh->sidecar, &buf, &len, err);
  if (st) return st;
  const mgs_gaussians *g = mgs_trainer_model(t);
  /* every record must be whole; the one in force at the checkpoint is the newest not after it */
  uint64_t head[REC_HEAD], use[REC_HEAD] = {0};
  size_t off = 0, at = SIZE_MAX;
  while (off < len) {
    size_t n = record_at(buf, len, off, gh->size, head);
    if (!n || head[2] != (uint64_t)gh->handoff) goto bad;
    if ((long)head[1] <= it) at = off, memcpy(use, head, sizeof use);
    off += n;
  }
  if (at == SIZE_MAX || use[3] > g->n) goto bad;
  gh->n_own = (size_t)use[3];
  gh->n_nb = (int)use[4];
  off = at + REC_HEAD * sizeof(uint64_t);
  size_t nbytes = (size_t)gh->n_nb * sizeof(int);
  gh->nb = malloc(nbytes + 1); gh->srows = malloc(nbytes + 1); gh->rrows = malloc(nbytes + 1);
  if (!gh->nb || !gh->srows || !gh->rrows) { free(buf); return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); }
  memcpy(gh->nb, buf + off, nbytes); off += nbytes;
  memcpy(gh->srows, buf + off, nbytes); off += nbytes;
  memcpy(gh->rrows, buf + off, nbytes); off += nbytes;
  size_t s = 0, r = 0;
  for (int i = 0; i < gh->n_nb; i++) {
    if (gh->nb[i] < 0 || gh->nb[i] >= gh->size || gh->nb[i] == gh->rank || gh->srows[i] < 0 || gh->rrows[i] < 0) goto bad;
    s += (size_t)gh->srows[i]; r += (size_t)gh->rrows[i];
  }
  if (s != use[5] || gh->n_own + r != g->n) goto bad;
  gh->exp = malloc((s ? s : 1) * sizeof(uint32_t));
  if (!gh->exp) { free(buf); return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory"); }
  memcpy(gh->exp, buf + off, s * sizeof(uint32_t));
  for (size_t j = 0; j < s; j++) if (gh->exp[j] >= gh->n_own) goto bad;
  /* the history as far as this checkpoint: later records belong to a future that is redone */
  free(gh->hist);
  gh->hist = buf;
  gh->hist_len = at + record_at(buf, len, at, gh->size, head);
  if ((st = set_counts(gh, err))) return st;
  /* the checkpoint holds the ghosts as last received */
  uint32_t *rows = malloc((gh->n_ghost ? gh->n_ghost : 1) * sizeof(uint32_t));
  if (!rows) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  for (size_t j = 0; j < gh->n_ghost; j++) rows[j] = (uint32_t)(gh->n_own + j);
  pack_rows(g, rows, gh->n_ghost, gh->dims, gh->vals);
  free(rows);
  gh->active = 1;
  return MGS_OK;
bad:
  free(buf);
  return mgs_error_set(err, MGS_ERR_FORMAT, "%s: not the ghost layout of this rank's checkpoint (written at the hand-off, "
                       "iteration %d, and at each migration); resume is not possible without it", gh->sidecar, gh->handoff);
}
/* One more exchange into a scratch buffer: the largest difference between a ghost as
   this rank holds it and its owner's current value (0 right after an exchange). */
mgs_status mgs_mpi_ghosts_lag(mgs_mpi_ghosts *gh, const mgs_trainer *t, double *lag, mgs_error *err) {
  *lag = 0;
  if (!gh->active) return MGS_OK;
  gh->iteration = mgs_trainer_iteration(t);
  size_t nv = gh->n_ghost * (size_t)gh->dims;
  float *now = malloc((nv ? nv : 1) * sizeof(float));
  if (!now) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  pack_rows(mgs_trainer_model(t), gh->exp, gh->n_exp, gh->dims, gh->sbuf);
  mgs_status st = collective(gh, now, err);
  if (st) { free(now); return st; }
  const mgs_gaussians *g = mgs_trainer_model(t);
  size_t off = 0;
  for (int k = 0; k < MGS_PARAM_COUNT; k++) {
    size_t d = (size_t)mgs_param_dim((mgs_param_group)k);
    const float *held = mgs_gaussians_group((mgs_gaussians *)g, (mgs_param_group)k) + gh->n_own * d;
    for (size_t j = 0; j < gh->n_ghost; j++)
      for (size_t c = 0; c < d; c++) *lag = fmax(*lag, fabs((double)held[j * d + c] - now[j * (size_t)gh->dims + off + c]));
    off += d;
  }
  free(now);
  return MGS_OK;
}
#endif
