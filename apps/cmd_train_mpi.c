/* `mpirun -np K morsegs train --mpi DATA -o RUN [options]`: the same options as `morsegs
 * train` (train/mgs_config.h); one process is the serial trainer (the same model as
 * `morsegs train`), more run the distributed trainer (dist/mgs_dist.h), which refuses, by
 * the option table, every option it does not honour. */
#include <stdio.h>
#include "apps/mgs_cli.h"
#include "core/mgs_core.h"
#ifdef MGS_HAVE_MPI
#include <mpi.h>
#include "dist/mgs_dist.h"
#endif

int mgs_cmd_train_mpi(mgs_train_config *c, const char *data) {
#ifndef MGS_HAVE_MPI
  (void)c; (void)data;
  fprintf(stderr, "morsegs train: --mpi: this morsegs was built without MPI (install libopenmpi-dev, rebuild)\n");
  return 2;
#else
  int provided = 0;
  if (MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
    fprintf(stderr, "morsegs train --mpi: MPI_Init failed\n");
    return 1;
  }
  int rank = 0, size = 1, rc;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  mgs_error err;
  if (size == 1) {
    rc = mgs_cmd_train_config(c, data);
  } else if (mgs_config_validate(c, size, &err)) {
    if (rank == 0) fprintf(stderr, "morsegs train --mpi: %s\n", err.msg);
    rc = 2;
  } else {
    if (c->threads) mgs_parallel_set_threads(c->threads);
    rc = mgs_dist_train(c, data, rank, size);
  }
  MPI_Finalize();
  return rc;
#endif
}
