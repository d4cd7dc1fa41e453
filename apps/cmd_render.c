/* PLACEHOLDER: replaced by the implementation of `morsegs render`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_cmd_render(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs render: not implemented yet\n"); return 1; }
