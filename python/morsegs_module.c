/* morsegs._morsegs: the C half of `import morsegs` (python/morsegs/__init__.py is the other).
 * Thin and strict: every entry takes arrays of one exact dtype and layout (the Python half
 * converts and validates user input, GUDHI-style) and returns plain numpy arrays; the
 * persistence engine, the .vdb reader and the diagram distances are the library's
 * (topo/, vdb/). The GIL is released around every library call; a library error becomes
 * a Python exception carrying the library's message. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <limits.h>
#include <math.h>
#include <string.h>
#include "core/mgs_parallel.h"
#include "topo/mgs_diagram_tools.h"
#include "topo/mgs_levelset_check.h"
#include "topo/mgs_persistence.h"
#include "vdb/mgs_vdb.h"

/* ---------------------------------------------------------------- errors */

static PyObject *raise_status(mgs_status st, const mgs_error *err) {
  PyObject *type;
  switch (st) {
    case MGS_ERR_IO: type = PyExc_OSError; break;
    case MGS_ERR_NOMEM: type = PyExc_MemoryError; break;
    case MGS_ERR_EXISTS: type = PyExc_FileExistsError; break;
    case MGS_ERR_INTERRUPTED: type = PyExc_KeyboardInterrupt; break;
    case MGS_ERR_ARG:
    case MGS_ERR_FORMAT:
    case MGS_ERR_NUMERIC:
    case MGS_ERR_UNSUPPORTED: type = PyExc_ValueError; break;
    default: type = PyExc_RuntimeError; break;
  }
  PyErr_SetString(type, err && err->msg[0] ? err->msg : mgs_status_name(st));
  return NULL;
}

/* An argument that must already be a numpy array of one dtype, C-contiguous, given rank;
 * the Python half guarantees it, so a mismatch is a TypeError, never a silent copy. */
static PyArrayObject *want_array(PyObject *o, const char *what, int type, int ndim, npy_intp cols) {
  if (!PyArray_Check(o)) {
    PyErr_Format(PyExc_TypeError, "%s: expected a numpy array", what);
    return NULL;
  }
  PyArrayObject *a = (PyArrayObject *)o;
  if (PyArray_TYPE(a) != type || PyArray_NDIM(a) != ndim || !PyArray_IS_C_CONTIGUOUS(a) || !PyArray_ISALIGNED(a)) {
    PyErr_Format(PyExc_TypeError, "%s: expected a C-contiguous %d-dimensional array of %s", what, ndim,
                 type == NPY_FLOAT32 ? "float32" : type == NPY_FLOAT64 ? "float64" : type == NPY_INT64 ? "int64" : "uint8");
    return NULL;
  }
  if (cols >= 0 && PyArray_DIM(a, 1) != cols) {
    PyErr_Format(PyExc_TypeError, "%s: expected %zd columns", what, (Py_ssize_t)cols);
    return NULL;
  }
  return a;
}

/* ---------------------------------------------------------------- diagram -> arrays */

static int dict_put(PyObject *d, const char *k, PyObject *v) {
  if (!v) return -1;
  int r = PyDict_SetItemString(d, k, v);
  Py_DECREF(v);
  return r;
}

static PyObject *stats_dict(const mgs_topo_stats *s) {
  return Py_BuildValue("{s:n,s:n,s:n,s:n,s:n,s:n,s:n,s:d,s:n,s:d,s:d,s:d,s:d,s:d,s:n}",
                       "active_voxels", (Py_ssize_t)s->active_voxels, "leaves", (Py_ssize_t)s->leaves, "tiles",
                       (Py_ssize_t)s->tiles, "cells_total", (Py_ssize_t)s->cells_total, "band_cells",
                       (Py_ssize_t)s->band_cells, "critical_cells", (Py_ssize_t)s->critical_cells, "truncated",
                       (Py_ssize_t)s->truncated, "reduction_ratio", s->reduction_ratio, "persistent_cells",
                       (Py_ssize_t)s->persistent_cells, "effective_w", s->effective_w, "seconds_build",
                       s->seconds_build, "seconds_morse", s->seconds_morse, "seconds_pairs", s->seconds_pairs,
                       "seconds", s->seconds, "peak_bytes", (Py_ssize_t)s->peak_bytes);
}

/* dim (n,) int64, birth_death (n,2) float64, voxels (n,6) int64 (birth xyz, death xyz),
 * positions (n,6) float64 (world centres of the two critical cells), truncated (n,) uint8.
 * The death end of an essential class has no cell: voxel -1, position NaN. */
static PyObject *diagram_dict(const mgs_diagram *d, const mgs_topo_stats *s) {
  npy_intp n = (npy_intp)d->n, s2[2] = {n, 2}, s6[2] = {n, 6};
  PyObject *out = PyDict_New();
  if (!out) return NULL;
  PyArrayObject *dim = (PyArrayObject *)PyArray_SimpleNew(1, &n, NPY_INT64);
  PyArrayObject *bd = (PyArrayObject *)PyArray_SimpleNew(2, s2, NPY_FLOAT64);
  PyArrayObject *vox = (PyArrayObject *)PyArray_SimpleNew(2, s6, NPY_INT64);
  PyArrayObject *pos = (PyArrayObject *)PyArray_SimpleNew(2, s6, NPY_FLOAT64);
  PyArrayObject *tr = (PyArrayObject *)PyArray_SimpleNew(1, &n, NPY_UINT8);
  if (!dim || !bd || !vox || !pos || !tr) goto fail;
  int64_t *pd = PyArray_DATA(dim), *pv = PyArray_DATA(vox);
  double *pb = PyArray_DATA(bd), *pp = PyArray_DATA(pos);
  uint8_t *pt = PyArray_DATA(tr);
  for (size_t i = 0; i < d->n; i++) {
    const mgs_pair *q = &d->pairs[i];
    int ess = isinf(q->death);
    pd[i] = q->dim;
    pb[2 * i] = q->birth;
    pb[2 * i + 1] = q->death;
    for (int k = 0; k < 3; k++) {
      pv[6 * i + k] = q->b.voxel[k];
      pv[6 * i + 3 + k] = ess ? -1 : q->d.voxel[k];
      pp[6 * i + k] = q->b.pos[k];
      pp[6 * i + 3 + k] = ess ? NAN : q->d.pos[k];
    }
    pt[i] = (uint8_t)(q->truncated != 0);
  }
  if (dict_put(out, "dim", (PyObject *)dim) || dict_put(out, "birth_death", (PyObject *)bd) ||
      dict_put(out, "voxels", (PyObject *)vox) || dict_put(out, "positions", (PyObject *)pos) ||
      dict_put(out, "truncated", (PyObject *)tr) || dict_put(out, "stats", stats_dict(s))) {
    Py_DECREF(out);
    return NULL;
  }
  return out;
fail:
  Py_XDECREF(dim);
  Py_XDECREF(bd);
  Py_XDECREF(vox);
  Py_XDECREF(pos);
  Py_XDECREF(tr);
  Py_DECREF(out);
  return NULL;
}

/* ---------------------------------------------------------------- dense */

static PyObject *py_dense(PyObject *self, PyObject *args, PyObject *kw) {
  static char *kwlist[] = {"values", "construction", NULL};
  PyObject *obj;
  int construction = 0;
  if (!PyArg_ParseTupleAndKeywords(args, kw, "O|i:dense_persistence", kwlist, &obj, &construction)) return NULL;
  PyArrayObject *a = want_array(obj, "dense_persistence: values", NPY_FLOAT32, 3, -1);
  if (!a) return NULL;
  if (construction != MGS_TOPO_V && construction != MGS_TOPO_T) {
    PyErr_Format(PyExc_ValueError, "dense_persistence: construction %d is not 0 (V) or 1 (T)", construction);
    return NULL;
  }
  int n[3];
  for (int k = 0; k < 3; k++) {
    npy_intp s = PyArray_DIM(a, k);
    if (s < 1 || s > INT_MAX) {
      PyErr_Format(PyExc_ValueError, "dense_persistence: axis %d has %zd voxels (need 1 .. %d)", k, (Py_ssize_t)s, INT_MAX);
      return NULL;
    }
    n[k] = (int)s;
  }
  mgs_topo_opts o;
  mgs_topo_opts_default(&o);
  o.construction = (mgs_topo_construction)construction;
  mgs_diagram *d = NULL;
  mgs_topo_stats stats;
  memset(&stats, 0, sizeof stats);
  mgs_error err;
  mgs_error_clear(&err);
  mgs_status st;
  const float *v = PyArray_DATA(a);
  Py_BEGIN_ALLOW_THREADS
  st = mgs_topo_persistence_dense_stats(v, n[0], n[1], n[2], &o, &d, &stats, &err);
  Py_END_ALLOW_THREADS
  if (st != MGS_OK) {
    mgs_diagram_destroy(d);
    return raise_status(st, &err);
  }
  PyObject *r = diagram_dict(d, &stats);
  mgs_diagram_destroy(d);
  return r;
}

/* ---------------------------------------------------------------- .vdb */

static const char *class_name(mgs_vdb_class c) {
  return c == MGS_VDB_CLASS_LEVEL_SET ? "level set" : c == MGS_VDB_CLASS_FOG ? "fog volume" : "unknown";
}

/* As `morsegs persistence IN.vdb` (apps/cmd_persistence.c): the same defaults, checks and
 * superlevel convention (fog: values negated back, birth >= death), so both give one diagram. */
static PyObject *py_vdb(PyObject *self, PyObject *args, PyObject *kw) {
  static char *kwlist[] = {"path", "grid", "construction", "filtration", "band", "check", NULL};
  const char *path, *grid = NULL;
  int construction = 0, filtration = -1, check = 1;
  double band = NAN;
  if (!PyArg_ParseTupleAndKeywords(args, kw, "s|ziidp:vdb_persistence", kwlist, &path, &grid, &construction,
                                   &filtration, &band, &check))
    return NULL;
  if (construction != MGS_TOPO_V && construction != MGS_TOPO_T) {
    PyErr_Format(PyExc_ValueError, "vdb_persistence: construction %d is not 0 (V) or 1 (T)", construction);
    return NULL;
  }
  if (filtration < -1 || filtration > 1) {
    PyErr_Format(PyExc_ValueError, "vdb_persistence: filtration %d is not -1 (auto), 0 (sublevel) or 1 (superlevel)", filtration);
    return NULL;
  }
  if (!isnan(band) && !(band > 0 && isfinite(band))) {
    PyErr_Format(PyExc_ValueError, "vdb_persistence: band %g must be a positive number of voxels", band);
    return NULL;
  }
  mgs_error err;
  mgs_error_clear(&err);
  mgs_status st;
  mgs_vdb_grid *g = NULL;
  mgs_diagram *d = NULL;
  mgs_topo_stats stats;
  memset(&stats, 0, sizeof stats);
  int superlevel = 0;
  Py_BEGIN_ALLOW_THREADS
  st = mgs_vdb_read_grid(path, grid, &g, &err);
  if (st == MGS_OK) {
    const char *gname = mgs_vdb_grid_name(g);
    mgs_vdb_class cls = mgs_vdb_grid_class(g);
    if (filtration < 0) filtration = cls == MGS_VDB_CLASS_FOG ? MGS_TOPO_SUPERLEVEL : MGS_TOPO_SUBLEVEL;
    superlevel = filtration == MGS_TOPO_SUPERLEVEL;
    if (cls == MGS_VDB_CLASS_LEVEL_SET && superlevel)
      st = mgs_error_set(&err, MGS_ERR_ARG, "%s: grid '%s' is a level set: its topology is that of the sublevel filtration", path, gname);
    else if (mgs_vdb_grid_active_voxel_count(g) == 0)
      st = mgs_error_set(&err, MGS_ERR_FORMAT, "%s: grid '%s' has no active voxels", path, gname);
    else if (cls == MGS_VDB_CLASS_LEVEL_SET && check)
      st = mgs_topo_check_level_set(g, path, &err);
  }
  if (st == MGS_OK) {
    mgs_topo_opts o;
    mgs_topo_opts_default(&o);
    o.construction = (mgs_topo_construction)construction;
    o.filtration = (mgs_topo_filtration)filtration;
    o.half_width = isnan(band) ? INFINITY : band * mgs_vdb_grid_voxel_size(g);
    st = mgs_topo_persistence_vdb_stats(g, &o, &d, &stats, &err);
    if (st != MGS_OK) { /* the engine's messages do not know the file */
      char msg[MGS_ERROR_MSG_MAX];
      snprintf(msg, sizeof msg, "%s", err.msg);
      mgs_error_set(&err, st, "%s: %s", path, msg);
    } else if (superlevel) /* the engine reports -f values: back to density units */
      for (size_t i = 0; i < d->n; i++) {
        d->pairs[i].birth = -d->pairs[i].birth;
        d->pairs[i].death = -d->pairs[i].death;
      }
  }
  Py_END_ALLOW_THREADS
  PyObject *r = NULL;
  if (st != MGS_OK) raise_status(st, &err);
  else if ((r = diagram_dict(d, &stats))) {
    double t[3];
    mgs_vdb_grid_translation(g, t);
    const char *gname = mgs_vdb_grid_name(g);
    PyObject *info = Py_BuildValue("{s:s,s:s,s:s,s:d,s:d,s:(ddd),s:n}", "grid", gname ? gname : "", "grid_class",
                                   class_name(mgs_vdb_grid_class(g)), "filtration", superlevel ? "superlevel" : "sublevel",
                                   "voxel_size", mgs_vdb_grid_voxel_size(g), "background",
                                   (double)mgs_vdb_grid_background(g), "translation", t[0], t[1], t[2], "active_voxels",
                                   (Py_ssize_t)mgs_vdb_grid_active_voxel_count(g));
    if (dict_put(r, "grid", info)) Py_CLEAR(r);
  }
  mgs_diagram_destroy(d);
  mgs_vdb_grid_destroy(g);
  return r;
}

/* ---------------------------------------------------------------- diagrams from arrays */

/* points: (n,2) float64 (birth, death), all of dimension 0. */
static mgs_status points_diagram(PyArrayObject *a, mgs_diagram **out, mgs_error *err) {
  *out = mgs_diagram_create();
  if (!*out) return mgs_error_set(err, MGS_ERR_NOMEM, "out of memory");
  const double *p = PyArray_DATA(a);
  npy_intp n = PyArray_DIM(a, 0);
  mgs_status st = MGS_OK;
  for (npy_intp i = 0; i < n && st == MGS_OK; i++) {
    mgs_pair q;
    memset(&q, 0, sizeof q);
    q.birth = p[2 * i];
    q.death = p[2 * i + 1];
    st = mgs_diagram_push(*out, &q, err);
  }
  return st;
}

static PyObject *py_distance(PyObject *self, PyObject *args, PyObject *kw) {
  static char *kwlist[] = {"a", "b", "order", "internal_p", NULL};
  PyObject *oa, *ob;
  double order = INFINITY, internal_p = INFINITY;
  if (!PyArg_ParseTupleAndKeywords(args, kw, "OO|dd:diagram_distance", kwlist, &oa, &ob, &order, &internal_p)) return NULL;
  PyArrayObject *a = want_array(oa, "diagram_distance: a", NPY_FLOAT64, 2, 2);
  PyArrayObject *b = a ? want_array(ob, "diagram_distance: b", NPY_FLOAT64, 2, 2) : NULL;
  if (!b) return NULL;
  mgs_error err;
  mgs_error_clear(&err);
  mgs_diagram *da = NULL, *db = NULL;
  double v = NAN, bound = 0.0;
  mgs_status st;
  Py_BEGIN_ALLOW_THREADS
  st = points_diagram(a, &da, &err);
  if (st == MGS_OK) st = points_diagram(b, &db, &err);
  if (st == MGS_OK) {
    if (isinf(order) && isinf(internal_p)) st = mgs_diagram_bottleneck(da, db, 0, &v, &err);
    else st = mgs_diagram_wasserstein(da, db, 0, order, internal_p, &v, &bound, &err);
  }
  Py_END_ALLOW_THREADS
  mgs_diagram_destroy(da);
  mgs_diagram_destroy(db);
  if (st != MGS_OK) return raise_status(st, &err);
  return Py_BuildValue("(dd)", v, bound);
}

/* write_diagram(path, dim, birth_death, voxels, positions, truncated, json, meta_json) */
static PyObject *py_write(PyObject *self, PyObject *args) {
  const char *path, *meta = NULL;
  PyObject *odim, *obd, *ovox, *opos, *otr;
  int json = 0;
  if (!PyArg_ParseTuple(args, "sOOOOOp|z:write_diagram", &path, &odim, &obd, &ovox, &opos, &otr, &json, &meta)) return NULL;
  PyArrayObject *dim = want_array(odim, "write_diagram: dim", NPY_INT64, 1, -1);
  PyArrayObject *bd = dim ? want_array(obd, "write_diagram: birth_death", NPY_FLOAT64, 2, 2) : NULL;
  PyArrayObject *vox = bd ? want_array(ovox, "write_diagram: voxels", NPY_INT64, 2, 6) : NULL;
  PyArrayObject *pos = vox ? want_array(opos, "write_diagram: positions", NPY_FLOAT64, 2, 6) : NULL;
  PyArrayObject *tr = pos ? want_array(otr, "write_diagram: truncated", NPY_UINT8, 1, -1) : NULL;
  if (!tr) return NULL;
  npy_intp n = PyArray_DIM(dim, 0);
  if (PyArray_DIM(bd, 0) != n || PyArray_DIM(vox, 0) != n || PyArray_DIM(pos, 0) != n || PyArray_DIM(tr, 0) != n) {
    PyErr_SetString(PyExc_ValueError, "write_diagram: arrays of different lengths");
    return NULL;
  }
  const int64_t *pd = PyArray_DATA(dim), *pv = PyArray_DATA(vox);
  const double *pb = PyArray_DATA(bd), *pp = PyArray_DATA(pos);
  const uint8_t *pt = PyArray_DATA(tr);
  mgs_error err;
  mgs_error_clear(&err);
  mgs_status st = MGS_OK;
  mgs_diagram *d = mgs_diagram_create();
  if (!d) return PyErr_NoMemory();
  for (npy_intp i = 0; i < n && st == MGS_OK; i++) {
    mgs_pair q;
    memset(&q, 0, sizeof q);
    q.dim = (int)pd[i];
    q.birth = pb[2 * i];
    q.death = pb[2 * i + 1];
    for (int k = 0; k < 3; k++) {
      q.b.voxel[k] = (int32_t)pv[6 * i + k];
      q.d.voxel[k] = (int32_t)pv[6 * i + 3 + k];
      q.b.pos[k] = pp[6 * i + k];
      q.d.pos[k] = pp[6 * i + 3 + k];
    }
    q.truncated = pt[i];
    st = mgs_diagram_push(d, &q, &err);
  }
  if (st == MGS_OK) {
    Py_BEGIN_ALLOW_THREADS
    st = json ? mgs_diagram_write_json(path, d, meta, &err) : mgs_diagram_write_text(path, d, &err);
    Py_END_ALLOW_THREADS
  }
  mgs_diagram_destroy(d);
  if (st != MGS_OK) return raise_status(st, &err);
  Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- threads */

static PyObject *py_set_threads(PyObject *self, PyObject *args) {
  int n;
  if (!PyArg_ParseTuple(args, "i:set_num_threads", &n)) return NULL;
  if (n < 0) {
    PyErr_Format(PyExc_ValueError, "set_num_threads: %d must be >= 0 (0 = all cores)", n);
    return NULL;
  }
  mgs_parallel_set_threads(n);
  Py_RETURN_NONE;
}

static PyObject *py_get_threads(PyObject *self, PyObject *noargs) {
  return PyLong_FromLong(mgs_parallel_max_threads());
}

static PyMethodDef methods[] = {
    {"dense_persistence", (PyCFunction)(void (*)(void))py_dense, METH_VARARGS | METH_KEYWORDS,
     "dense_persistence(values, construction=0) -> dict: the diagram of a C-contiguous float32 (nx, ny, nz) array "
     "(construction 0 = V, 1 = T), sublevel filtration, every pair of positive persistence."},
    {"vdb_persistence", (PyCFunction)(void (*)(void))py_vdb, METH_VARARGS | METH_KEYWORDS,
     "vdb_persistence(path, grid=None, construction=0, filtration=-1, band=nan, check=True) -> dict: as "
     "`morsegs persistence`."},
    {"diagram_distance", (PyCFunction)(void (*)(void))py_distance, METH_VARARGS | METH_KEYWORDS,
     "diagram_distance(a, b, order=inf, internal_p=inf) -> (distance, error_bound): bottleneck (order inf) or "
     "Wasserstein between two (n, 2) float64 arrays."},
    {"write_diagram", py_write, METH_VARARGS, "write_diagram(path, dim, birth_death, voxels, positions, truncated, json, meta=None)"},
    {"set_num_threads", py_set_threads, METH_VARARGS, "set_num_threads(n): worker threads of the library (0 = all cores)."},
    {"get_num_threads", py_get_threads, METH_NOARGS, "get_num_threads() -> int"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_morsegs",
                                    "C extension of morsegs (use the morsegs package, not this module).", -1, methods,
                                    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__morsegs(void) {
  import_array();
  return PyModule_Create(&module);
}
