/* Pinhole cameras in the OpenCV convention; OpenGL (Blender/NeRF) conversions. */
#include <math.h>
#include <string.h>
#include "core/mgs_camera.h"
#include "core/mgs_math.h"

static void set_identity(double M[16]) {
  memset(M, 0, 16 * sizeof(double));
  M[0] = M[5] = M[10] = M[15] = 1.0;
}

void mgs_camera_init(mgs_camera *cam, int width, int height, double fx, double fy, double cx, double cy) {
  memset(cam, 0, sizeof *cam);
  cam->width = width; cam->height = height;
  cam->fx = fx; cam->fy = fy; cam->cx = cx; cam->cy = cy;
  cam->znear = 0.01; cam->zfar = 1e10;
  set_identity(cam->w2c);
  set_identity(cam->c2w);
}

void mgs_camera_init_fovx(mgs_camera *cam, int width, int height, double fovx) {
  double f = 0.5 * width / tan(0.5 * fovx);
  mgs_camera_init(cam, width, height, f, f, 0.5 * width, 0.5 * height);
}

void mgs_camera_set_c2w_opencv(mgs_camera *cam, const double c2w[16]) {
  memcpy(cam->c2w, c2w, sizeof cam->c2w);
  mgs_mat4_rigid_inverse(c2w, cam->w2c);
}

void mgs_camera_set_w2c_opencv(mgs_camera *cam, const double w2c[16]) {
  memcpy(cam->w2c, w2c, sizeof cam->w2c);
  mgs_mat4_rigid_inverse(w2c, cam->c2w);
}

/* OpenGL -> OpenCV camera axes: flip y and z (the reference's c2w[:3, 1:3] *= -1). */
void mgs_camera_set_c2w_opengl(mgs_camera *cam, const double gl[16]) {
  double cv[16];
  memcpy(cv, gl, sizeof cv);
  for (int r = 0; r < 3; r++) { cv[4*r+1] = -cv[4*r+1]; cv[4*r+2] = -cv[4*r+2]; }
  mgs_camera_set_c2w_opencv(cam, cv);
}

void mgs_camera_get_c2w_opengl(const mgs_camera *cam, double gl[16]) {
  memcpy(gl, cam->c2w, 16 * sizeof(double));
  for (int r = 0; r < 3; r++) { gl[4*r+1] = -gl[4*r+1]; gl[4*r+2] = -gl[4*r+2]; }
}

void mgs_camera_center(const mgs_camera *cam, double c[3]) {
  c[0] = cam->c2w[3]; c[1] = cam->c2w[7]; c[2] = cam->c2w[11];
}

void mgs_camera_world_to_cam(const mgs_camera *cam, const double p[3], double pc[3]) {
  const double *M = cam->w2c;
  for (int r = 0; r < 3; r++) pc[r] = M[4*r]*p[0] + M[4*r+1]*p[1] + M[4*r+2]*p[2] + M[4*r+3];
}

int mgs_camera_project(const mgs_camera *cam, const double p[3], double *u, double *v, double *depth) {
  double pc[3];
  mgs_camera_world_to_cam(cam, p, pc);
  if (depth) *depth = pc[2];
  if (!(pc[2] > cam->znear)) return 0;
  *u = cam->fx * pc[0] / pc[2] + cam->cx;
  *v = cam->fy * pc[1] / pc[2] + cam->cy;
  return 1;
}

void mgs_camera_ray(const mgs_camera *cam, double u, double v, double origin[3], double dir[3]) {
  double d[3] = {(u - cam->cx) / cam->fx, (v - cam->cy) / cam->fy, 1.0};
  const double *M = cam->c2w;
  for (int r = 0; r < 3; r++) dir[r] = M[4*r]*d[0] + M[4*r+1]*d[1] + M[4*r+2]*d[2];
  mgs_normalize3d(dir);
  mgs_camera_center(cam, origin);
}

void mgs_camera_downscale(mgs_camera *cam, int factor) {
  if (factor <= 1) return;
  cam->width /= factor; cam->height /= factor;
  cam->fx /= factor; cam->fy /= factor; cam->cx /= factor; cam->cy /= factor;
}

void mgs_camera_resize(mgs_camera *cam, int w, int h) {
  if (w < 1 || h < 1 || (w == cam->width && h == cam->height)) return;
  double sx = (double)w / cam->width, sy = (double)h / cam->height;
  cam->fx *= sx; cam->cx *= sx;
  cam->fy *= sy; cam->cy *= sy;
  cam->width = w; cam->height = h;
}

int mgs_camera_focal_valid(double f, int size) {
  return size >= 1 && isfinite(f) && f >= 4e-4 * size && f <= 6e5 * size;
}

double mgs_camera_fovx(const mgs_camera *cam) { return 2.0 * atan(0.5 * cam->width / cam->fx); }
double mgs_camera_fovy(const mgs_camera *cam) { return 2.0 * atan(0.5 * cam->height / cam->fy); }

void mgs_camera_look_at(mgs_camera *cam, const double eye[3], const double target[3], const double up[3]) {
  /* OpenCV axes: z forward, x right, y down. */
  double z[3], x[3], y[3];
  mgs_sub3d(target, eye, z);
  mgs_normalize3d(z);
  double down[3] = {-up[0], -up[1], -up[2]};
  mgs_cross3d(down, z, x);       /* x = down × z ... right-handed: x = y × z with y = down */
  if (mgs_normalize3d(x) < 1e-12) { /* up parallel to the view direction: pick any side */
    double alt[3] = {1, 0, 0};
    if (fabs(z[0]) > 0.9) { alt[0] = 0; alt[1] = 1; }
    mgs_cross3d(alt, z, x);
    mgs_normalize3d(x);
  }
  mgs_cross3d(z, x, y);
  double c2w[16] = {x[0], y[0], z[0], eye[0],
                    x[1], y[1], z[1], eye[1],
                    x[2], y[2], z[2], eye[2],
                    0, 0, 0, 1};
  mgs_camera_set_c2w_opencv(cam, c2w);
}
