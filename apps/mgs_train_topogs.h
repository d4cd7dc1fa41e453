/* Topology-GS's flags of `morsegs train` (SPEC §5.3), kept out of cmd_train.c's option
 * table: cmd_train.c calls mgs_topogs_flags_extract() first, which removes these flags
 * from argv, and then asks this block for the initial model (--init lpvi), the loss term
 * (--pers-loss), the cfg_args record and the usage text.
 *
 *   --preset topology-gs      = --init lpvi + --pers-loss (the authors' defaults); other
 *                               --preset values are left in argv for cmd_train.c
 *   --lpvi-faithful           the authors' LPVI (train/mgs_lpvi.h); default corrected
 *   --lpvi-tau T (0.25)  --lpvi-max-edge E (2.0)
 *   --pers-loss[=λ]           PersLoss with weight λ (10)
 *   --pers-loss-form topk|betti   --pers-loss-downsample F (0.09)
 *   --pers-loss-k K0,K1,K2 (10,20,50)   --pers-loss-schedule FROM,UNTIL,EVERY (1500,15000,200) */
#ifndef MGS_TRAIN_TOPOGS_H
#define MGS_TRAIN_TOPOGS_H
#include <stdio.h>
#include "core/mgs_dataset.h"
#include "core/mgs_gaussians.h"
#include "train/mgs_lpvi.h"
#include "train/mgs_persloss.h"
#include "train/mgs_train.h"

typedef struct mgs_topogs_flags {
  int preset;            /* --preset topology-gs given */
  mgs_lpvi_options lpvi;
  int pers;              /* PersLoss on */
  mgs_persloss_options pl;
  unsigned given;        /* bit per flag typed (for --resume: the rest comes from cfg_args) */
} mgs_topogs_flags;

void mgs_topogs_flags_init(mgs_topogs_flags *f);
/* Removes this block's flags from argv (updating *argc; argv[*argc] stays NULL). Returns 0,
 * or 2 after printing a one-line error naming the flag. */
int mgs_topogs_flags_extract(int *argc, char **argv, mgs_topogs_flags *f);
/* The --init to use: "lpvi" under the preset unless --init was typed. */
const char *mgs_topogs_init(const mgs_topogs_flags *f, const char *init, int init_given);
/* --resume: settings not typed again come from the run's cfg_args. */
void mgs_topogs_flags_restore(mgs_topogs_flags *f, const mgs_settings *prev);
void mgs_topogs_flags_record(const mgs_topogs_flags *f, int lpvi_used, mgs_settings *s);
/* --init lpvi: LPVI over the dataset's points (the random init's when it has none). */
mgs_status mgs_topogs_init_model(mgs_topogs_flags *f, const mgs_dataset *ds, int sh_degree, uint64_t seed,
                                 int random_points, mgs_gaussians **out, mgs_error *err);
/* --pers-loss: adds the term. */
mgs_status mgs_topogs_add_terms(const mgs_topogs_flags *f, mgs_trainer *t, mgs_error *err);
void mgs_topogs_usage(FILE *out);

#endif
