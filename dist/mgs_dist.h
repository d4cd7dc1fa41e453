/* Distributed training (dist/, Open MPI): it owns
 *   blocks ........... the scene's points cut into K blocks (train/mgs_partition.h), each rank
 *                      training its block and ghost copies within a margin on the views
 *                      that see it (dist/train_blocks.c)
 *   hand-off, ghosts,  at --densify-until each rank keeps what its block holds; neighbours'
 *   migration ........ Gaussians as ghosts refreshed by their owners, Gaussians that leave a
 *                      block moved with their Adam state (dist/ghosts.c)
 *   the merged model . point_cloud.ply on rank 0, and the merged .vdb built by blocks
 *                      (dist/merged_vdb.c)
 * It reads the same configuration as the serial trainer (train/mgs_config.h) and drives the
 * trainer through its public hooks. Depends on train/ and MPI only. */
#ifndef MGS_DIST_H
#define MGS_DIST_H
#include "train/mgs_config.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Call on every rank between MPI_Init and MPI_Finalize, with size > 1 (one process is the
 * serial trainer). c has been validated for `size` ranks (mgs_config_validate). Returns the
 * same exit code on every rank: 0 done, 2 a run folder refused (message printed by rank 0).
 * A rank that fails ends the job through MPI_Abort with its rank and message: MPI's way to
 * end a job whose peers would otherwise wait for it forever. */
int mgs_dist_train(const mgs_train_config *c, const char *data, int rank, int size);

#ifdef __cplusplus
}
#endif
#endif
