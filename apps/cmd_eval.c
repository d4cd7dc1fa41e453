/* PLACEHOLDER: replaced by the implementation of `morsegs eval`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_cmd_eval(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs eval: not implemented yet\n"); return 1; }
