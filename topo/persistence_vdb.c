/* The VDB entry point: a grid's leaves and non-background tiles become the sparse block
 * input (topo/cubical_blocks.c); voxel size and translation give world positions. */
#include <stdlib.h>
#include "topo/cubical_internal.h"
#include "vdb/mgs_vdb.h"

mgs_status mgs_topo_persistence_vdb_stats(const mgs_vdb_grid *g, const mgs_topo_opts *opts_in,
                                          mgs_diagram **out, mgs_topo_stats *stats, mgs_error *err) {
  if (!g || !out) return mgs_error_set(err, MGS_ERR_ARG, "persistence: null argument");
  *out = NULL;
  mgs_topo_opts opts;
  if (opts_in) opts = *opts_in; else mgs_topo_opts_default(&opts);
  float bg = mgs_vdb_grid_background(g);
  mgs_vdb_class cls = mgs_vdb_grid_class(g);
  const char *name = mgs_vdb_grid_name(g);
  if (cls == MGS_VDB_CLASS_LEVEL_SET && opts.filtration != MGS_TOPO_SUBLEVEL)
    return mgs_error_set(err, MGS_ERR_ARG, "persistence: grid '%s' is a level set: use the sublevel filtration", name ? name : "");
  if (cls == MGS_VDB_CLASS_LEVEL_SET && !(bg > 0))
    return mgs_error_set(err, MGS_ERR_FORMAT, "persistence: level set '%s' has a non-positive background %g", name ? name : "", (double)bg);
  opts.voxel_size = mgs_vdb_grid_voxel_size(g);
  mgs_vdb_grid_translation(g, opts.origin);
  mgs_topo_sparse *s = NULL;
  mgs_status st = mgs_topo_sparse_create(bg, &s, err);
  if (st != MGS_OK) return st;
  size_t nl = mgs_vdb_leaf_count(g);
  mgs_vdb_leaf_view *lv = malloc((nl ? nl : 1) * sizeof *lv);
  size_t nt = mgs_vdb_tiles(g, MGS_VDB_TILES_ALL, 0, NULL, 0);
  mgs_vdb_tile *tv = malloc((nt ? nt : 1) * sizeof *tv);
  if (!lv || !tv) { st = mgs_error_set(err, MGS_ERR_NOMEM, "persistence: out of memory (%zu leaves)", nl); goto done; }
  nl = mgs_vdb_leaf_views(g, lv, nl);
  nt = mgs_vdb_tiles(g, MGS_VDB_TILES_ALL, 0, tv, nt);
  for (size_t i = 0; i < nl && st == MGS_OK; i++) {
    st = mgs_topo_sparse_add_leaf(s, lv[i].origin, lv[i].values, err);
    if (st != MGS_OK && err)
      mgs_error_set(err, st, "persistence: grid '%s', leaf at (%d,%d,%d): %s", name ? name : "", lv[i].origin[0],
                    lv[i].origin[1], lv[i].origin[2], st == MGS_ERR_NUMERIC ? "non-finite value" : "bad leaf");
  }
  for (size_t i = 0; i < nt && st == MGS_OK; i++) st = mgs_topo_sparse_add_tile(s, tv[i].origin, tv[i].dim, tv[i].value, err);
  if (st == MGS_OK) {
    double wl = cls == MGS_VDB_CLASS_LEVEL_SET ? (double)bg : INFINITY;
    mgs_topo_stats local;
    st = mgs_topo_persistence_sparse_stats(s, &opts, wl, out, &local, err);
    local.active_voxels = mgs_vdb_grid_active_voxel_count(g);
    if (*out) (*out)->n_active_voxels = local.active_voxels;
    if (stats) *stats = local;
  }
done:
  free(lv);
  free(tv);
  mgs_topo_sparse_destroy(s);
  return st;
}

mgs_status mgs_topo_persistence_vdb(const mgs_vdb_grid *g, const mgs_topo_opts *opts, mgs_diagram **out,
                                    mgs_error *err) {
  return mgs_topo_persistence_vdb_stats(g, opts, out, NULL, err);
}
