/* PLACEHOLDER: replaced by the implementation of `morsegs bench topo`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_bench_topo(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs bench topo: not implemented yet\n"); return 1; }
