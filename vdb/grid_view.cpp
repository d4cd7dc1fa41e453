// The C view of a grid: leaves and tiles without copying, random access, world/index
// transforms, trilinear sampling of values and gradients, per-leaf change detection.
#include <openvdb/openvdb.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <vector>
#include "vdb/vdb_internal.hpp"

using namespace openvdb;
using LeafT = FloatTree::LeafNodeType;

extern "C" size_t mgs_vdb_leaf_count(const mgs_vdb_grid *g) { return (size_t)g->grid->tree().leafCount(); }

extern "C" size_t mgs_vdb_leaf_views(const mgs_vdb_grid *g, mgs_vdb_leaf_view *out, size_t cap) {
  size_t n = 0;
  for (auto it = g->grid->tree().cbeginLeaf(); it; ++it, ++n) {
    if (n >= cap || !out) continue;
    const LeafT &leaf = *it;
    const Coord o = leaf.origin();
    mgs_vdb_leaf_view &v = out[n];
    v.origin[0] = o[0]; v.origin[1] = o[1]; v.origin[2] = o[2];
    v.values = leaf.buffer().data();
    // NodeMask<3> holds exactly its 8 64-bit words.
    static_assert(sizeof(LeafT::NodeMaskType) == 8 * sizeof(uint64_t), "leaf mask layout");
    v.active_mask = reinterpret_cast<const uint64_t *>(&leaf.getValueMask());
  }
  return n;
}

namespace {
struct TileSink {
  int which, keep_bg;
  float bg;
  mgs_vdb_tile *out;
  size_t cap, n = 0;
  void emit(const Coord &c, int32_t dim, float value, bool on) {
    if (on && !(which & MGS_VDB_TILES_ACTIVE)) return;
    if (!on && !(which & MGS_VDB_TILES_INACTIVE)) return;
    if (!on && !keep_bg && value == bg) return;
    if (out && n < cap) {
      mgs_vdb_tile &t = out[n];
      t.origin[0] = c[0]; t.origin[1] = c[1]; t.origin[2] = c[2];
      t.dim = dim; t.value = value; t.active = on ? 1 : 0;
    }
    n++;
  }
};
}  // namespace

extern "C" size_t mgs_vdb_tiles(const mgs_vdb_grid *g, int which, int keep_background, mgs_vdb_tile *out, size_t cap) {
  const FloatTree &tree = g->grid->tree();
  TileSink s{which, keep_background, tree.background(), out, cap};
  using RootT = FloatTree::RootNodeType;
  using Int2 = RootT::ChildNodeType;
  using Int1 = Int2::ChildNodeType;
  const auto &root = tree.root();
  for (auto it = root.cbeginValueAll(); it; ++it) s.emit(it.getCoord(), (int32_t)Int2::DIM, *it, it.isValueOn());
  for (auto i2 = root.cbeginChildOn(); i2; ++i2) {
    for (auto t = i2->cbeginValueAll(); t; ++t) s.emit(t.getCoord(), (int32_t)Int1::DIM, *t, t.isValueOn());
    for (auto i1 = i2->cbeginChildOn(); i1; ++i1)
      for (auto t = i1->cbeginValueAll(); t; ++t) s.emit(t.getCoord(), (int32_t)LeafT::DIM, *t, t.isValueOn());
  }
  return s.n;
}

extern "C" float mgs_vdb_value(const mgs_vdb_grid *g, const int32_t ijk[3], int *active) {
  const Coord c(ijk[0], ijk[1], ijk[2]);
  float v = 0;
  const bool on = g->grid->tree().probeValue(c, v);
  if (active) *active = on ? 1 : 0;
  return v;
}

extern "C" void mgs_vdb_values(const mgs_vdb_grid *g, size_t n, const int32_t *ijk, float *values, uint8_t *active) {
  mgs_vdb_detail::parallel_for(0, n, 4096, [&](size_t b, size_t e) {
    auto acc = g->grid->getConstAccessor();
    for (size_t i = b; i < e; i++) {
      const Coord c(ijk[3 * i], ijk[3 * i + 1], ijk[3 * i + 2]);
      float v = 0;
      const bool on = acc.probeValue(c, v);
      values[i] = v;
      if (active) active[i] = on ? 1 : 0;
    }
  });
}

extern "C" void mgs_vdb_index_to_world(const mgs_vdb_grid *g, const double ijk[3], double xyz[3]) {
  Vec3d w = g->grid->transform().indexToWorld(Vec3d(ijk[0], ijk[1], ijk[2]));
  xyz[0] = w[0]; xyz[1] = w[1]; xyz[2] = w[2];
}
extern "C" void mgs_vdb_world_to_index(const mgs_vdb_grid *g, const double xyz[3], double ijk[3]) {
  Vec3d u = g->grid->transform().worldToIndex(Vec3d(xyz[0], xyz[1], xyz[2]));
  ijk[0] = u[0]; ijk[1] = u[1]; ijk[2] = u[2];
}

namespace {
template <class Acc>
inline float corner_grad(Acc &acc, const Coord &c, int axis, float inv2h) {
  Coord p = c, m = c;
  p[axis] += 1;
  m[axis] -= 1;
  return (acc.getValue(p) - acc.getValue(m)) * inv2h;
}

template <bool Grad>
void sample_impl(const mgs_vdb_grid *g, size_t n, const float *xyz, float *grad, float *values) {
  const math::Transform &xf = g->grid->transform();
  const float inv2h = (float)(0.5 / g->grid->voxelSize()[0]);
  mgs_vdb_detail::parallel_for(0, n, 1024, [&](size_t b, size_t e) {
    auto acc = g->grid->getConstAccessor();
    for (size_t i = b; i < e; i++) {
      const Vec3d u = xf.worldToIndex(Vec3d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]));
      const Coord c0((int32_t)std::floor(u[0]), (int32_t)std::floor(u[1]), (int32_t)std::floor(u[2]));
      const double f[3] = {u[0] - c0[0], u[1] - c0[1], u[2] - c0[2]};
      double v = 0, gr[3] = {0, 0, 0};
      for (int corner = 0; corner < 8; corner++) {
        const int dx = corner >> 2, dy = (corner >> 1) & 1, dz = corner & 1;
        const double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
        const Coord c = c0.offsetBy(dx, dy, dz);
        if (values || !Grad) v += w * acc.getValue(c);
        if (Grad)
          for (int a = 0; a < 3; a++) gr[a] += w * corner_grad(acc, c, a, inv2h);
      }
      if (values) values[i] = (float)v;
      if (Grad)
        for (int a = 0; a < 3; a++) grad[3 * i + a] = (float)gr[a];
    }
  });
}
}  // namespace

extern "C" void mgs_vdb_sample(const mgs_vdb_grid *g, size_t n, const float *xyz, float *values) {
  sample_impl<false>(g, n, xyz, nullptr, values);
}
extern "C" void mgs_vdb_sample_gradient(const mgs_vdb_grid *g, size_t n, const float *xyz, float *grad, float *values) {
  sample_impl<true>(g, n, xyz, grad, values);
}

extern "C" mgs_status mgs_vdb_leaf_changes(const mgs_vdb_grid *before, const mgs_vdb_grid *after, float tol,
                                           mgs_vdb_leaf_change **out, size_t *n, mgs_error *err) {
  *out = nullptr;
  *n = 0;
  if (before->grid->transform() != after->grid->transform())
    return mgs_error_set(err, MGS_ERR_ARG, "leaf changes: the two grids have different transforms");
  const FloatTree &ta = before->grid->tree(), &tb = after->grid->tree();
  std::vector<const LeafT *> la, lb;
  for (auto it = ta.cbeginLeaf(); it; ++it) la.push_back(it.getLeaf());
  for (auto it = tb.cbeginLeaf(); it; ++it) lb.push_back(it.getLeaf());
  // For every leaf of `before`: kind and diff (-1 = unchanged).
  std::vector<mgs_vdb_leaf_change> ca(la.size());
  std::vector<int8_t> keep(la.size(), 0);
  mgs_vdb_detail::parallel_for(0, la.size(), 64, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; i++) {
      const LeafT *a = la[i];
      const Coord o = a->origin();
      mgs_vdb_leaf_change &c = ca[i];
      c.origin[0] = o[0]; c.origin[1] = o[1]; c.origin[2] = o[2];
      c.max_diff = 0;
      const LeafT *bl = tb.probeConstLeaf(o);
      if (!bl) { c.kind = MGS_VDB_LEAF_REMOVED; keep[i] = 1; continue; }
      c.kind = MGS_VDB_LEAF_CHANGED;
      const float *va = a->buffer().data(), *vb = bl->buffer().data();
      float md = 0;
      for (int k = 0; k < 512; k++) {
        const float d = std::fabs(va[k] - vb[k]);
        if (!(d <= md)) md = d;  // NaN counts as a change
      }
      c.max_diff = md;
      keep[i] = (md > tol || std::isnan(md) || a->getValueMask() != bl->getValueMask()) ? 1 : 0;
    }
  });
  std::vector<mgs_vdb_leaf_change> res;
  for (size_t i = 0; i < la.size(); i++)
    if (keep[i]) res.push_back(ca[i]);
  for (const LeafT *b : lb) {
    const Coord o = b->origin();
    if (!ta.probeConstLeaf(o)) res.push_back(mgs_vdb_leaf_change{{o[0], o[1], o[2]}, MGS_VDB_LEAF_ADDED, 0.0f});
  }
  std::sort(res.begin(), res.end(), [](const mgs_vdb_leaf_change &x, const mgs_vdb_leaf_change &y) {
    return std::lexicographical_compare(x.origin, x.origin + 3, y.origin, y.origin + 3);
  });
  if (!res.empty()) {
    *out = static_cast<mgs_vdb_leaf_change *>(std::malloc(res.size() * sizeof(mgs_vdb_leaf_change)));
    if (!*out) return mgs_error_set(err, MGS_ERR_NOMEM, "leaf changes: out of memory");
    std::memcpy(*out, res.data(), res.size() * sizeof(mgs_vdb_leaf_change));
  }
  *n = res.size();
  return MGS_OK;
}
