/* PLACEHOLDER: replaced by the implementation of `morsegs vdb`. */
#include <stdio.h>
#include "apps/mgs_cli.h"
int mgs_cmd_vdb(int argc, char **argv) { (void)argc; (void)argv; fprintf(stderr, "morsegs vdb: not implemented yet\n"); return 1; }
