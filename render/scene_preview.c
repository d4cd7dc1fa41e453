/* Pictures of a mesh that lies in a scene's world frame (a dataset's gt_mesh.ply, the
 * surface `morsegs vdb --mesh` extracts from a model trained on it): the scene's own
 * Embree renderer and shading, seen from the test rig's cameras around the origin. */
#include <math.h>
#include <stdlib.h>
#include "render/mgs_scene.h"

mgs_status mgs_scene_render_mesh_views(const mgs_mesh *mesh, int n_views, int size, mgs_image **views, mgs_error *err) {
  if (!views || n_views < 1 || n_views > 64 || size < 8 || size > 4096)
    return mgs_error_set(err, MGS_ERR_ARG, "mesh views: need 1..64 views of 8..4096 pixels");
  for (int i = 0; i < n_views; i++) views[i] = NULL;
  mgs_scene_options o;
  mgs_scene_options_default(&o);
  o.width = o.height = size;
  o.n_test = n_views;
  o.specular = 1;
  o.spp = 2;
  o.allow_open = 1; /* extracted surfaces may have boundary edges */
  o.quiet = 1;
  o.mesh_name = "mesh views";
  mgs_status s = mgs_scene_check_mesh(mesh, &o, err);
  if (s != MGS_OK) return s;
  double bound = 0;
  for (size_t i = 0; i < mesh->nv; i++) {
    const float *p = mesh->v + 3 * i;
    double r = sqrt((double)p[0] * p[0] + (double)p[1] * p[1] + (double)p[2] * p[2]);
    if (r > bound) bound = r;
  }
  mgs_camera *cams = calloc((size_t)n_views, sizeof *cams);
  if (!cams) return mgs_error_set(err, MGS_ERR_NOMEM, "mesh views: out of memory");
  mgs_scene_make_cameras(&o, 1, n_views, mgs_scene_camera_radius(&o, bound), cams);
  mgs_scene_renderer *r = NULL;
  s = mgs_scene_renderer_create(mesh, &r, err);
  for (int i = 0; i < n_views && s == MGS_OK; i++) {
    views[i] = mgs_image_create(size, size, 4);
    if (!views[i]) s = mgs_error_set(err, MGS_ERR_NOMEM, "mesh views: out of memory");
    else mgs_scene_render_view(r, &cams[i], &o, (uint32_t)i, views[i]);
  }
  mgs_scene_renderer_destroy(r);
  free(cams);
  if (s != MGS_OK)
    for (int i = 0; i < n_views; i++) { mgs_image_destroy(views[i]); views[i] = NULL; }
  return s;
}
