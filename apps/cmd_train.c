/* PLACEHOLDER: replaced by the implementation of `morsegs train`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_cmd_train(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs train: not implemented yet\n"); return 1; }
