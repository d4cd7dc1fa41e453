/* The loss-term wrapper (train/mgs_term.h). */
#include <stdlib.h>
#include "train/mgs_term.h"

mgs_term *mgs_term_create(const mgs_term_ops *ops, void *self) {
  mgs_term *t = malloc(sizeof *t);
  if (!t) {
    if (ops && ops->destroy) ops->destroy(self);
    return NULL;
  }
  t->ops = ops;
  t->self = self;
  return t;
}

void mgs_term_destroy(mgs_term *t) {
  if (!t) return;
  if (t->ops && t->ops->destroy) t->ops->destroy(t->self);
  free(t);
}
