/* Internals of the distributed trainer shared by its files (dist/train_blocks.c,
 * dist/merged_vdb.c, dist/ghosts.c). Only compiled with MPI. */
#ifndef MGS_DIST_INTERNAL_H
#define MGS_DIST_INTERNAL_H
#ifdef MGS_HAVE_MPI
#include <mpi.h>
#include "core/mgs_gaussians.h"
#include "train/mgs_partition.h"

/* Ends every rank: a message naming this rank, then MPI_Abort. */
void mgs_mpi_die(int rank, const char *what);
/* Rank 0 waits for rq[1..n-1] until `limit` seconds have passed; then names every rank
 * whose message (`what`) has not come and ends the run. */
void mgs_mpi_wait_all(MPI_Request *rq, int n, double limit, const char *what, int explicit_limit);

/* The merged model's α-field computed by blocks: every rank builds the field over the voxels
 * it owns (the partition's owner of the voxel centre), from the Gaussians whose kσ support
 * reaches its tiles; rank 0 unions the disjoint pieces, derives the SDF and density and
 * writes `path` as `morsegs vdb` would from the merged .ply. `merged` on rank 0 (broadcast
 * here), NULL elsewhere. *voxels_out = the active α voxels this rank contributed. */
void mgs_mpi_merged_vdb(const mgs_gaussians *merged, const mgs_partition *part, int rank, int size, int resolution,
                        double limit, int explicit_limit, const char *path, unsigned long long *voxels_out);

/* Ghost copies after the hand-off (apps/train_mpi_ghosts.c). Installed as the trainer's
 * after_step hook (user = the handle): at iteration `handoff` each rank keeps the Gaussians
 * its block holds and receives read-only copies of the neighbours' Gaussians whose 3σ
 * support grown by `margin` (world units) reaches its tiles; every `every` iterations
 * (0: only at the hand-off) the owners send their current values; every `migrate_every`
 * iterations (0: never) Gaussians whose means left their owner's block move to the block
 * that holds them, with their Adam moments, and the layout is made again. `sidecar`: where
 * the layouts are kept for --resume (as far back as the last checkpoint, every
 * `checkpoint_every` iterations, needs). An exchange that has not completed after `timeout`
 * seconds (<= 0: 600) ends the run, naming this rank's neighbours. */
typedef struct mgs_mpi_ghosts mgs_mpi_ghosts;
mgs_mpi_ghosts *mgs_mpi_ghosts_create(const mgs_partition *part, int rank, int size, int handoff, int every,
                                      int migrate_every, int checkpoint_every, double margin, const char *sidecar,
                                      double timeout);
void mgs_mpi_ghosts_destroy(mgs_mpi_ghosts *gh);
struct mgs_trainer;
mgs_status mgs_mpi_ghosts_after_step(void *user, struct mgs_trainer *t, mgs_error *err);
/* After a checkpoint was loaded: past the hand-off, the layout is read back from `sidecar`. */
mgs_status mgs_mpi_ghosts_resume(mgs_mpi_ghosts *gh, struct mgs_trainer *t, mgs_error *err);
int mgs_mpi_ghosts_active(const mgs_mpi_ghosts *gh);  /* the hand-off has happened */
size_t mgs_mpi_ghosts_owned(const mgs_mpi_ghosts *gh); /* rows [0, owned) are this rank's */
size_t mgs_mpi_ghosts_count(const mgs_mpi_ghosts *gh);
unsigned long long mgs_mpi_ghosts_bytes(const mgs_mpi_ghosts *gh); /* sent by this rank so far */
long mgs_mpi_ghosts_exchanges(const mgs_mpi_ghosts *gh);
/* 1: ghosts train on their holders' views too and, at each exchange, every shared Gaussian
 * becomes the mean of its owner's value and its copies' (0, default: ghosts read-only,
 * owner-computed). */
void mgs_mpi_ghosts_set_average(mgs_mpi_ghosts *gh, int average);
/* The scalars summed over every rank (MPI_Allreduce) at the last migration: the ranks'
 * mean loss and their owned Gaussians in all; returns its iteration (-1: none yet). */
int mgs_mpi_ghosts_sums(const mgs_mpi_ghosts *gh, double *mean_loss, double *gaussians);
/* Gaussians this rank sent to and received from other blocks by migration so far. */
void mgs_mpi_ghosts_migrated(const mgs_mpi_ghosts *gh, unsigned long long *out, unsigned long long *in);
/* Collective: the largest |ghost - its owner's current value| over this rank's ghosts. */
mgs_status mgs_mpi_ghosts_lag(mgs_mpi_ghosts *gh, const struct mgs_trainer *t, double *lag, mgs_error *err);
#endif
#endif
