/* Internals of `morsegs train --mpi` shared by its files (apps/cmd_train_mpi.c,
 * apps/train_mpi_vdb.c). Only compiled with MPI. */
#ifndef MGS_APPS_TRAIN_MPI_H
#define MGS_APPS_TRAIN_MPI_H
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
#endif
#endif
