/* Multi-view datasets: NeRF-synthetic (transforms_{train,val,test}.json), nerfstudio
 * (transforms.json) and COLMAP (sparse/0/{cameras,images,points3D}.{bin,txt} + images/),
 * detected from the folder's content. Every loader fills the same structure, with
 * cameras in the internal OpenCV convention (core/mgs_camera.h), so the rest of the
 * system never sees the format. */
#ifndef MGS_DATASET_H
#define MGS_DATASET_H
#include <stddef.h>
#include "core/mgs_error.h"
#include "core/mgs_camera.h"
#include "core/mgs_image.h"
#include "core/mgs_ply.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { MGS_DATASET_AUTO = 0, MGS_DATASET_NERF_SYNTHETIC, MGS_DATASET_NERFSTUDIO, MGS_DATASET_COLMAP } mgs_dataset_format;
typedef enum { MGS_SPLIT_TRAIN = 0, MGS_SPLIT_VAL, MGS_SPLIT_TEST, MGS_SPLIT_COUNT } mgs_split;

typedef struct mgs_view {
  char *name;        /* file stem, e.g. "r_0" */
  char *image_path;  /* absolute or relative to the working directory */
  mgs_camera cam;    /* intrinsics already scaled by the downscale factor */
  mgs_image *image;  /* RGB composited on the background, downscaled; NULL until loaded */
  mgs_image *alpha;  /* 1-channel alpha when the file had one (else NULL) */
  int full_width, full_height; /* the image file's size before downscaling */
} mgs_view;

typedef struct mgs_dataset_options {
  mgs_dataset_format format; /* AUTO detects */
  int downscale;             /* integer factor >= 1: images round(w/f) x round(h/f) (the
                                reference's --resolution 1|2|4|8); 1 = full size */
  int max_width;             /* 1600: with downscale 1, wider images are resized to this
                                width (the reference's cap when no resolution is given);
                                0 = never. Resampling is PIL's bicubic either way. */
  int white_background;      /* 1 white, 0 black, -1 by format (default): white for
                                NeRF-synthetic, black otherwise, as the reference's -w use */
  int load_images;           /* 1: read all images now, in parallel (and check their sizes);
                                0: only check that each image file exists */
  int test_every;            /* COLMAP / nerfstudio without splits: every Nth view is test (8) */
  const char *images;        /* COLMAP, nerfstudio: the image folder under the root (NULL or "" =
                                images/; the reference's -i; nerfstudio: each frame's file name
                                in it). Another folder (Mip-NeRF 360's images_4)
                                may hold smaller images: each camera is scaled to its image's
                                size (same aspect ratio within a pixel, else an error) */
} mgs_dataset_options;

typedef struct mgs_dataset {
  mgs_dataset_format format;
  char *root;
  mgs_view *views[MGS_SPLIT_COUNT];
  size_t n_views[MGS_SPLIT_COUNT];
  mgs_point_cloud *init_points; /* COLMAP points3D, nerfstudio ply_file_path, or points3d.ply
                                   beside a NeRF-synthetic dataset; NULL if none */
  char *mesh_path;              /* ground-truth mesh if the dataset has one (gt_mesh.ply) */
  float background[3];
  int white_background;         /* the background chosen (1 white, 0 black) */
  int downscale;                /* factor applied to cameras and images */
  int max_width;                /* the cap applied (0: none) */
  /* Scene normalization of the reference: centre of the camera centres and the radius
     (1.1 x the largest distance to it) used for learning rates and densification. */
  double center[3];
  double extent;
  /* The scene origin (core/mgs_origin.h): cameras, points and `center` above are relative
     to it (shifted in double before anything became float); world = origin + local.
     (0,0,0) for a centred scene. Chosen from the files alone, so every load of the same
     folder (a resumed run, each MPI rank, render/eval) gets the same one: the centre of
     the initial points' robust box, else the training cameras' look-at point
     (mgs_dataset_look_at), against the cameras' extent. */
  double origin[3];
} mgs_dataset;

void mgs_dataset_options_default(mgs_dataset_options *o);
mgs_status mgs_dataset_load(const char *dir, const mgs_dataset_options *o, mgs_dataset **out, mgs_error *err);
/* The training size of an image of full_w x full_h (see downscale and max_width). */
void mgs_dataset_image_size(int full_w, int full_h, int downscale, int max_width, int *w, int *h);
/* Loads one view's image if not yet loaded (checks its size against the camera, naming
 * the image on mismatch). Safe to call concurrently for different views. */
mgs_status mgs_dataset_load_image(mgs_dataset *d, mgs_view *v, mgs_error *err);
void mgs_dataset_destroy(mgs_dataset *d);
/* Where the training cameras look, in the dataset's frame: the point nearest (least
 * squares) to all their optical axes. Returns 0 and the cameras' centre (`center`) when
 * the axes are near parallel or the point lies behind most of the cameras. */
int mgs_dataset_look_at(const mgs_dataset *d, double p[3]);
const char *mgs_split_name(mgs_split s); /* "train", "val", "test" */

#ifdef __cplusplus
}
#endif
#endif
