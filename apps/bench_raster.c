/* PLACEHOLDER: replaced by the implementation of `morsegs bench raster`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_bench_raster(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs bench raster: not implemented yet\n"); return 1; }
