// CGAL shim of train/mgs_poisson.h: Poisson reconstruction (CGAL's
// poisson_reconstruction_example.cpp pipeline) and Garland–Heckbert edge collapse.
#include "train/mgs_poisson.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/facets_in_complex_2_to_triangle_mesh.h>
#include <CGAL/Implicit_surface_3.h>
#include <CGAL/Poisson_reconstruction_function.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_default_triangulation_3.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/compute_average_spacing.h>
#include <CGAL/make_surface_mesh.h>

#include <array>
#include <cmath>
#include <exception>
#include <utility>
#include <vector>

namespace {
typedef CGAL::Exact_predicates_inexact_constructions_kernel Kernel;
typedef Kernel::FT FT;
typedef Kernel::Point_3 Point;
typedef Kernel::Vector_3 Vector;
typedef Kernel::Sphere_3 Sphere;
typedef std::pair<Point, Vector> Point_with_normal;
typedef CGAL::First_of_pair_property_map<Point_with_normal> Point_map;
typedef CGAL::Second_of_pair_property_map<Point_with_normal> Normal_map;
typedef CGAL::Poisson_reconstruction_function<Kernel> Poisson;
typedef CGAL::Surface_mesh_default_triangulation_3 STr;
typedef CGAL::Surface_mesh_complex_2_in_triangulation_3<STr> C2t3;
typedef CGAL::Implicit_surface_3<Kernel, Poisson> Surface_3;
typedef CGAL::Surface_mesh<Point> Mesh;

mgs_mesh *to_mgs(const Mesh &sm) {
  std::vector<size_t> index(sm.number_of_vertices() + sm.number_of_removed_vertices(), 0);
  mgs_mesh *m = mgs_mesh_create(sm.number_of_vertices(), sm.number_of_faces());
  if (!m) return nullptr;
  size_t k = 0;
  for (auto v : sm.vertices()) {
    const Point &p = sm.point(v);
    m->v[3 * k] = (float)p.x();
    m->v[3 * k + 1] = (float)p.y();
    m->v[3 * k + 2] = (float)p.z();
    index[(size_t)v] = k++;
  }
  size_t t = 0;
  for (auto f : sm.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      if (c < 3) m->t[3 * t + c] = (uint32_t)index[(size_t)v];
      c++;
    }
    if (c == 3) t++;
  }
  m->nt = t;
  return m;
}
}  // namespace

extern "C" void mgs_poisson_options_default(mgs_poisson_options *o) {
  o->angle = 20.0;
  o->radius = 3.0;
  o->distance = 0.375;
}

extern "C" mgs_status mgs_poisson_reconstruct(const double *p, const double *n, size_t m, const mgs_poisson_options *o,
                                              mgs_mesh **out, mgs_error *err) {
  *out = nullptr;
  if (m < 16) return mgs_error_set(err, MGS_ERR_NUMERIC, "poisson: %zu oriented points are too few to reconstruct from", m);
  try {
    std::vector<Point_with_normal> pts;
    pts.reserve(m);
    for (size_t i = 0; i < m; i++)
      pts.emplace_back(Point(p[3 * i], p[3 * i + 1], p[3 * i + 2]), Vector(n[3 * i], n[3 * i + 1], n[3 * i + 2]));
    Poisson function(pts.begin(), pts.end(), Point_map(), Normal_map());
    if (!function.compute_implicit_function())
      return mgs_error_set(err, MGS_ERR_NUMERIC, "poisson: CGAL's solver failed on %zu points", m);
    FT spacing = CGAL::compute_average_spacing<CGAL::Sequential_tag>(pts, 6, CGAL::parameters::point_map(Point_map()));
    Point inner = function.get_inner_point();
    Sphere bsphere = function.bounding_sphere();
    FT radius = std::sqrt(bsphere.squared_radius());
    FT sphere_radius = 5.0 * radius;
    FT dichotomy = o->distance * spacing / 1000.0;
    Surface_3 surface(function, Sphere(inner, sphere_radius * sphere_radius), dichotomy / sphere_radius);
    CGAL::Surface_mesh_default_criteria_3<STr> criteria(o->angle, o->radius * spacing, o->distance * spacing);
    STr tr;
    /* Seeds: the mesher finds a component only where a Voronoi edge of its triangulation
       crosses it, and its own initial points are shot from the function's inner point, so
       it can stop at the first small closed piece it meets (measured on the thin built-in
       scene: a 92-triangle blob out of 53k points). Up to 2000 input points (evenly
       strided; they lie on the surface within the reconstruction's error) seed every part. */
    const size_t stride = m > 2000 ? m / 2000 : 1;
    for (size_t i = 0; i < m; i += stride) tr.insert(pts[i].first);
    C2t3 c2t3(tr);
    CGAL::make_surface_mesh(c2t3, surface, criteria, CGAL::Manifold_with_boundary_tag());
    if (tr.number_of_vertices() == 0)
      return mgs_error_set(err, MGS_ERR_NUMERIC, "poisson: the surface mesher found no surface (%zu points)", m);
    Mesh sm;
    CGAL::facets_in_complex_2_to_triangle_mesh(c2t3, sm);
    *out = to_mgs(sm);
    if (!*out) return mgs_error_set(err, MGS_ERR_NOMEM, "poisson: out of memory");
    return MGS_OK;
  } catch (const std::bad_alloc &) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "poisson: out of memory (%zu points)", m);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NUMERIC, "poisson: CGAL: %s", e.what());
  }
}

extern "C" mgs_status mgs_mesh_decimate(mgs_mesh **mm, size_t max_triangles, int *decimated, mgs_error *err) {
  *decimated = 0;
  mgs_mesh *m = *mm;
  if (!m || m->nt <= max_triangles) return MGS_OK;
  namespace PMP = CGAL::Polygon_mesh_processing;
  namespace SMS = CGAL::Surface_mesh_simplification;
  try {
    std::vector<Point> pts;
    std::vector<std::array<size_t, 3>> faces;
    pts.reserve(m->nv);
    for (size_t i = 0; i < m->nv; i++) pts.emplace_back(m->v[3 * i], m->v[3 * i + 1], m->v[3 * i + 2]);
    for (size_t t = 0; t < m->nt; t++) faces.push_back({m->t[3 * t], m->t[3 * t + 1], m->t[3 * t + 2]});
    PMP::repair_polygon_soup(pts, faces);
    PMP::orient_polygon_soup(pts, faces);
    if (!PMP::is_polygon_soup_a_polygon_mesh(faces)) return MGS_OK;
    Mesh sm;
    PMP::polygon_soup_to_polygon_mesh(pts, faces, sm);
    SMS::Count_stop_predicate<Mesh> stop(max_triangles * 3 / 2); /* counts edges: 3/2 per triangle */
    typedef SMS::GarlandHeckbert_plane_policies<Mesh, Kernel> GH;
    GH gh(sm);
    SMS::edge_collapse(sm, stop, CGAL::parameters::get_cost(gh.get_cost()).get_placement(gh.get_placement()));
    sm.collect_garbage();
    mgs_mesh *r = to_mgs(sm);
    if (!r) return mgs_error_set(err, MGS_ERR_NOMEM, "decimate: out of memory");
    mgs_mesh_destroy(m);
    *mm = r;
    *decimated = 1;
    return MGS_OK;
  } catch (const std::bad_alloc &) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "decimate: out of memory (%zu triangles)", m->nt);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NUMERIC, "decimate: CGAL: %s", e.what());
  }
}
