/* The `morsegs` command line: one entry point per subcommand, each in its own file
 * (cmd_<name>.c), and the benchmarks of `morsegs bench NAME` (bench_<name>.c). Every
 * command returns a process exit code: 0 success, 1 runtime error (message printed),
 * 2 usage error. */
#ifndef MGS_CLI_H
#define MGS_CLI_H
#include "core/mgs_error.h"
#include "train/mgs_config.h"

int mgs_cmd_demo(int argc, char **argv);
int mgs_cmd_report(int argc, char **argv);
int mgs_cmd_scene(int argc, char **argv);
int mgs_cmd_train(int argc, char **argv);
int mgs_cmd_render(int argc, char **argv);
int mgs_cmd_eval(int argc, char **argv);
int mgs_cmd_vdb(int argc, char **argv);
/* morsegs vdb RUN --sugar-mesh (apps/cmd_vdb_sugar.c) */
struct mgs_sugar_mesh_options;
int mgs_cmd_vdb_sugar(const char *run, int iteration, const struct mgs_sugar_mesh_options *o, int resolution, int force);
int mgs_cmd_persistence(int argc, char **argv);
int mgs_cmd_bench(int argc, char **argv);
int mgs_cmd_experiment(int argc, char **argv);

int mgs_bench_io(int argc, char **argv);
int mgs_bench_scene(int argc, char **argv);
int mgs_bench_raster(int argc, char **argv);
int mgs_bench_train(int argc, char **argv);
int mgs_bench_vdb(int argc, char **argv);
int mgs_bench_topo(int argc, char **argv);
int mgs_bench_diagram(int argc, char **argv);
int mgs_bench_scale(int argc, char **argv);
int mgs_bench_mpi(int argc, char **argv);
int mgs_bench_patchmatch(int argc, char **argv);
/* `morsegs train` on a parsed config: the serial trainer, and `--mpi` (apps/cmd_train_mpi.c) */
int mgs_cmd_train_config(mgs_train_config *c, const char *data);
int mgs_cmd_train_mpi(mgs_train_config *c, const char *data);

/* Prints "morsegs <cmd>: <message>" to stderr and returns 1 (for `return mgs_cli_fail(...)`). */
int mgs_cli_fail(const char *cmd, const mgs_error *err);
/* --mask-carve PX|off (measure/mgs_depth_fusion.h's mask_carve_px, off = -1) into *px;
 * 0 after printing the usage error naming the command and the value. */
int mgs_cli_mask_carve(const char *cmd, const char *arg, int *px);
#endif
