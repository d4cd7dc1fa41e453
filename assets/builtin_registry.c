/* The table of builtin scenes: names, one-line descriptions and constructors. */
#include <string.h>
#include "assets/mgs_assets.h"
#include "assets/assets_internal.h"

typedef struct {
  const char *name, *description;
  mgs_status (*make)(int detail, mgs_mesh **out, mgs_error *err);
} builtin;

static const builtin table[] = {
    {"sphere", "bumpy blob, closed, genus 0", mgs_builtin_sphere},
    {"genus2", "double torus, closed, genus 2", mgs_builtin_genus2},
    {"thin", "thin rods and plates on a stand, a wire ring, 5 small floating balls (14 parts)", mgs_builtin_thin},
};
#define N_BUILTIN (sizeof table / sizeof table[0])

size_t mgs_assets_builtin_count(void) { return N_BUILTIN; }
const char *mgs_assets_builtin_name(size_t i) { return i < N_BUILTIN ? table[i].name : NULL; }
const char *mgs_assets_builtin_description(size_t i) { return i < N_BUILTIN ? table[i].description : NULL; }

mgs_status mgs_assets_builtin_detail(const char *name, int detail, mgs_mesh **out, mgs_error *err) {
  *out = NULL;
  if (detail < 1 || detail > 16) return mgs_error_set(err, MGS_ERR_ARG, "builtin %s: detail %d out of range (1..16)", name ? name : "?", detail);
  for (size_t i = 0; name && i < N_BUILTIN; i++)
    if (!strcmp(name, table[i].name)) return table[i].make(detail, out, err);
  return mgs_error_set(err, MGS_ERR_ARG, "unknown builtin scene '%s' (known: sphere, genus2, thin)", name ? name : "");
}

mgs_status mgs_assets_builtin(const char *name, mgs_mesh **out, mgs_error *err) {
  return mgs_assets_builtin_detail(name, 1, out, err);
}
