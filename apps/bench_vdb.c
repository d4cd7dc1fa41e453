/* PLACEHOLDER: replaced by the implementation of `morsegs bench vdb`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_bench_vdb(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs bench vdb: not implemented yet\n"); return 1; }
