/* PLACEHOLDER: replaced by the implementation of `morsegs bench train`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_bench_train(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs bench train: not implemented yet\n"); return 1; }
