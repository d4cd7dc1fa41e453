/* PLACEHOLDER: replaced by the implementation of `morsegs bench scene`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_bench_scene(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs bench scene: not implemented yet\n"); return 1; }
