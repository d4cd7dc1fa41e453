/* Hook of `morsegs eval` for geometry metrics against a ground-truth mesh (Chamfer
 * distance, F-score, floater count), implemented in measure/eval_geometry.c by the vdb
 * work. cmd_eval calls it when --mesh GT is given or the dataset has gt_mesh.ply.
 *   ply_path          the trained 3DGS .ply
 *   gt_mesh_path      the ground-truth mesh (OBJ/PLY/OFF)
 *   cjson_object_out  a cJSON* object (passed as void*) to add the metrics to
 *   table_out         receives readable table rows (NUL-terminated, at most table_len)
 * Returns 0 on success; non-zero makes eval skip the geometry metrics with a note. */
#ifndef MGS_EVAL_GEOMETRY_H
#define MGS_EVAL_GEOMETRY_H
#include <stddef.h>

/* Chamfer (and its two directions), F-score, precision and recall of `metrics` (a
 * const mgs_geometry_metrics *, render/mgs_mesh_distance.h) into a cJSON object (void *):
 * the same keys for both surfaces. */
void mgs_eval_geometry_add_metrics(void *cjson_object, const void *metrics);
int mgs_eval_geometry(const char *ply_path, const char *gt_mesh_path, void *cjson_object_out, char *table_out,
                      size_t table_len);
/* The same for the surface of the model's depth fused at the run's cameras
 * (measure/eval_geometry_fused.c; `morsegs vdb RUN`'s default): Chamfer, F-score and the
 * fusion's settings into the object; a note on stderr and non-zero when it fails. */
typedef struct mgs_fusion_opts mgs_fusion_opts;
int mgs_eval_geometry_fused(const char *run_dir, const mgs_fusion_opts *opts, const char *gt_mesh_path,
                            void *cjson_object_out, char *table_out, size_t table_len);
/* The same metrics for a mesh file (measure/eval_geometry_sugar.c: SuGaR's RUN/mesh/sugar.ply,
 * eval's geometry.sugar), with the α-surface's samples and threshold. */
int mgs_eval_geometry_mesh(const char *mesh_path, const char *gt_mesh_path, void *cjson_object_out, char *table_out,
                           size_t table_len);
#endif
