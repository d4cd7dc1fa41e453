// The SDF of S_α = {A = τ} as an OpenVDB narrow-band level set, and the density fog grid.
//
// Three constructions (mgs_vdb_sdf_method), all measured (tests/vdb/test_vdb_field prints the
// errors; bench/RESULTS-vdb.md has the timings). Max band error in voxels against the exact
// distance: sphere (one isotropic Gaussian, R = 4.3 voxels) / ellipsoid (anisotropic,
// curvature radius down to ~2 voxels) / two merged Gaussians; CPU s for α-field + SDF of
// 1M Gaussians at 512³ (torus, bench vdb):
//   CLOSEST (default) 0.016 / 0.041 / 0.004;  ~8 CPU s in a run where OpenVDB's own
//         ParticlesToLevelSet took 8.6 (its quiet-machine wall time: 2.4 s)
//   MESH              0.076 / 0.18  / 0.07;   37 CPU s (19 s wall on a quiet machine)
//   SWEEP             0.44  / -     / -;      6.5 CPU s (3.4 s wall on a quiet machine)
// CLOSEST: voxels with a 6-neighbour across the discrete interface (seeds) get the closest
//         point of {A = τ} by Chopp's iteration on the α-field's triquadratic interpolant;
//         each further ring of the band (26-neighbour dilation, w rings) takes the nearest of
//         its neighbours' closest points and refines it the same way; a relaxation pass then
//         repairs every voxel whose distance exceeds a neighbour's by more than their
//         spacing, and each seed also keeps the edge crossing it shares with its neighbour
//         across the interface, so the band is a distance field between EVERY pair of
//         neighbours (|d_i - d_j| <= h), on trained models too (floaters, interior
//         Gaussians, ragged sheets: tests/vdb/test_vdb_band). Distances are to the surface
//         itself, not to a polygonization (MESH) or a first-order upwind solution (SWEEP),
//         and it is linear in the band voxels with no mesh in between.
//   MESH: volumeToMesh(A, τ) -> meshToLevelSet; vertices projected onto {A = τ} and quads
//         split around a projected centre (mesh_refine). meshToLevelSet decides the sign by
//         flood fill from outside, so a hollow shell's cavity (A = 0) comes out *inside*
//         (tests/vdb/test_vdb_field, hollow shell), as does the inner side of a trained
//         surface's shell: kept for comparison only.
//   SWEEP: fogToSdf (first-order Godunov fast sweeping) on the α-field dilated by the band,
//         trimmed to ±w·h: seeds from linear interpolation of the steep α ramp, hence 0.44.
// CLOSEST is the default: the only one within the 0.1-voxel contract on all three shapes,
// signs follow A everywhere, and it costs about what OpenVDB's own P2LS costs.
// All give: negative inside {A > τ}, world units, band of half-width w voxels,
// background w·h, interior filled with inactive -w·h tiles.
#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/FastSweeping.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/ValueTransformer.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <algorithm>
#include <atomic>
#include <mutex>
#include <cstring>
#include <cmath>
#include <limits>
#include <vector>
#include "core/mgs_log.h"
#include "vdb/vdb_internal.hpp"

using namespace openvdb;

namespace {

FloatGrid::Ptr empty_level_set(const FloatGrid &like, float bg) {
  auto g = FloatGrid::create(bg);
  g->setTransform(like.transform().copy());
  return g;
}

// Voxels with |d| beyond the band become inactive ±bg.
void clamp_band(FloatTree &t, float bg) {
  for (auto it = t.beginValueOn(); it; ++it) {
    const float d = *it;
    if (d >= bg) it.setValueOff(), it.setValue(bg);
    else if (d <= -bg) it.setValueOff(), it.setValue(-bg);
  }
}

// Clamp |d| to the band: voxels beyond it become inactive ±bg; background bg; tiles pruned.
void trim_band(FloatGrid &g, float bg) {
  clamp_band(g.tree(), bg);
  tools::changeLevelSetBackground(g.tree(), bg);
  tools::pruneLevelSet(g.tree());
}

// volumeToMesh places one vertex per cell (the mean of its edge crossings), which sits
// inside a curved surface by up to ~0.1 voxel. Two Newton steps on the triquadratic
// interpolant of the α-field (trilinear would bias it inward by ~0.05 voxel: ∇²A < 0 there),
// each at most half a voxel, move every vertex onto {A = τ} itself.
void project_vertices(const FloatGrid &alpha, float tau, std::vector<Vec3s> &pts) {
  const math::Transform &xf = alpha.transform();
  const double h = alpha.voxelSize()[0];
  mgs_vdb_detail::parallel_for(0, pts.size(), 4096, [&](size_t b, size_t e) {
    auto acc = alpha.getConstAccessor();
    tools::GridSampler<FloatGrid::ConstAccessor, tools::QuadraticSampler> s(acc, xf);
    for (size_t i = b; i < e; i++) {
      Vec3d p = pts[i], p0 = pts[i];
      for (int it = 0; it < 2; it++) {
        const double v = s.wsSample(p) - tau;
        Vec3d g;
        for (int a = 0; a < 3; a++) {
          Vec3d q1 = p, q0 = p;
          q1[a] += 0.5 * h;
          q0[a] -= 0.5 * h;
          g[a] = (s.wsSample(q1) - s.wsSample(q0)) / h;
        }
        const double g2 = g.lengthSqr();
        if (!(g2 > 0) || !std::isfinite(g2)) break;
        Vec3d step = -v * g / g2;
        const double len = step.length();
        if (len > 0.5 * h) step *= 0.5 * h / len;
        p += step;
      }
      if ((p - p0).length() <= h) pts[i] = Vec3s(p);
    }
  });
}

FloatGrid::Ptr sdf_mesh(const FloatGrid &alpha_in, float tau, int w, int refine) {
  // Mesh in the grid's own frame without its translation: float vertex positions keep
  // sub-voxel precision even for scenes far from the origin. The tree is shared, not copied.
  FloatGrid::Ptr local = FloatGrid::create(std::const_pointer_cast<FloatTree>(alpha_in.constTreePtr()));
  local->setTransform(math::Transform::createLinearTransform(alpha_in.voxelSize()[0]));
  const FloatGrid &alpha = *local;
  std::vector<Vec3s> pts;
  std::vector<Vec3I> tris;
  std::vector<Vec4I> quads;
  const double t0 = mgs_now();
  tools::volumeToMesh(alpha, pts, tris, quads, (double)tau, 0.0, true);
  const double t1 = mgs_now();
  // Flat quads cut inside a curved surface by ~diagonal²/8R (0.06 voxel at R = 4 voxels):
  // split every quad into 4 triangles around its centre, which is projected too.
  if (refine >= 2) {
    const size_t nv0 = pts.size();
    pts.resize(nv0 + quads.size());
    tris.reserve(tris.size() + 4 * quads.size());
    for (size_t i = 0; i < quads.size(); i++) {
      const Vec4I &q = quads[i];
      pts[nv0 + i] = (pts[q[0]] + pts[q[1]] + pts[q[2]] + pts[q[3]]) * 0.25f;
      const Index m = (Index)(nv0 + i);
      tris.emplace_back(q[0], q[1], m);
      tris.emplace_back(q[1], q[2], m);
      tris.emplace_back(q[2], q[3], m);
      tris.emplace_back(q[3], q[0], m);
    }
    quads.clear();
  }
  if (refine >= 1) project_vertices(alpha, tau, pts);
  const double t2 = mgs_now();
  const float bg = (float)(w * alpha.voxelSize()[0]);
  if (pts.empty()) return empty_level_set(alpha_in, bg);
  // (Measured: meshToVolume without its renormalization / intersecting-voxel passes is no
  // faster here and raises the sphere test's band error from 0.08 to 0.27 voxel.)
  auto g = tools::meshToLevelSet<FloatGrid>(alpha.transform(), pts, tris, quads, (float)w);
  g->setTransform(alpha_in.transform().copy());
  mgs_debug("sdf (mesh): volumeToMesh %.3f s, split+project %.3f s (%zu vertices, %zu triangles), meshToLevelSet %.3f s",
            t1 - t0, t2 - t1, pts.size(), tris.size(), mgs_now() - t2);
  return g;
}

// fogToSdf on the α-field widened by the band (outside the kσ ellipsoids A is below τ, so
// the outer band needs the room); null if it found no surface.
FloatGrid::Ptr sweep_field(const FloatGrid &alpha, float tau, int w) {
  auto dom = alpha.deepCopy();
  tools::dilateActiveValues(dom->tree(), w + 1, tools::NN_FACE_EDGE_VERTEX, tools::EXPAND_TILES);
  return tools::fogToSdf(*dom, tau, 1);
}

FloatGrid::Ptr sdf_sweep(const FloatGrid &alpha, float tau, int w) {
  const float bg = (float)(w * alpha.voxelSize()[0]);
  auto g = sweep_field(alpha, tau, w);
  if (!g) return empty_level_set(alpha, bg);
  trim_band(*g, bg);
  return g;
}

// SWEEP's band before the background change and pruning (for the incremental build): the
// sweep's leaves with |d| clamped to the band; null if the sweep found no surface or left
// tiles (then only a whole build is used).
FloatTree::Ptr sdf_sweep_raw(const FloatGrid &alpha, float tau, int w) {
  auto g = sweep_field(alpha, tau, w);
  if (!g || g->tree().activeTileCount() > 0) return nullptr;
  clamp_band(g->tree(), (float)(w * alpha.voxelSize()[0]));
  // only the leaves carry the band; the tiles above them are made again by the finish
  auto raw = std::make_shared<FloatTree>(g->tree().background());
  for (auto l = g->tree().cbeginLeaf(); l; ++l) raw->addLeaf(new FloatTree::LeafNodeType(*l));
  return raw;
}

FloatGrid::Ptr sdf_sweep_finish(FloatTree::Ptr raw, const FloatGrid &alpha, float bg) {
  auto g = FloatGrid::create(raw);
  g->setTransform(alpha.transform().copy());
  tools::changeLevelSetBackground(g->tree(), bg);
  tools::pruneLevelSet(g->tree());
  return g;
}

// ---- CLOSEST: closest points on {A = τ}, seeded at the interface, carried through the band.
//
// The α-field's triquadratic interpolant (Lagrange through the 27 voxels around the nearest
// voxel centre: exact at voxel centres, so signs agree with the voxels) with its analytic
// gradient, in index space. One stencil fetch serves every Newton step that stays in its cell.
// True if c's 26 neighbours lie in c's own leaf (8³).
inline bool interior(const Coord &c) {
  return ((c[0] + 7) & 7) < 6 && ((c[1] + 7) & 7) < 6 && ((c[2] + 7) & 7) < 6;
}

// The leaves of a tree around one leaf (index 9 (dx + 1) + 3 (dy + 1) + dz + 1 for the leaf
// dx, dy, dz leaves away; null where there is none), each looked up once: reads at ±1 voxel of
// a leaf go straight to the buffers (through the accessor, 58 % of voxels touch a leaf face and
// each read of a neighbour went through its hash of cached nodes: 8 % of the SDF's time).
template <class TreeT> class LeafNbhd {
 public:
  using Leaf = typename TreeT::LeafNodeType;
  explicit LeafNbhd(const TreeT &t) : acc_(t) {}
  // Forget the leaves unless `o` (a leaf origin) is the one they are around.
  void at(const Coord &o) {
    if (known_ && o == o_) return;
    o_ = o;
    known_ = 0;
  }
  const Coord &origin() const { return o_; }
  // Index of the leaf holding the voxel at local (x, y, z) from the origin, each in [-8, 15].
  static int index(int x, int y, int z) { return 9 * ((x >> 3) + 1) + 3 * ((y >> 3) + 1) + (z >> 3) + 1; }
  static int offset(int x, int y, int z) { return ((x & 7) << 6) | ((y & 7) << 3) | (z & 7); }
  const Leaf *leaf(int k) {
    if (!(known_ >> k & 1)) {
      nb_[k] = acc_.probeConstLeaf(o_.offsetBy((k / 9 - 1) * 8, (k / 3 % 3 - 1) * 8, (k % 3 - 1) * 8));
      known_ |= 1u << k;
    }
    return nb_[k];
  }
  tree::ValueAccessor<const TreeT> &accessor() { return acc_; }

 private:
  tree::ValueAccessor<const TreeT> acc_;
  Coord o_;
  uint32_t known_ = 0;
  const Leaf *nb_[27];
};

class QuadField {
 public:
  QuadField(const FloatTree &t, float tau) : nb_(t), tau_(tau) {}
  // f = A(p) - τ, g = ∇A(p) (per voxel).
  double eval(const Vec3d &p, Vec3d &g) {
    const Coord c((Int32)std::floor(p[0] + 0.5), (Int32)std::floor(p[1] + 0.5), (Int32)std::floor(p[2] + 0.5));
    if (!have_ || c != c_) {
      int n = 0;
      nb_.at(Coord(c[0] & ~7, c[1] & ~7, c[2] & ~7));
      const FloatTree::LeafNodeType *leaf;
      if (interior(c) && (leaf = nb_.leaf(13))) {  // all 27 in one leaf (42 %)
        const float *buf = leaf->buffer().data();
        const int o = (int)FloatTree::LeafNodeType::coordToOffset(c);
        for (int i = -64; i <= 64; i += 64)
          for (int j = -8; j <= 8; j += 8)
            for (int k = -1; k <= 1; k++) v_[n++] = buf[o + i + j + k];
      } else {
        const Coord &o = nb_.origin();
        int li[3][3], lo[3][3];  // per axis and step: the leaf's index term and the offset term
        for (int a = 0; a < 3; a++)
          for (int s = 0; s < 3; s++) {
            const int x = c[a] - o[a] + s - 1;
            li[a][s] = ((x >> 3) + 1) * (a == 0 ? 9 : a == 1 ? 3 : 1);
            lo[a][s] = (x & 7) << (a == 0 ? 6 : a == 1 ? 3 : 0);
          }
        for (int i = 0; i < 3; i++)
          for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) {
              const float *buf = data(li[0][i] + li[1][j] + li[2][k]);
              // no leaf: a tile's value or the background
              v_[n++] = buf ? buf[lo[0][i] | lo[1][j] | lo[2][k]] : nb_.accessor().getValue(c.offsetBy(i - 1, j - 1, k - 1));
            }
      }
      c_ = c;
      have_ = true;
    }
    double w[3][3], d[3][3];
    for (int a = 0; a < 3; a++) {
      const double u = p[a] - c_[a];
      w[a][0] = 0.5 * u * (u - 1); w[a][1] = 1 - u * u; w[a][2] = 0.5 * u * (u + 1);
      d[a][0] = u - 0.5;           d[a][1] = -2 * u;    d[a][2] = u + 0.5;
    }
    double f = 0, gx = 0, gy = 0, gz = 0;
    int n = 0;
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) {
        double s = 0, sz = 0;
        for (int k = 0; k < 3; k++, n++) s += w[2][k] * v_[n], sz += d[2][k] * v_[n];
        f += w[0][i] * w[1][j] * s;
        gx += d[0][i] * w[1][j] * s;
        gy += w[0][i] * d[1][j] * s;
        gz += w[0][i] * w[1][j] * sz;
      }
    g = Vec3d(gx, gy, gz);
    return f - tau_;
  }
  float tau() const { return tau_; }

 private:
  // The values of leaf k of the neighbourhood (null: no leaf), looked up once per origin.
  const float *data(int k) {
    if (data_origin_ != nb_.origin() || !have_data_) {
      data_origin_ = nb_.origin();
      have_data_ = true;
      data_known_ = 0;
    }
    if (!(data_known_ >> k & 1)) {
      const FloatTree::LeafNodeType *l = nb_.leaf(k);
      data_[k] = l ? l->buffer().data() : nullptr;
      data_known_ |= 1u << k;
    }
    return data_[k];
  }
  LeafNbhd<FloatTree> nb_;
  const float *data_[27];
  uint32_t data_known_ = 0;
  Coord data_origin_;
  bool have_data_ = false;
  float tau_;
  Coord c_;
  bool have_ = false;
  float v_[27];
};

// Chopp's closest-point iteration (2001) from p toward the point of {f = 0} nearest x:
// a Newton step onto the surface plus the step that removes the tangential part of x - p.
// Steps capped at half a voxel; stops when a step is under 1e-3 voxel. True if p ends on the
// surface to 0.1 voxel (it ends within 1e-3 of it where the field is resolved; the
// interpolant jumps where the stencil changes at half-integer coordinates, and on sheets
// under a voxel thick the iteration can hop between two cells there without converging).
bool closest_point(QuadField &q, const Vec3d &x, Vec3d &p, int iters) {
  Vec3d g;
  for (int it = 0;; it++) {
    const double f = q.eval(p, g), g2 = g.lengthSqr();
    if (!(g2 > 1e-20) || !std::isfinite(g2)) return false;
    const Vec3d r = x - p;
    Vec3d step = -f / g2 * g + (r - r.dot(g) / g2 * g);
    const double len = step.length();
    if (it == iters || len < 1e-3) return std::fabs(f) < 0.1 * std::sqrt(g2);
    if (len > 0.5) step *= 0.5 / len;
    p += step;
  }
}

// Smallest root of a u² + b u + c on [lo, hi] (NaN if none).
inline double first_root(double a, double b, double c, double lo, double hi) {
  double r[2];
  int n = 0;
  if (std::fabs(a) <= 1e-12 * (std::fabs(b) + std::fabs(c))) {
    if (b != 0) r[n++] = -c / b;
  } else {
    const double disc = b * b - 4 * a * c;
    if (disc >= 0) {
      const double qq = -0.5 * (b + std::copysign(std::sqrt(disc), b));
      r[n++] = qq / a;
      if (qq != 0) r[n++] = c / qq;
    }
  }
  double best = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < n; i++)
    if (r[i] >= lo && r[i] <= hi && !(r[i] >= best)) best = r[i];
  return best;
}

// The point where {A > τ} ends on the edge from voxel c to c + e_axis, whose ends lie on
// either side: the triquadratic interpolant restricted to the edge is, on each half, the
// parabola through the three voxels along the axis around the nearer end (the weights of
// the other axes are 0/1/0 on a line of voxel centres), so this is a point of {A = τ} as
// closest_point sees it. The first crossing from c; if neither parabola crosses on its half,
// the two disagree at the midpoint (the interpolant jumps there) and the midpoint is where
// the side changes. Computed from the lower end only, so both voxels get the same point.
inline Vec3d edge_crossing(tree::ValueAccessor<const FloatTree> &acc, const Coord &c, int axis, float tau) {
  Coord e(0, 0, 0);
  e[axis] = 1;
  const double f0 = acc.getValue(c - e) - tau, f1 = acc.getValue(c) - tau;
  const double f2 = acc.getValue(c + e) - tau, f3 = acc.getValue(c + e + e) - tau;
  double t = first_root(0.5 * (f2 - 2 * f1 + f0), 0.5 * (f2 - f0), f1, 0, 0.5);  // u from c
  if (!(t >= 0)) {
    const double qa = 0.5 * (f3 - 2 * f2 + f1), qb = 0.5 * (f3 - f1);
    const double ml = f1 + 0.25 * (f2 - f0) + 0.125 * (f2 - 2 * f1 + f0);  // c's parabola at 1/2
    const double mr = f2 - 0.25 * (f3 - f1) + 0.125 * (f3 - 2 * f2 + f1);  // c+e's at -1/2
    const double v = first_root(qa, qb, f2, -0.5, 0);                     // v from c + e
    t = (ml > 0) != (mr > 0) || !(v <= 0) ? 0.5 : 1 + v;
  }
  Vec3d p = c.asVec3d();
  p[axis] += t;
  return p;
}

// Per-leaf parallel loop over the leaves of a tree (const tree: read them; else edit them).
template <class Tree, class F> void for_each_on(Tree &m, const F &f) {
  std::vector<decltype(&*m.beginLeaf())> leaves;
  leaves.reserve(m.leafCount());
  for (auto it = m.beginLeaf(); it; ++it) leaves.push_back(&*it);
  mgs_vdb_detail::parallel_for(0, leaves.size(), 16, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; i++) f(*leaves[i]);
  });
}

// The band's leaves, trimmed, before the flood fill of the tiles above them and pruning
// (sdf_finish): the incremental build (sdf_update) splices these.
FloatTree::Ptr sdf_closest_raw(const FloatGrid &alpha, float tau, int w) {
  const FloatTree &at = alpha.tree();
  const float bg = (float)(w * alpha.voxelSize()[0]);
  const float h = (float)alpha.voxelSize()[0];
  double t0 = mgs_now();
  // Inside = active α voxels with A > τ (inactive α is 0, outside).
  MaskTree inside(at, false, TopologyCopy());
  inside.voxelizeActiveTiles();
  for_each_on(inside, [&](MaskTree::LeafNodeType &l) {
    tree::ValueAccessor<const FloatTree> acc(at);
    for (auto v = l.getValueMask().beginOn(); v; ++v)
      if (!(acc.getValue(l.offsetToGlobalCoord(v.pos())) > tau)) l.setValueOff(v.pos());
  });
  tools::pruneInactive(inside);
  // Seeds: voxels with a 6-neighbour on the other side of the discrete interface.
  MaskTree seeds(inside);
  tools::dilateActiveValues(seeds, 1, tools::NN_FACE, tools::EXPAND_TILES);
  seeds.voxelizeActiveTiles();
  for_each_on(seeds, [&](MaskTree::LeafNodeType &l) {
    tree::ValueAccessor<const MaskTree> in(inside);
    for (auto v = l.getValueMask().beginOn(); v; ++v) {
      const Coord c = l.offsetToGlobalCoord(v.pos());
      const bool s = in.isValueOn(c);
      if (in.isValueOn(c.offsetBy(-1, 0, 0)) == s && in.isValueOn(c.offsetBy(1, 0, 0)) == s &&
          in.isValueOn(c.offsetBy(0, -1, 0)) == s && in.isValueOn(c.offsetBy(0, 1, 0)) == s &&
          in.isValueOn(c.offsetBy(0, 0, -1)) == s && in.isValueOn(c.offsetBy(0, 0, 1)) == s)
        l.setValueOff(v.pos());
    }
  });
  tools::pruneInactive(seeds);
  // The whole band: voxels within Chebyshev distance w of a seed hold every voxel closer
  // than w to a resolved surface (its closest point lies in a cell with a seed corner).
  MaskTree band(seeds);
  tools::dilateActiveValues(band, w, tools::NN_FACE_EDGE_VERTEX, tools::EXPAND_TILES);
  band.voxelizeActiveTiles();
  auto dist_ptr = std::make_shared<FloatTree>(band, bg, TopologyCopy());
  FloatTree &dist = *dist_ptr;  // signed distance in voxels, then world units
  Vec3STree cp(band, Vec3s(0.0f), TopologyCopy());  // closest point - voxel, index units
  const double t1 = mgs_now();

  // Ring 0: Chopp's iteration from the voxel itself, else from each crossing on its 6 edges
  // to the other side (thin sheets: at a sheet's crest ∇A vanishes and the first Newton step
  // goes nowhere); the nearest point that converges. Every crossing itself is a candidate
  // too, the same point for both voxels of its edge (edge_crossing): whatever the iteration
  // does, two face neighbours of opposite sign end with |d_i| + |d_j| <= 1 voxel, as in a
  // distance field (on trained α-fields, ragged crests and sheets under a voxel thick made
  // the iteration's own points land up to 1.75 voxels away on both sides of an edge).
  std::atomic<size_t> fallback{0};
  for_each_on(seeds, [&](const MaskTree::LeafNodeType &ml) {
    QuadField q(at, tau);
    tree::ValueAccessor<const FloatTree> acc(at);
    tree::ValueAccessor<const MaskTree> in(inside);
    auto *dl = dist.probeLeaf(ml.origin());
    auto *cl = cp.probeLeaf(ml.origin());
    for (auto v = ml.getValueMask().beginOn(); v; ++v) {
      const Coord c = ml.offsetToGlobalCoord(v.pos());
      const Vec3d x = c.asVec3d();
      const bool s = in.isValueOn(c);
      Vec3d p = x;
      double d = INFINITY;
      const bool own = closest_point(q, x, p, 8) && (p - x).length() <= 1.75;
      if (own) d = (p - x).length();
      bool converged = own;
      for (int a = 0; a < 3; a++)
        for (int sgn = -1; sgn <= 1; sgn += 2) {
          Coord n = c;
          n[a] += sgn;
          if (in.isValueOn(n) == s) continue;
          Vec3d pe = edge_crossing(acc, sgn > 0 ? c : n, a, tau);
          if ((pe - x).length() < d) d = (pe - x).length(), p = pe;
          if (!own && closest_point(q, x, pe, 8) && (pe - x).length() < d) d = (pe - x).length(), p = pe, converged = true;
        }
      if (!converged) fallback++;
      cl->setValueOnly(v.pos(), Vec3s(p - x));
      dl->setValueOnly(v.pos(), (float)(s ? -d : d));
    }
  });
  const double t2 = mgs_now();
  // Rings 1..w: the nearest of the 26 neighbours' closest points in the previous ring,
  // refined by the same iteration from there (the seeds' points are a voxel apart on the
  // surface, too coarse by themselves: 0.1 voxel at 1 voxel off a 4-voxel sphere).
  // Ring k is the previous ring grown by one voxel, minus the voxels already known: a voxel
  // at 26-neighbour distance k from the seeds has a neighbour at k - 1, so this is the known
  // set's own dilation minus itself, without dilating and copying the whole band w times.
  MaskTree known(seeds);
  std::unique_ptr<MaskTree> prev(new MaskTree(seeds));
  for (int k = 1; k <= w; k++) {
    MaskTree ring(*prev);
    tools::dilateActiveValues(ring, 1, tools::NN_FACE_EDGE_VERTEX, tools::EXPAND_TILES);
    ring.topologyDifference(known);
    ring.voxelizeActiveTiles();
    for_each_on(ring, [&](const MaskTree::LeafNodeType &ml) {
      QuadField q(at, tau);
      LeafNbhd<MaskTree> pa(*prev);
      LeafNbhd<Vec3STree> ca(cp);
      pa.at(ml.origin());
      ca.at(ml.origin());
      tree::ValueAccessor<const MaskTree> in(inside);
      auto *dl = dist.probeLeaf(ml.origin());
      auto *cl = cp.probeLeaf(ml.origin());
      if (!dl || !cl) return;
      for (auto v = ml.getValueMask().beginOn(); v; ++v) {
        const Coord c = ml.offsetToGlobalCoord(v.pos());
        const Vec3d x = c.asVec3d();
        double best = INFINITY;
        Vec3d bp;
        const int o = (int)v.pos(), lx = o >> 6, ly = (o >> 3) & 7, lz = o & 7;
        for (int i = -1; i <= 1; i++)
          for (int j = -1; j <= 1; j++)
            for (int l = -1; l <= 1; l++) {
              const int k = LeafNbhd<MaskTree>::index(lx + i, ly + j, lz + l);
              const int on = LeafNbhd<MaskTree>::offset(lx + i, ly + j, lz + l);
              const auto *pl = pa.leaf(k);
              if (!pl || !pl->isValueOn(on)) continue;
              const auto *cpl = ca.leaf(k);
              if (!cpl) continue;
              const Vec3d p = x + Vec3d(i, j, l) + Vec3d(cpl->getValue(on));
              const double d2 = (p - x).lengthSqr();
              if (d2 < best) best = d2, bp = p;  // (false for NaN: no closest point)
            }
        if (!std::isfinite(best)) {  // (not met: every seed hands on a point) chamfer step
          double dc = INFINITY;
          for (int i = -1; i <= 1; i++)
            for (int j = -1; j <= 1; j++)
              for (int l = -1; l <= 1; l++) {
                const Coord n = c.offsetBy(i, j, l);
                if (prev->isValueOn(n)) dc = std::min(dc, std::fabs((double)dist.getValue(n)) + std::sqrt(double(i * i + j * j + l * l)));
              }
          cl->setValueOnly(v.pos(), Vec3s(std::numeric_limits<float>::quiet_NaN()));
          dl->setValueOnly(v.pos(), (float)(in.isValueOn(c) ? -dc : dc));
          continue;
        }
        double d = std::sqrt(best);
        Vec3d p = bp;
        if (closest_point(q, x, p, 3)) {
          const double dr = (p - x).length();
          if (dr < d) d = dr, bp = p;
        }
        cl->setValueOnly(v.pos(), Vec3s(bp - x));
        dl->setValueOnly(v.pos(), (float)(in.isValueOn(c) ? -d : d));
      }
    });
    known.topologyUnion(ring);
    prev.reset(new MaskTree(ring));
  }
  const double t3 = mgs_now();
  // Relaxation. A ring takes the points of its inner neighbours only, so two neighbours of
  // one ring (or a voxel and its outer neighbour) can keep points of different sheets of a
  // ragged surface, several voxels apart in distance (measured on trained models: jumps of
  // up to 2.7 voxels between face neighbours, thousands of pairs over 1.1). Sweep until no
  // voxel's distance exceeds a neighbour's (26) by more than their spacing: such a voxel
  // takes the nearest of its neighbours' points (refined by the same iteration), which is
  // within that bound. In the end |d_i| <= |d_j| + |x_i - x_j| (+1e-4 voxel) between all
  // neighbours of one side, and the seeds' shared edge crossings bound |d_i| + |d_j| <= 1
  // across the interface: a distance field between every pair of neighbours. Voxels that
  // meet the bound keep their own point (taking any nearer neighbour point everywhere
  // spread the iteration's unconverged points, up to 0.1 voxel off the surface, and doubled
  // the clean shapes' band errors: ellipsoid 0.046 -> 0.091 voxel). After the first sweep
  // only the voxels next to a change are visited; each change lowers a distance, so the
  // sweeps end.
  size_t sweeps = 0, moved = 0, grown = 0;
  const double eps = 1e-4;  // voxels: float rounding of the stored points
  const double lsteps[4] = {0, 1, std::sqrt(2.0), std::sqrt(3.0)};
  const float lstepsf[4] = {0, 1, (float)std::sqrt(2.0), (float)std::sqrt(3.0)};
  // Sweeps over `work` (a mask inside the band) until nothing changes; every voxel that
  // changed is added to `touched`.
  auto relax = [&](std::unique_ptr<MaskTree> work, MaskTree &touched) {
  while (work->activeVoxelCount() > 0) {
    sweeps++;
    // the new points of the voxels that change, per leaf (few: no tree the band's size)
    struct Moves {
      Coord origin;
      std::vector<std::pair<Index, Vec3s>> v;
    };
    std::vector<Moves> moves;
    std::mutex mu;
    MaskTree changed(*work);
    for_each_on(changed, [&](MaskTree::LeafNodeType &ml) {
      QuadField q(at, tau);
      tree::ValueAccessor<const Vec3STree> ca(cp);
      tree::ValueAccessor<const FloatTree> da(dist);
      const Vec3STree::LeafNodeType *cl = ca.probeConstLeaf(ml.origin());
      if (!cl) return;
      // the 27 leaves around this one, looked up once (most voxels touch a leaf face)
      const Vec3STree::LeafNodeType *nb[27];
      const FloatTree::LeafNodeType *nd[27];
      for (int k = 0; k < 27; k++) {
        const Coord o = ml.origin().offsetBy((k / 9 - 1) * 8, (k / 3 % 3 - 1) * 8, (k % 3 - 1) * 8);
        nb[k] = ca.probeConstLeaf(o);
        nd[k] = nb[k] ? da.probeConstLeaf(o) : nullptr;
      }
      // Most voxels meet the bound. Find those that may not from the stored |d| (float, no
      // square root; +inf off the band) of the leaf and its one-voxel rim, over 8 voxels of
      // a row at a time, and test only them exactly on the points below. |d| and the length
      // of the stored point differ by float rounding, < 1e-6 (1 + |d|) voxel, so the filter,
      // with that much less slack, passes every voxel the exact test breaks.
      float pad[10][10][10];
      for (int x = -1; x <= 8; x++)
        for (int y = -1; y <= 8; y++)
          for (int z = -1; z <= 8; z++) {
            const int k = 9 * ((x >> 3) + 1) + 3 * ((y >> 3) + 1) + (z >> 3) + 1;
            const int on = ((x & 7) << 6) | ((y & 7) << 3) | (z & 7);
            pad[x + 1][y + 1][z + 1] = nd[k] && nb[k]->isValueOn(on) ? std::fabs(nd[k]->getValue(on)) : INFINITY;
          }
      const auto &mask = ml.getValueMask();
      std::vector<std::pair<Index, Vec3s>> mine;
      for (int lx = 0; lx < 8; lx++)
        for (int ly = 0; ly < 8; ly++) {
          const Index row = (Index)(lx << 6 | ly << 3);
          if (!(mask.getWord<uint8_t>(row >> 3))) continue;
          float m[8];
          for (int z = 0; z < 8; z++) m[z] = INFINITY;
          for (int i = -1; i <= 1; i++)
            for (int j = -1; j <= 1; j++)
              for (int l = -1; l <= 1; l++) {
                if (!i && !j && !l) continue;
                const float st = lstepsf[(i != 0) + (j != 0) + (l != 0)];
                const float *r = &pad[lx + 1 + i][ly + 1 + j][1 + l];
                for (int z = 0; z < 8; z++) m[z] = std::min(m[z], r[z] + st);
              }
          for (int lz = 0; lz < 8; lz++) {
            const Index o = row | (Index)lz;
            if (!mask.isOn(o)) continue;
            const Vec3d own(cl->getValue(o));
            const bool finite = std::isfinite(own.lengthSqr());
            const float d0f = pad[lx + 1][ly + 1][lz + 1];
            if (finite && !(d0f > m[lz] + (float)eps - 1e-6f * (1 + d0f))) {
              ml.setValueOff(o);
              continue;
            }
            const double d0 = finite ? own.length() : INFINITY;
            double best = d0 * d0;
            bool broken = false;
            Vec3d bo;
            for (int i = -1; i <= 1; i++)
              for (int j = -1; j <= 1; j++)
                for (int l = -1; l <= 1; l++) {
                  const int x = lx + i, y = ly + j, z = lz + l;
                  const auto *leaf = nb[9 * ((x >> 3) + 1) + 3 * ((y >> 3) + 1) + (z >> 3) + 1];
                  const int on = ((x & 7) << 6) | ((y & 7) << 3) | (z & 7);
                  if (!leaf || !leaf->isValueOn(on)) continue;
                  const Vec3s pn = leaf->getValue(on);
                  const Vec3d off = Vec3d(i, j, l) + Vec3d(pn);
                  const double d2 = off.lengthSqr();
                  if (d2 < best) best = d2, bo = off;  // (false for NaN)
                  if (d0 > Vec3d(pn).length() + lsteps[(i != 0) + (j != 0) + (l != 0)] + eps) broken = true;
                }
            if (!broken) {
              ml.setValueOff(o);
              continue;
            }
            const double d = std::sqrt(best);
            const Vec3d x = ml.offsetToGlobalCoord(o).asVec3d();
            Vec3d p = x + bo;
            if (closest_point(q, x, p, 3) && (p - x).length() < d) bo = p - x;
            mine.emplace_back(o, Vec3s(bo));
          }
        }
      if (!mine.empty()) {
        std::lock_guard<std::mutex> lk(mu);
        moves.push_back(Moves{ml.origin(), std::move(mine)});
      }
    });
    tools::pruneInactive(changed);
    mgs_vdb_detail::parallel_for(0, moves.size(), 16, [&](size_t b, size_t e) {
      tree::ValueAccessor<const MaskTree> in(inside);
      for (size_t k = b; k < e; k++) {
        auto *cl = cp.probeLeaf(moves[k].origin);
        auto *dl = dist.probeLeaf(moves[k].origin);
        for (const auto &mv : moves[k].v) {
          const double d = Vec3d(mv.second).length();
          cl->setValueOnly(mv.first, mv.second);
          dl->setValueOnly(mv.first, (float)(in.isValueOn(cl->offsetToGlobalCoord(mv.first)) ? -d : d));
        }
      }
    });
    moved += changed.activeVoxelCount();
    touched.topologyUnion(changed);
    work.reset(new MaskTree(changed));
    tools::dilateActiveValues(*work, 1, tools::NN_FACE_EDGE_VERTEX, tools::EXPAND_TILES);
    work->topologyIntersection(band);
  }
  };
  MaskTree touched(false);
  relax(std::unique_ptr<MaskTree>(new MaskTree(band)), touched);
  // The band's outer layer. The band is the seeds grown by w voxels, but the surface also
  // has parts no seed sees: sub-voxel bubbles and slivers of the interpolant between voxel
  // centres of one sign, which the iteration finds. A voxel next to one can sit deep inside the
  // seeds' band at |d| = 0.1 voxel with a neighbour left out at the background ±w
  // (measured on a 7050-iteration model of gmsh-doc's lever.stl at 512: 48 such pairs,
  // up to 2.9 voxels apart; issue 21). So grow the band: every voxel outside it beside a band
  // voxel i with |d_i| + |x_i - x_j| < w joins, with the nearest of its neighbours' points
  // (refined), and the relaxation runs again around it; repeat until none. Afterwards an
  // active voxel beside an inactive one has |d| >= w - 1 voxel, so the background is within a
  // voxel of it too. Each round adds only voxels nearer than w to a point, so it ends.
  std::unique_ptr<MaskTree> scan(new MaskTree(band));
  for (;;) {
    std::mutex mu;
    std::vector<Coord> add;
    for_each_on(*scan, [&](const MaskTree::LeafNodeType &ml) {
      tree::ValueAccessor<const Vec3STree> ca(cp);
      tree::ValueAccessor<const MaskTree> ba(band);
      std::vector<Coord> mine;
      for (auto v = ml.getValueMask().beginOn(); v; ++v) {
        const Coord c = ml.offsetToGlobalCoord(v.pos());
        const double d = Vec3d(ca.getValue(c)).length();
        if (!(d + 1 < w)) continue;  // (false for NaN)
        for (int i = -1; i <= 1; i++)
          for (int j = -1; j <= 1; j++)
            for (int l = -1; l <= 1; l++) {
              const Coord n = c.offsetBy(i, j, l);
              if (!ba.isValueOn(n) && d + lsteps[(i != 0) + (j != 0) + (l != 0)] < w) mine.push_back(n);
            }
      }
      if (!mine.empty()) {
        std::lock_guard<std::mutex> lk(mu);
        add.insert(add.end(), mine.begin(), mine.end());
      }
    });
    if (add.empty()) break;
    std::sort(add.begin(), add.end(), [](const Coord &a, const Coord &b) { return a < b; });
    add.erase(std::unique(add.begin(), add.end()), add.end());
    // points first (from the band as it was), then the topology: the reads see no new voxel
    std::vector<Vec3s> off(add.size());
    {
      QuadField q(at, tau);
      tree::ValueAccessor<const Vec3STree> ca(cp);
      tree::ValueAccessor<const MaskTree> ba(band);
      for (size_t k = 0; k < add.size(); k++) {
        const Vec3d x = add[k].asVec3d();
        double best = INFINITY;
        Vec3d bp(0.0);
        for (int i = -1; i <= 1; i++)
          for (int j = -1; j <= 1; j++)
            for (int l = -1; l <= 1; l++) {
              const Coord n = add[k].offsetBy(i, j, l);
              if (!ba.isValueOn(n)) continue;
              const Vec3d p = n.asVec3d() + Vec3d(ca.getValue(n));
              const double d2 = (p - x).lengthSqr();
              if (d2 < best) best = d2, bp = p;
            }
        Vec3d p = bp;
        if (closest_point(q, x, p, 3) && (p - x).lengthSqr() < best) bp = p;
        off[k] = Vec3s(bp - x);
      }
    }
    MaskTree added(false);
    {
      tree::ValueAccessor<const MaskTree> in(inside);
      for (size_t k = 0; k < add.size(); k++) {
        const double d = Vec3d(off[k]).length();
        band.setValueOn(add[k]);
        added.setValueOn(add[k]);
        cp.setValueOn(add[k], off[k]);
        dist.setValueOn(add[k], (float)(in.isValueOn(add[k]) ? -d : d));
      }
    }
    grown += add.size();
    // New band leaves: their other voxels hold the trees' backgrounds, inactive (the trim
    // below signs them from the inside mask).
    std::unique_ptr<MaskTree> work(new MaskTree(added));
    tools::dilateActiveValues(*work, 1, tools::NN_FACE_EDGE_VERTEX, tools::EXPAND_TILES);
    work->topologyIntersection(band);
    MaskTree again(false);
    relax(std::move(work), again);
    scan.reset(new MaskTree(added));
    scan->topologyUnion(again);
  }
  const double t4 = mgs_now();
  cp.clear();
  // Voxels to world units; beyond the band: inactive ±bg. Every inactive voxel of a band
  // leaf takes its sign from the inside mask, not from OpenVDB's scanline flood fill: that
  // fills a leaf left with no active voxel (all of it trimmed beyond ±w) by the sign of its
  // first voxel, which need not be in the band at all (measured on a trained model: a whole
  // leaf of deep-inside voxels at +w next to -2.9 voxels). The flood fill then only sets the
  // tiles above the leaves, from the leaves' corner values.
  for_each_on(dist, [&](FloatTree::LeafNodeType &l) {
    tree::ValueAccessor<const MaskTree> in(inside);
    for (auto v = l.beginValueAll(); v; ++v) {
      if (!v.isValueOn()) {
        v.setValue(in.isValueOn(v.getCoord()) ? -bg : bg);
        continue;
      }
      const float d = *v * h;
      if (d >= bg) v.setValue(bg), v.setValueOff();
      else if (d <= -bg) v.setValue(-bg), v.setValueOff();
      // an inside voxel on the surface itself (Chopp's iteration did not move: d = -0) must
      // still read as inside wherever the sign is taken as v < 0
      else if (d == 0 && std::signbit(d)) v.setValue(-std::numeric_limits<float>::min());
      else v.setValue(d);
    }
  });
  if (fallback) mgs_debug("sdf (closest): %zu seed voxels kept an edge crossing (no iteration converged)", (size_t)fallback);
  mgs_debug("sdf (closest): masks %.3f s, %zu seeds %.3f s, rings %.3f s, relaxation %.3f s (%zu sweeps, %zu voxels "
            "moved, %zu grown), trim %.3f s (%zu band voxels)", t1 - t0, (size_t)seeds.activeVoxelCount(), t2 - t1, t3 - t2,
            t4 - t3, sweeps, moved, grown, mgs_now() - t4, (size_t)dist.activeVoxelCount());
  return dist_ptr;
}

// The raw band (taken over) -> the level set: tiles above the leaves signed by flood fill
// from the leaves' corner values, then pruned.
FloatGrid::Ptr sdf_finish(FloatTree::Ptr raw, const FloatGrid &alpha) {
  auto g = FloatGrid::create(raw);
  g->setTransform(alpha.transform().copy());
  tools::signedFloodFill(g->tree(), true, 1, /*minLevel: above the leaves*/ 1);
  tools::pruneLevelSet(g->tree());
  return g;
}

FloatGrid::Ptr sdf_closest(const FloatGrid &alpha, float tau, int w) { return sdf_finish(sdf_closest_raw(alpha, tau, w), alpha); }

bool exceeds(const FloatGrid &a, float tau) {
  for (auto it = a.tree().cbeginValueOn(); it; ++it)
    if (*it > tau) return true;
  return false;
}

inline Coord leaf_key(const Coord &origin) { return Coord(origin[0] >> 3, origin[1] >> 3, origin[2] >> 3); }

// The raw band (CLOSEST's, or SWEEP's) of `alpha` from the last build's (prev_alpha -> prev_raw) on the same lattice:
// the leaves where the two α-fields differ (D), grown by `reach` voxels (U), are computed
// again from a crop of `alpha` grown by `reach` once more; every other leaf is copied. A
// voxel's value depends on α within reach = 2w + 10 voxels: its closest point lies within w,
// Chopp's iteration reads the 27 voxels around it, the rings hand points on one voxel at a
// time, and a relaxation chain only moves a point to voxels within their own distance of it
// (at most w), so w + w + a few; a sweep's value is the length of an upwind path from the
// interface, and a path longer than w ends beyond the band. The result is the leaves of a whole build, bit for bit
// (tests/vdb/test_vdb_sdf_cache), while that bound holds. Returns null when so much changed
// that a whole build is cheaper.
FloatTree::Ptr sdf_raw(const FloatGrid &alpha, float tau, int w, bool sweep) {
  return sweep ? sdf_sweep_raw(alpha, tau, w) : sdf_closest_raw(alpha, tau, w);
}

FloatTree::Ptr sdf_update(const FloatGrid &alpha, float tau, int w, bool sweep, const FloatGrid &prev_alpha,
                          const FloatTree &prev_raw, mgs_vdb_sdf_update_info &info) {
  const FloatTree &at = alpha.tree(), &pt = prev_alpha.tree();
  MaskTree changed(false);  // leaf keys (origin / 8)
  for (auto l = at.cbeginLeaf(); l; ++l) {
    const auto *p = pt.probeConstLeaf(l->origin());
    if (!p || p->getValueMask() != l->getValueMask() ||
        std::memcmp(p->buffer().data(), l->buffer().data(), FloatTree::LeafNodeType::SIZE * sizeof(float)))
      changed.setValueOn(leaf_key(l->origin()));
  }
  for (auto l = pt.cbeginLeaf(); l; ++l)
    if (!at.probeConstLeaf(l->origin())) changed.setValueOn(leaf_key(l->origin()));
  info.leaves_changed = (size_t)changed.activeVoxelCount();
  info.leaves_total = (size_t)prev_raw.leafCount();
  if (!info.leaves_changed) {
    info.leaves_recomputed = 0;
    return std::make_shared<FloatTree>(prev_raw);
  }
  // (+2: a voxel the band grows by takes a neighbour's point, one voxel further; w = 3 still
  // gives 2 leaves)
  const int reach = 2 * w + 10, grow = (reach + 7) / 8;  // in leaves
  MaskTree redo(changed);
  tools::dilateActiveValues(redo, grow, tools::NN_FACE_EDGE_VERTEX, tools::EXPAND_TILES);
  redo.voxelizeActiveTiles();
  MaskTree crop_keys(redo);
  tools::dilateActiveValues(crop_keys, grow, tools::NN_FACE_EDGE_VERTEX, tools::EXPAND_TILES);
  crop_keys.voxelizeActiveTiles();
  size_t redo_band = 0;
  tree::ValueAccessor<const MaskTree> ra(redo);
  for (auto l = prev_raw.cbeginLeaf(); l; ++l) redo_band += ra.isValueOn(leaf_key(l->origin()));
  info.leaves_recomputed = redo_band;
  auto crop = FloatGrid::create(at.background());
  crop->setTransform(alpha.transform().copy());
  size_t cropped = 0;
  for (auto k = crop_keys.cbeginValueOn(); k; ++k) {
    const Coord c = k.getCoord();
    const auto *l = at.probeConstLeaf(Coord(c[0] * 8, c[1] * 8, c[2] * 8));
    if (l) crop->tree().addLeaf(new FloatTree::LeafNodeType(*l)), cropped++;
  }
  if (cropped > at.leafCount() * 3 / 4) return nullptr;  // the crop is most of the field: build it whole
  auto out = std::make_shared<FloatTree>(prev_raw.background());
  for (auto l = prev_raw.cbeginLeaf(); l; ++l)
    if (!ra.isValueOn(leaf_key(l->origin()))) out->addLeaf(new FloatTree::LeafNodeType(*l));
  if (exceeds(*crop, tau)) {
    FloatTree::Ptr part = sdf_raw(*crop, tau, w, sweep);
    if (!part) return nullptr;
    for (auto l = part->cbeginLeaf(); l; ++l)
      if (ra.isValueOn(leaf_key(l->origin()))) out->addLeaf(new FloatTree::LeafNodeType(*l));
  }
  return out;
}

}  // namespace

// The last build of mgs_vdb_sdf_from_alpha_cached: its α-field (shared, never written) and
// raw band, and the parameters they were made with.
struct mgs_vdb_sdf_cache {
  FloatGrid::Ptr alpha;
  FloatTree::Ptr raw;
  float tau = 0;
  int w = 0;
  bool sweep = false;
};

extern "C" void mgs_vdb_sdf_params_default(mgs_vdb_sdf_params *p) {
  p->tau = 0.5;
  p->half_width = 3;
  p->method = MGS_VDB_SDF_CLOSEST;
  p->mesh_refine = 2;
}

extern "C" mgs_status mgs_vdb_sdf_from_alpha(const mgs_vdb_grid *alpha, const mgs_vdb_sdf_params *pin,
                                             mgs_vdb_grid **out, mgs_error *err) {
  *out = nullptr;
  mgs_vdb_sdf_params p;
  if (pin) p = *pin; else mgs_vdb_sdf_params_default(&p);
  if (!(p.tau > 0) || !std::isfinite(p.tau))
    return mgs_error_set(err, MGS_ERR_ARG, "sdf: iso value tau = %g must be positive", p.tau);
  if (p.half_width < 1 || p.half_width > 1000)
    return mgs_error_set(err, MGS_ERR_ARG, "sdf: band half-width %d outside [1, 1000] voxels", p.half_width);
  const FloatGrid &a = *alpha->grid;
  try {
    // Is the surface anywhere? (fogToSdf would return ±inf otherwise.)
    float mx = -INFINITY;
    for (auto it = a.tree().cbeginValueOn(); it; ++it) mx = std::max(mx, *it);
    FloatGrid::Ptr g;
    const float bg = (float)(p.half_width * a.voxelSize()[0]);
    if (!(mx > p.tau)) {
      mgs_warn("sdf: the alpha field never exceeds tau = %g (max %g): empty level set", p.tau, (double)mx);
      g = empty_level_set(a, bg);
    } else if (p.method == MGS_VDB_SDF_SWEEP) {
      g = sdf_sweep(a, (float)p.tau, p.half_width);
    } else if (p.method == MGS_VDB_SDF_CLOSEST) {
      g = sdf_closest(a, (float)p.tau, p.half_width);
    } else {
      g = sdf_mesh(a, (float)p.tau, p.half_width, p.mesh_refine);
    }
    g->setName("sdf");
    g->setGridClass(GRID_LEVEL_SET);
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "sdf: %s", e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "sdf: out of memory");
}

extern "C" mgs_status mgs_vdb_density_from_alpha(const mgs_vdb_grid *alpha, mgs_vdb_grid **out, mgs_error *err) {
  *out = nullptr;
  try {
    auto g = alpha->grid->deepCopy();
    tools::foreach(g->beginValueOn(), [](const FloatGrid::ValueOnIter &it) {
      it.setValue(std::min(std::max(*it, 0.0f), 1.0f));
    });
    g->setName("density");
    g->setGridClass(GRID_FOG_VOLUME);
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "density: %s", e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "density: out of memory");
}

extern "C" mgs_vdb_sdf_cache *mgs_vdb_sdf_cache_create(void) { return new (std::nothrow) mgs_vdb_sdf_cache(); }
extern "C" void mgs_vdb_sdf_cache_destroy(mgs_vdb_sdf_cache *c) { delete c; }

extern "C" mgs_status mgs_vdb_sdf_from_alpha_cached(const mgs_vdb_grid *alpha, const mgs_vdb_sdf_params *pin,
                                                    mgs_vdb_sdf_cache *cache, mgs_vdb_grid **out,
                                                    mgs_vdb_sdf_update_info *info, mgs_error *err) {
  if (out) *out = nullptr;
  if (!alpha || !out) return mgs_error_set(err, MGS_ERR_ARG, "sdf: null argument");
  if (!cache) return mgs_error_set(err, MGS_ERR_ARG, "sdf: no cache");
  mgs_vdb_sdf_params p;
  if (pin) p = *pin; else mgs_vdb_sdf_params_default(&p);
  mgs_vdb_sdf_update_info local{};
  mgs_vdb_sdf_update_info &in = info ? *info : local;
  in = mgs_vdb_sdf_update_info{};
  in.whole = 1;
  const FloatGrid &a = *alpha->grid;
  const bool sweep = p.method == MGS_VDB_SDF_SWEEP;
  if (p.method == MGS_VDB_SDF_MESH || !(p.tau > 0) || p.half_width < 1 || p.half_width > 1000 ||
      a.tree().activeTileCount() > 0 || !exceeds(a, (float)p.tau)) {
    cache->alpha.reset();
    cache->raw.reset();
    return mgs_vdb_sdf_from_alpha(alpha, &p, out, err);
  }
  try {
    FloatTree::Ptr raw;
    const bool same = cache->alpha && cache->raw && cache->tau == (float)p.tau && cache->w == p.half_width && cache->sweep == sweep &&
                      cache->alpha->transform() == a.transform() && cache->alpha->background() == a.background() &&
                      cache->alpha->tree().activeTileCount() == 0;
    if (same) raw = sdf_update(a, (float)p.tau, p.half_width, sweep, *cache->alpha, *cache->raw, in);
    if (raw) in.whole = 0;
    else if ((raw = sdf_raw(a, (float)p.tau, p.half_width, sweep))) in.leaves_recomputed = in.leaves_total = raw->leafCount();
    if (!raw) {  // the sweep left tiles: built whole, nothing cached
      cache->alpha.reset();
      cache->raw.reset();
      return mgs_vdb_sdf_from_alpha(alpha, &p, out, err);
    }
    cache->alpha = alpha->grid;
    cache->raw = raw;
    cache->tau = (float)p.tau;
    cache->w = p.half_width;
    cache->sweep = sweep;
    FloatGrid::Ptr g = sweep ? sdf_sweep_finish(std::make_shared<FloatTree>(*raw), a, (float)(p.half_width * a.voxelSize()[0]))
                             : sdf_finish(std::make_shared<FloatTree>(*raw), a);
    g->setName("sdf");
    g->setGridClass(GRID_LEVEL_SET);
    *out = mgs_vdb_detail::wrap(g);
  } catch (const std::exception &e) {
    cache->alpha.reset();
    cache->raw.reset();
    return mgs_error_set(err, MGS_ERR_NOMEM, "sdf: %s", e.what());
  }
  return *out ? MGS_OK : mgs_error_set(err, MGS_ERR_NOMEM, "sdf: out of memory");
}
