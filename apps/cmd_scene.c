/* PLACEHOLDER: replaced by the implementation of `morsegs scene`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_cmd_scene(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs scene: not implemented yet\n"); return 1; }
