/* libFuzzer target: the mesh reader (mgs_mesh_read: header checks, then assimp). The first
 * byte picks the file's extension (.ply, .obj, .off, .stl: assimp chooses its reader by
 * extension and content), the rest is the file. A read either gives a mesh whose indices
 * are in range and vertices finite, or fails with a message naming the file. */
#include <math.h>
#include "core/mgs_mesh.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static char *paths[4];
  static const char *names[4] = {"input.ply", "input.obj", "input.off", "input.stl"};
  if (size < 1) return 0;
  const int k = data[0] & 3;
  if (!paths[k]) paths[k] = fuzz_path(names[k]);
  fuzz_write(paths[k], data + 1, size - 1);
  mgs_error err;
  mgs_mesh *m = NULL;
  if (mgs_mesh_read(paths[k], &m, &err) == MGS_OK) {
    if (!m || m->nv == 0 || m->nt == 0) abort();
    for (size_t i = 0; i < m->nt * 3; i++)
      if (m->t[i] >= m->nv) abort();
    for (size_t i = 0; i < m->nv * 3; i++)
      if (!isfinite(m->v[i])) abort();
    mgs_mesh_destroy(m);
  } else if (m || !strstr(err.msg, names[k])) {
    abort();
  }
  return 0;
}
