/* Pinhole cameras. The internal convention is OpenCV/COLMAP (x right, y down, camera
 * looks down +z), as in the reference 3DGS; NeRF-synthetic / nerfstudio / Blender
 * matrices (OpenGL: y up, looking down -z) are converted on load. Extrinsics are held in
 * double so that scenes far from the origin (1e5) keep sub-millimetre precision.
 * Pixel centres are at integer + 0.5: pixel (0,0) covers [0,1)x[0,1). */
#ifndef MGS_CAMERA_H
#define MGS_CAMERA_H
#include "core/mgs_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct mgs_camera {
  int width, height;
  double fx, fy, cx, cy; /* pixels */
  double w2c[16];        /* world -> camera (OpenCV), row-major rigid transform */
  double c2w[16];        /* its inverse */
  double znear, zfar;    /* clip range for rendering (default 0.01, 1e10) */
} mgs_camera;

/* Sets intrinsics; extrinsics to identity. */
void mgs_camera_init(mgs_camera *cam, int width, int height, double fx, double fy, double cx, double cy);
/* From a fov along x (radians), principal point at the image centre. */
void mgs_camera_init_fovx(mgs_camera *cam, int width, int height, double fovx);
/* Set pose from a camera-to-world matrix (row-major 4x4) in OpenCV or OpenGL convention. */
void mgs_camera_set_c2w_opencv(mgs_camera *cam, const double c2w[16]);
void mgs_camera_set_c2w_opengl(mgs_camera *cam, const double c2w_gl[16]);
void mgs_camera_set_w2c_opencv(mgs_camera *cam, const double w2c[16]);
/* The OpenGL camera-to-world matrix (for transforms.json). */
void mgs_camera_get_c2w_opengl(const mgs_camera *cam, double c2w_gl[16]);
/* Camera centre in world coordinates. */
void mgs_camera_center(const mgs_camera *cam, double c[3]);
/* World point -> camera space (OpenCV). */
void mgs_camera_world_to_cam(const mgs_camera *cam, const double p[3], double pc[3]);
/* World point -> pixel (u right, v down, continuous, pixel centres at +0.5). Returns 1 if
 * the point is in front of the camera (z > znear), 0 otherwise (u, v then undefined). */
int mgs_camera_project(const mgs_camera *cam, const double p[3], double *u, double *v, double *depth);
/* Unit world-space direction of the ray through continuous pixel (u, v). */
void mgs_camera_ray(const mgs_camera *cam, double u, double v, double origin[3], double dir[3]);
/* Scale intrinsics for an image downscaled by an integer factor. */
void mgs_camera_downscale(mgs_camera *cam, int factor);
/* Intrinsics for the image resized to w x h with its whole extent kept (fields of view
 * and the principal point's relative position exact, whatever the ratio). */
void mgs_camera_resize(mgs_camera *cam, int w, int h);
/* A pinhole focal length in pixels that every later stage can use for an image side of
 * `size` pixels: finite, a field of view between ~1e-4 and ~179.95 degrees (a file's
 * 1e-300 would pass "> 0" and become 0 in a resize). */
int mgs_camera_focal_valid(double f, int size);
double mgs_camera_fovx(const mgs_camera *cam);
double mgs_camera_fovy(const mgs_camera *cam);
/* Look-at pose: camera at eye looking at target with world up vector. */
void mgs_camera_look_at(mgs_camera *cam, const double eye[3], const double target[3], const double up[3]);
/* RUN/cameras.json of the reference 3DGS layout (core/camera_json.c): *out malloc'd
 * (free()), in file order; names (may be NULL): the img_name of each, malloc'd strings in
 * a malloc'd array. Errors name the file and the camera. */
mgs_status mgs_cameras_read_json(const char *path, mgs_camera **out, char ***names, size_t *n, mgs_error *err);

#ifdef __cplusplus
}
#endif
#endif
