/* PLACEHOLDER: replaced by the implementation of `morsegs demo`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_cmd_demo(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs demo: not implemented yet\n"); return 1; }
