/* PLACEHOLDER: replaced by the implementation of `morsegs persistence`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_cmd_persistence(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs persistence: not implemented yet\n"); return 1; }
