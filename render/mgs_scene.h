/* Ground-truth scene maker: renders a NeRF-synthetic dataset of a triangle mesh with
 * Embree (C API, called directly). Owns: the camera rig (Fibonacci spiral on a sphere or
 * upper hemisphere, jittered by the seed), the shading (diffuse albedo: the mesh's own
 * diffuse texture through its UVs, else its vertex colours, else a procedural 3D texture;
 * optional Blinn-Phong specular, headlight + fixed directional light), the
 * antialiased RGBA images (stratified supersampling, alpha = coverage), and the dataset
 * folder (train/, test/, transforms_{train,test}.json, gt_mesh.ply, points3d.ply,
 * scene.json), written into a staging folder and renamed into place at the end.
 * Everything is a pure function of (mesh, options): the same seed gives identical files.
 *
 * World frame: the mesh is normalized so its bounding box is centred at the origin with
 * largest side 2 (it fits [-1,1]^3); +z is up (Blender convention), cameras look at the
 * origin. */
#ifndef MGS_SCENE_H
#define MGS_SCENE_H
#include <stddef.h>
#include <stdint.h>
#include "core/mgs_error.h"
#include "core/mgs_camera.h"
#include "core/mgs_image.h"
#include "core/mgs_mesh.h"
#include "core/mgs_texture.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { MGS_SCENE_INIT_NONE = 0, MGS_SCENE_INIT_RANDOM, MGS_SCENE_INIT_SURFACE } mgs_scene_init;

typedef struct mgs_scene_options {
  int n_train, n_test;     /* views per split (60 / 20) */
  int width, height;       /* pixels (200 x 200) */
  double fovx;             /* horizontal field of view, radians (0.6911, as NeRF-synthetic) */
  double radius;           /* camera distance from the origin; 0 = fit the bounding sphere */
  int hemisphere;          /* 1: cameras on the upper (z > 0) hemisphere only */
  int specular;            /* 1: add a Blinn-Phong highlight (view-dependent colour) */
  double texture_scale;    /* the albedo is evaluated at texture_scale x position (1): finer
                              texture gives feature detectors (COLMAP's SIFT) corners to find */
  int spp;                 /* supersampling: spp x spp stratified samples per pixel (4) */
  int white_background;    /* RGB stored under alpha = 0 and recorded in the JSON (1) */
  mgs_scene_init init;     /* initial point cloud written as points3d.ply (SURFACE) */
  size_t init_points;      /* 0 = default (surface 10000, random 100000) */
  double init_noise;       /* surface init: noise sigma as a fraction of the extent 2 (0.01) */
  uint64_t seed;           /* cameras jitter, init points, sub-pixel jitter (0) */
  int force;               /* replace an existing dataset at out_dir */
  int allow_open;          /* render meshes with boundary / non-manifold edges */
  const char *mesh_name;   /* named in error messages and scene.json (may be NULL) */
  int quiet;               /* no progress bar */
  int procedural_texture;  /* 1: the procedural texture even where the mesh has its own
                              texture or colours (a texture bad for SIFT, say) */
  int city_size;           /* > 0: the mesh is mgs_assets_city(city_size): kept in world
                              units (not normalized) and seen by the city's camera rig
                              (mgs_scene_city_cameras) instead of the sphere around it */
} mgs_scene_options;

void mgs_scene_options_default(mgs_scene_options *o);

/* Figures of one dataset build (for the benchmark). */
typedef struct mgs_scene_stats {
  size_t views;
  double rays;            /* primary rays cast */
  double render_seconds;  /* ray casting + shading only */
  double total_seconds;   /* everything, files included */
  size_t triangles;
  const char *appearance; /* "texture", "vertex colors" or "procedural" (static string) */
} mgs_scene_stats;

/* Renders the dataset of `mesh` (not modified: a normalized copy is used) into out_dir.
 * Appearance: the mesh's diffuse texture (mesh->texture read with mgs_texture_read, looked
 * up through mesh->uv) where it has one, else its vertex colours, else the procedural
 * texture; all procedural with o->procedural_texture. A texture that cannot be read
 * (missing, corrupt) is not an error: a warning names the mesh, the texture and why, and
 * the renders fall back (colours, else procedural); scene.json records the appearance used.
 * Errors (nothing left behind on any of them): empty mesh or non-finite vertices
 * (MGS_ERR_FORMAT); boundary or non-manifold edges unless allow_open (MGS_ERR_FORMAT);
 * out_dir holding a dataset without force, or holding anything that is not a dataset
 * (MGS_ERR_EXISTS). */
mgs_status mgs_scene_render_dataset(const mgs_mesh *mesh, const mgs_scene_options *o,
                                    const char *out_dir, mgs_error *err);
mgs_status mgs_scene_render_dataset_stats(const mgs_mesh *mesh, const mgs_scene_options *o,
                                          const char *out_dir, mgs_scene_stats *stats, mgs_error *err);

/* Checks a mesh is renderable under the options (empty, non-finite, open/non-manifold). */
mgs_status mgs_scene_check_mesh(const mgs_mesh *mesh, const mgs_scene_options *o, mgs_error *err);

/* The camera rig of one split (0 = train, 1 = test): n cameras of o's size and fov,
 * looking at the origin from distance `radius` (> 0). Train and test use different
 * spiral offsets, so no test view repeats a training view. */
void mgs_scene_make_cameras(const mgs_scene_options *o, int split, int n, double radius, mgs_camera *cams);
/* The city's rig (render/scene_city.c): n cameras of o's size and fov, half at street
 * level, half low aerial, each seeing a few units of the city of size o->city_size. */
void mgs_scene_city_cameras(const mgs_scene_options *o, int split, int n, mgs_camera *cams);
/* The camera distance used for a mesh whose vertices lie within `bound_radius` of the
 * origin: o->radius if set, else the distance at which that sphere fits the view. */
double mgs_scene_camera_radius(const mgs_scene_options *o, double bound_radius);

/* The renderer: an Embree scene of one (already normalized) mesh. */
typedef struct mgs_scene_renderer mgs_scene_renderer;
mgs_status mgs_scene_renderer_create(const mgs_mesh *mesh, mgs_scene_renderer **out, mgs_error *err);
void mgs_scene_renderer_destroy(mgs_scene_renderer *r);
/* Shade with the mesh's appearance (the same mesh, or one with the same triangles): its
 * per-corner UVs with `tex` (borrowed: kept alive by the caller while rendering; NULL: no
 * texture), its colours. A NULL mesh, or none of these, gives the procedural texture (the
 * default). Errors: out of memory. */
mgs_status mgs_scene_renderer_set_appearance(mgs_scene_renderer *r, const mgs_mesh *mesh, const mgs_texture *tex, mgs_error *err);
/* Renders one view into rgba (cam->width x cam->height, 4 channels, straight alpha).
 * `view_index` only seeds the sub-pixel jitter. Returns the number of rays cast. */
double mgs_scene_render_view(const mgs_scene_renderer *r, const mgs_camera *cam, const mgs_scene_options *o,
                             uint32_t view_index, mgs_image *rgba);
/* n_views RGBA pictures (size x size, straight alpha) of a mesh in a scene's world frame,
 * seen from the test rig's cameras around the origin (mgs_scene_make_cameras, split 1),
 * with the dataset's shading; open meshes are allowed. views[] is filled (caller destroys
 * each) or, on an error, left all NULL. Errors: bad counts/size (MGS_ERR_ARG), an empty or
 * non-finite mesh (MGS_ERR_FORMAT), Embree or memory failures. */
mgs_status mgs_scene_render_mesh_views(const mgs_mesh *mesh, int n_views, int size, mgs_image **views, mgs_error *err);
/* First hit of a ray (t in (tnear, tfar)); returns 1 and the distance on a hit. */
int mgs_scene_trace(const mgs_scene_renderer *r, const double org[3], const double dir[3], double tnear, double *t_hit);

/* Shading, exposed for the init point colours and the tests. Albedo of the procedural
 * texture at a world position (components in [0.05, 0.95]). */
void mgs_scene_albedo(const float p[3], float rgb[3]);

#ifdef __cplusplus
}
#endif
#endif
