/* `morsegs train`'s MorseGS flags (presets, --spawn/--prune, --topo-loss, thresholds),
 * kept apart from apps/cmd_train.c: train_morse_flags_take() removes them from argv before
 * cmd_train's own getopt runs, and may add the plain flags a preset implies (--strategy,
 * --init, --normal-loss) when they were not typed. */
#ifndef MGS_TRAIN_MORSE_FLAGS_H
#define MGS_TRAIN_MORSE_FLAGS_H
#include "train/mgs_morse.h"
#include "train/mgs_term.h"
#include "topo/mgs_persistence.h"
#include "train/mgs_train.h"

typedef struct train_morse_flags {
  mgs_morse_options o;
  const char *preset;     /* NULL = none */
  int literal;
  int any_typed;          /* a morse flag was typed */
  int spawn_typed, prune_typed, topo_typed;
  char *argv_storage[8];  /* strings added to argv */
  char **argv_alloc;      /* the argv array handed back */
} train_morse_flags;

/* Parses and removes the morse flags from argv (argc updated); on --resume (with -o RUN)
 * restores settings not typed from RUN/cfg_args. Returns 0 after printing a one-line error
 * naming the flag, else 1. *argv_out is a new array (free with the flags). */
int train_morse_flags_take(int *argc, char ***argv, train_morse_flags *f);
/* With the strategy chosen: fills the strategy defaults and checks ranges and the grid
 * budget (prints the error, returns 0). Called before anything is written. */
int train_morse_flags_check(train_morse_flags *f, const char *strategy, int iterations);
/* Settings for cfg_args. */
void train_morse_flags_record(const train_morse_flags *f, const char *strategy, mgs_settings *s);
void train_morse_flags_free(train_morse_flags *f);
/* usage lines */
extern const char *train_morse_flags_usage;
#endif
