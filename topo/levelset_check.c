/* Narrow-band level set validation (declared in topo/mgs_levelset_check.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "topo/mgs_levelset_check.h"
#include "vdb/mgs_vdb.h"

static const int face[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

mgs_status mgs_topo_check_level_set(const mgs_vdb_grid *g, const char *source, mgs_error *err) {
  const char *src = source ? source : "grid";
  const char *name = mgs_vdb_grid_name(g);
  double b = mgs_vdb_grid_background(g), h = mgs_vdb_grid_voxel_size(g);
  if (!(isfinite(b) && b > 0))
    return mgs_error_set(err, MGS_ERR_FORMAT, "%s: level set '%s' has background %g (must be a positive half-width)", src, name, b);
  double bound = b * (1 + 1e-5) + 1e-12;
  double jump = MGS_LEVELSET_MAX_JUMP_VOXELS * h * (1 + 1e-4) + 1e-6 * b;
  /* inactive tiles: ±background */
  size_t nt = mgs_vdb_tiles(g, MGS_VDB_TILES_ALL, 1, NULL, 0);
  mgs_vdb_tile *tiles = nt ? malloc(nt * sizeof *tiles) : NULL;
  if (nt && !tiles) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory checking '%s'", src, name);
  nt = mgs_vdb_tiles(g, MGS_VDB_TILES_ALL, 1, tiles, nt);
  for (size_t i = 0; i < nt; i++) {
    if (tiles[i].active) continue;
    if (!(fabs(fabs((double)tiles[i].value) - b) <= 1e-5 * b)) {
      mgs_status st = mgs_error_set(err, MGS_ERR_FORMAT,
          "%s: broken narrow band in level set '%s': inactive tile at (%d,%d,%d) holds %g, not +-background %g",
          src, name, tiles[i].origin[0], tiles[i].origin[1], tiles[i].origin[2], tiles[i].value, b);
      free(tiles);
      return st;
    }
  }
  free(tiles);
  size_t nl = mgs_vdb_leaf_count(g);
  mgs_vdb_leaf_view *leaves = nl ? malloc(nl * sizeof *leaves) : NULL;
  if (nl && !leaves) return mgs_error_set(err, MGS_ERR_NOMEM, "%s: out of memory checking '%s'", src, name);
  nl = mgs_vdb_leaf_views(g, leaves, nl);
  /* pass 1: finite and within ± background (the clearer message when both rules fail) */
  for (size_t li = 0; li < nl; li++) {
    const mgs_vdb_leaf_view *L = &leaves[li];
    for (int off = 0; off < 512; off++) {
      if (!mgs_vdb_leaf_is_active(L, off)) continue;
      double v = L->values[off];
      int32_t ijk[3] = {L->origin[0] + (off >> 6), L->origin[1] + ((off >> 3) & 7), L->origin[2] + (off & 7)};
      if (!isfinite(v) || fabs(v) > bound) {
        mgs_status bad = !isfinite(v)
            ? mgs_error_set(err, MGS_ERR_NUMERIC, "%s: level set '%s' has a non-finite value at voxel (%d,%d,%d)",
                            src, name, ijk[0], ijk[1], ijk[2])
            : mgs_error_set(err, MGS_ERR_FORMAT,
                            "%s: broken narrow band in level set '%s': active voxel (%d,%d,%d) = %g lies beyond +-background %g",
                            src, name, ijk[0], ijk[1], ijk[2], v, b);
        free(leaves);
        return bad;
      }
    }
  }
  /* pass 2: face jumps; neighbours outside the leaf are looked up in one batch per leaf */
  int32_t ext[6 * 64 * 3];
  float extv[6 * 64];
  mgs_status st = MGS_OK;
  for (size_t li = 0; li < nl && st == MGS_OK; li++) {
    const mgs_vdb_leaf_view *L = &leaves[li];
    size_t next = 0;
    for (int off = 0; off < 512; off++) {
      if (!mgs_vdb_leaf_is_active(L, off)) continue;
      int x = off >> 6, y = (off >> 3) & 7, z = off & 7;
      double v = L->values[off];
      int32_t ijk[3] = {L->origin[0] + x, L->origin[1] + y, L->origin[2] + z};
      if (!isfinite(v)) {
        st = mgs_error_set(err, MGS_ERR_NUMERIC, "%s: level set '%s' has a non-finite value at voxel (%d,%d,%d)",
                           src, name, ijk[0], ijk[1], ijk[2]);
        break;
      }
      if (fabs(v) > bound) {
        st = mgs_error_set(err, MGS_ERR_FORMAT,
            "%s: broken narrow band in level set '%s': active voxel (%d,%d,%d) = %g lies beyond +-background %g",
            src, name, ijk[0], ijk[1], ijk[2], v, b);
        break;
      }
      for (int f = 0; f < 6; f++) {
        int nx = x + face[f][0], ny = y + face[f][1], nz = z + face[f][2];
        double u;
        if (nx < 0 || ny < 0 || nz < 0 || nx > 7 || ny > 7 || nz > 7) {
          /* outside the leaf: only the faces of the leaf reach here, at most 6·64 */
          if (next < 6 * 64) {
            ext[3 * next] = ijk[0] + face[f][0]; ext[3 * next + 1] = ijk[1] + face[f][1]; ext[3 * next + 2] = ijk[2] + face[f][2];
            next++;
          }
          continue;
        }
        u = L->values[(nx << 6) | (ny << 3) | nz];
        if (isfinite(u) && fabs(u - v) > jump) {
          st = mgs_error_set(err, MGS_ERR_FORMAT,
              "%s: broken narrow band in level set '%s': voxel (%d,%d,%d) = %g but its neighbour (%d,%d,%d) = %g "
              "(a distance field changes by at most one voxel size, %g, per voxel)",
              src, name, ijk[0], ijk[1], ijk[2], v, ijk[0] + face[f][0], ijk[1] + face[f][1], ijk[2] + face[f][2], u, h);
          break;
        }
      }
      if (st != MGS_OK) break;
    }
    if (st != MGS_OK || next == 0) continue;
    mgs_vdb_values(g, next, ext, extv, NULL);
    /* pair each outside neighbour with its voxel again (the voxel is one face step back) */
    for (size_t k = 0; k < next; k++) {
      int32_t n[3] = {ext[3 * k], ext[3 * k + 1], ext[3 * k + 2]};
      int32_t loc[3] = {n[0] - L->origin[0], n[1] - L->origin[1], n[2] - L->origin[2]};
      int32_t src_ijk[3] = {n[0], n[1], n[2]};
      for (int a = 0; a < 3; a++) {
        if (loc[a] < 0) { src_ijk[a] = n[a] + 1; }
        else if (loc[a] > 7) { src_ijk[a] = n[a] - 1; }
      }
      int off = mgs_vdb_leaf_offset(src_ijk[0] - L->origin[0], src_ijk[1] - L->origin[1], src_ijk[2] - L->origin[2]);
      double v = L->values[off], u = extv[k];
      if (isfinite(u) && fabs(u - v) > jump) {
        st = mgs_error_set(err, MGS_ERR_FORMAT,
            "%s: broken narrow band in level set '%s': voxel (%d,%d,%d) = %g but its neighbour (%d,%d,%d) = %g "
            "(a distance field changes by at most one voxel size, %g, per voxel)",
            src, name, src_ijk[0], src_ijk[1], src_ijk[2], v, n[0], n[1], n[2], u, h);
        break;
      }
    }
  }
  free(leaves);
  return st;
}
