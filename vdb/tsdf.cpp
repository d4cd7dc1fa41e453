// TSDF fusion into sparse OpenVDB trees (value + weight, same topology) and the level set
// of its zero crossing (mgs_vdb_tsdf.h). Blocks are allocated from the views' rays
// (parallel over views, per-thread key lists), then every block is fused against all the
// views of the batch (parallel over blocks: each block is written by one thread only).
#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/ValueTransformer.h>
#include <algorithm>
#include <cmath>
#include <vector>
#include "core/mgs_log.h"
#include "vdb/mgs_vdb_tsdf.h"
#include "vdb/vdb_internal.hpp"

using namespace openvdb;

struct mgs_vdb_tsdf {
  mgs_vdb_tsdf_params p;
  math::Transform::Ptr xf;
  FloatTree::Ptr value, weight;
  // with truncation_thin: the narrow fusion and the views seeing a voxel as clearly free
  FloatTree::Ptr thin_value, thin_weight, free_views;
  mutable size_t thin_voxels = 0;  // voxels the last level set took from the narrow fusion
};

namespace {

struct View {
  const mgs_camera *cam;
  const float *depth;
};

// Ray length per unit of camera z through the centre of pixel (px, py).
inline double ray_scale(const mgs_camera &c, int px, int py) {
  const double a = (px + 0.5 - c.cx) / c.fx, b = (py + 0.5 - c.cy) / c.fy;
  return std::sqrt(1 + a * a + b * b);
}

inline double back_truncation(const mgs_vdb_tsdf_params &p) {
  return p.truncation_back > 0 ? p.truncation_back : p.truncation;
}

inline bool valid_depth(float d) { return d > 0 && std::isfinite(d); }

// Keys (origin / 8) of the blocks the segment of each valid pixel's ray within the
// truncation of its depth passes through (sampled every half voxel).
void collect_blocks(const mgs_vdb_tsdf &t, const View &v, std::vector<Coord> &keys, size_t &pixels) {
  const mgs_camera &c = *v.cam;
  const double h = t.p.voxel_size, tr = t.p.truncation, tb = back_truncation(t.p);
  const double *R = c.c2w;  // row-major: world = R x + translation
  for (int py = 0; py < c.height; py++)
    for (int px = 0; px < c.width; px++) {
      const float d = v.depth[(size_t)py * c.width + px];
      if (!valid_depth(d)) continue;
      pixels++;
      const double m = ray_scale(c, px, py), dz = tr / m, dzb = tb / m;  // -t_back <= (d - z) m <= t
      const double a = (px + 0.5 - c.cx) / c.fx, b = (py + 0.5 - c.cy) / c.fy;
      const double dir[3] = {R[0] * a + R[1] * b + R[2], R[4] * a + R[5] * b + R[6], R[8] * a + R[9] * b + R[10]};
      const double z0 = std::max((double)d - dz, 1e-6), z1 = (double)d + dzb;
      const int steps = (int)std::ceil((z1 - z0) * m / (0.5 * h)) + 1;
      Coord last(INT32_MAX, 0, 0);
      for (int s = 0; s <= steps; s++) {
        const double z = z0 + (z1 - z0) * s / steps;
        Coord k;
        for (int i = 0; i < 3; i++) {
          const double w = R[4 * i + 3] + z * dir[i];
          k[i] = (Int32)std::floor((w - t.p.origin[i]) / h + 0.5) >> 3;
        }
        if (k != last) keys.push_back(k), last = k;
      }
    }
}

// Does the block with index origin o possibly project into the view's image?
bool block_seen(const mgs_vdb_tsdf &t, const mgs_camera &c, const Coord &o) {
  const double h = t.p.voxel_size, rad = std::sqrt(3.0) * 4 * h;
  double w[3], pc[3];
  for (int i = 0; i < 3; i++) w[i] = t.p.origin[i] + (o[i] + 3.5) * h;
  mgs_camera_world_to_cam(&c, w, pc);
  if (pc[2] + rad <= 0) return false;
  if (pc[2] - rad <= 0) return true;
  const double zr = pc[2] - rad;
  const double u = c.fx * pc[0] / pc[2] + c.cx, v = c.fy * pc[1] / pc[2] + c.cy;
  const double ru = c.fx * rad / zr * 1.5 + 1, rv = c.fy * rad / zr * 1.5 + 1;
  return u + ru >= 0 && u - ru <= c.width && v + rv >= 0 && v - rv <= c.height;
}

struct BlockLeaves {
  FloatTree::LeafNodeType *d, *w, *td, *tw, *fv;  // td/tw/fv: NULL without truncation_thin
};

void fuse_block(const mgs_vdb_tsdf &t, const std::vector<View> &views, const BlockLeaves &b) {
  FloatTree::LeafNodeType &dl = *b.d, &wl = *b.w;
  const double h = t.p.voxel_size;
  const float tr = (float)t.p.truncation, tb = (float)back_truncation(t.p), tn = (float)t.p.truncation_thin;
  const Coord o = dl.origin();
  for (const View &v : views) {
    const mgs_camera &c = *v.cam;
    if (!block_seen(t, c, o)) continue;
    const double *M = c.w2c;
    for (auto it = dl.beginValueAll(); it; ++it) {
      const Coord ijk = it.getCoord();
      double w[3];
      for (int i = 0; i < 3; i++) w[i] = t.p.origin[i] + ijk[i] * h;
      const double z = M[8] * w[0] + M[9] * w[1] + M[10] * w[2] + M[11];
      if (!(z > 0)) continue;
      const double x = M[0] * w[0] + M[1] * w[1] + M[2] * w[2] + M[3];
      const double y = M[4] * w[0] + M[5] * w[1] + M[6] * w[2] + M[7];
      const double u = c.fx * x / z + c.cx, vv = c.fy * y / z + c.cy;
      if (!(u >= 0 && u < c.width && vv >= 0 && vv < c.height)) continue;
      const int px = (int)u, py = (int)vv;
      const float d = v.depth[(size_t)py * c.width + px];
      // d < 0: a background pixel, free space along its whole ray (carving)
      const double sdf = d < 0 ? (double)tr : valid_depth(d) ? ((double)d - z) * ray_scale(c, px, py) : NAN;
      const Index off = it.pos();
      if (b.td && sdf > -tn) {
        const float val = (float)std::min(sdf, (double)tn);
        const float W = b.tw->getValue(off), D = b.td->getValue(off);
        b.td->setValueOn(off, (D * W + val) / (W + 1));
        b.tw->setValueOn(off, W + 1);
        if (sdf > 2.0 * tn) b.fv->setValueOn(off, b.fv->getValue(off) + 1);
      }
      if (!(sdf > -tb)) continue;
      const float val = (float)std::min(sdf, (double)tr);
      const float W = wl.getValue(off), D = dl.getValue(off);
      dl.setValueOn(off, (D * W + val) / (W + 1));
      wl.setValueOn(off, W + 1);
    }
  }
}

// Thin parts: voxels the wide fusion calls inside although enough views see them as
// clearly free (the two sides of a part thinner than the truncation fused into one slab),
// grown by the wide truncation (the slab's reach), take the narrow fusion's value (scaled
// to the wide truncation, so the level set's field 1/2 - D/(2t) keeps its zero) and weight.
// value/weight become copies when anything is switched.
void thin_parts(const mgs_vdb_tsdf &t, float min_weight, FloatTree::Ptr &value, FloatTree::Ptr &weight) {
  const float min_views = t.p.thin_free_views > 0 ? (float)t.p.thin_free_views : 2.0f;
  const float share = t.p.thin_free_share > 0 ? (float)t.p.thin_free_share : 0.5f;
  MaskTree conflict(false);
  {
    tree::ValueAccessor<const FloatTree> va(*t.value), fa(*t.free_views);
    tree::ValueAccessor<MaskTree> ca(conflict);
    for (auto it = t.weight->cbeginValueOn(); it; ++it) {
      if (!(*it >= min_weight)) continue;
      const Coord c = it.getCoord();
      const float f = fa.getValue(c);
      if (va.getValue(c) < 0 && f >= min_views && f >= share * *it) ca.setValueOn(c);
    }
  }
  if (conflict.activeVoxelCount() == 0) return;
  const int grow = (int)std::ceil(t.p.truncation / t.p.voxel_size) + 1;
  tools::dilateActiveValues(conflict, grow, tools::NN_FACE_EDGE_VERTEX, tools::IGNORE_TILES);
  auto v = std::make_shared<FloatTree>(*t.value), w = std::make_shared<FloatTree>(*t.weight);
  tree::ValueAccessor<FloatTree> va(*v), wa(*w);
  tree::ValueAccessor<const FloatTree> tva(*t.thin_value), twa(*t.thin_weight);
  const float scale = (float)(t.p.truncation / t.p.truncation_thin);
  size_t n = 0;
  for (auto it = conflict.cbeginValueOn(); it; ++it) {
    const Coord c = it.getCoord();
    if (!wa.isValueOn(c) && !twa.isValueOn(c)) continue;
    const float tw = twa.getValue(c);
    if (tw > 0) {
      va.setValueOn(c, tva.getValue(c) * scale);
      wa.setValueOn(c, tw);
    } else {  // unobserved at the narrow truncation: left to the inside fill
      va.setValueOff(c, (float)t.p.truncation);
      wa.setValueOff(c, 0.0f);
    }
    n++;
  }
  t.thin_voxels = n;
  value = v;
  weight = w;
}

}  // namespace

extern "C" size_t mgs_vdb_tsdf_thin_voxels(const mgs_vdb_tsdf *t) { return t ? t->thin_voxels : 0; }

extern "C" mgs_status mgs_vdb_tsdf_create(const mgs_vdb_tsdf_params *p, mgs_vdb_tsdf **out, mgs_error *err) {
  *out = nullptr;
  if (!p || !(p->voxel_size > 0) || !std::isfinite(p->voxel_size) || !(p->truncation >= p->voxel_size) ||
      !std::isfinite(p->truncation))
    return mgs_error_set(err, MGS_ERR_ARG, "tsdf: voxel size %g and truncation %g: need 0 < voxel <= truncation",
                         p ? p->voxel_size : 0.0, p ? p->truncation : 0.0);
  if (p->truncation_thin != 0 &&
      !(p->truncation_thin >= p->voxel_size && p->truncation_thin <= p->truncation && std::isfinite(p->truncation_thin)))
    return mgs_error_set(err, MGS_ERR_ARG, "tsdf: thin-part truncation %g: need voxel %g <= it <= truncation %g (or 0)",
                         p->truncation_thin, p->voxel_size, p->truncation);
  if (!(p->thin_free_views == 0 || (p->thin_free_views >= 1 && std::isfinite(p->thin_free_views))) ||
      !(p->thin_free_share >= 0 && p->thin_free_share <= 1))
    return mgs_error_set(err, MGS_ERR_ARG, "tsdf: thin-part views %g / share %g: need views >= 1 (or 0), share in [0, 1]",
                         p->thin_free_views, p->thin_free_share);
  if (p->truncation_back != 0 &&
      !(p->truncation_back >= p->voxel_size && p->truncation_back <= p->truncation && std::isfinite(p->truncation_back)))
    return mgs_error_set(err, MGS_ERR_ARG, "tsdf: back truncation %g: need voxel %g <= it <= truncation %g (or 0)",
                         p->truncation_back, p->voxel_size, p->truncation);
  for (int i = 0; i < 3; i++)
    if (!std::isfinite(p->origin[i])) return mgs_error_set(err, MGS_ERR_ARG, "tsdf: origin not finite");
  mgs_vdb_detail::init();
  try {
    auto *t = new mgs_vdb_tsdf;
    t->p = *p;
    t->xf = mgs_vdb_detail::make_transform(p->voxel_size, p->origin);
    t->value = std::make_shared<FloatTree>((float)p->truncation);
    t->weight = std::make_shared<FloatTree>(0.0f);
    if (p->truncation_thin > 0) {
      t->thin_value = std::make_shared<FloatTree>((float)p->truncation_thin);
      t->thin_weight = std::make_shared<FloatTree>(0.0f);
      t->free_views = std::make_shared<FloatTree>(0.0f);
    }
    *out = t;
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "tsdf: %s", e.what());
  }
  return MGS_OK;
}

extern "C" void mgs_vdb_tsdf_destroy(mgs_vdb_tsdf *t) { delete t; }

extern "C" mgs_status mgs_vdb_tsdf_integrate(mgs_vdb_tsdf *t, size_t n, const mgs_camera *cams, const float *const *depth,
                                             mgs_vdb_tsdf_info *info, mgs_error *err) {
  if (!t || (n && (!cams || !depth))) return mgs_error_set(err, MGS_ERR_ARG, "tsdf: null argument");
  std::vector<View> views;
  for (size_t k = 0; k < n; k++) {
    if (!depth[k] || cams[k].width <= 0 || cams[k].height <= 0 || !(cams[k].fx > 0) || !(cams[k].fy > 0))
      return mgs_error_set(err, MGS_ERR_ARG, "tsdf: view %zu: no depth map or invalid camera", k);
    views.push_back(View{&cams[k], depth[k]});
  }
  try {
    const int nt = std::max(1, mgs_parallel_max_threads());
    std::vector<std::vector<Coord>> keys(nt);
    std::vector<size_t> pix(views.size(), 0);
    mgs_vdb_detail::parallel_for(0, views.size(), 1, [&](size_t b, size_t e) {
      auto &k = keys[mgs_parallel_thread_index() % nt];
      for (size_t i = b; i < e; i++) collect_blocks(*t, views[i], k, pix[i]);
    });
    std::vector<View> used;
    size_t pixels = 0;
    for (size_t i = 0; i < views.size(); i++) {
      bool carves = false;  // a view of background pixels only still carves the blocks others allocated
      const size_t np = (size_t)views[i].cam->width * views[i].cam->height;
      for (size_t p = 0; !pix[i] && !carves && p < np; p++) carves = views[i].depth[p] < 0;
      if (pix[i] || carves) used.push_back(views[i]), pixels += pix[i];
    }
    for (auto &k : keys)
      for (const Coord &c : k) {
        const Coord o(c[0] * 8, c[1] * 8, c[2] * 8);
        t->value->touchLeaf(o);
        t->weight->touchLeaf(o);
        if (t->thin_value) t->thin_value->touchLeaf(o), t->thin_weight->touchLeaf(o), t->free_views->touchLeaf(o);
      }
    keys.clear();
    std::vector<BlockLeaves> dl;
    for (auto it = t->value->beginLeaf(); it; ++it) {
      const Coord o = it->origin();
      BlockLeaves b{&*it, t->weight->probeLeaf(o), nullptr, nullptr, nullptr};
      if (t->thin_value) b.td = t->thin_value->probeLeaf(o), b.tw = t->thin_weight->probeLeaf(o), b.fv = t->free_views->probeLeaf(o);
      dl.push_back(b);
    }
    if (!used.empty())
      mgs_vdb_detail::parallel_for(0, dl.size(), 4, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; i++) fuse_block(*t, used, dl[i]);
      });
    if (info) {
      info->views_used = used.size();
      info->pixels_used = pixels;
      info->blocks = dl.size();
      info->voxels_observed = (size_t)t->weight->activeVoxelCount();
    }
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "tsdf: %s", e.what());
  }
  return MGS_OK;
}

extern "C" mgs_status mgs_vdb_tsdf_grids(const mgs_vdb_tsdf *t, mgs_vdb_grid **tsdf, mgs_vdb_grid **weight,
                                         mgs_error *err) {
  if (tsdf) *tsdf = nullptr;
  if (weight) *weight = nullptr;
  try {
    for (int k = 0; k < 2; k++) {
      mgs_vdb_grid **o = k ? weight : tsdf;
      if (!o) continue;
      auto g = FloatGrid::create(std::make_shared<FloatTree>(k ? *t->weight : *t->value));
      g->setTransform(t->xf->copy());
      g->setName(k ? "tsdf_weight" : "tsdf");
      g->setGridClass(GRID_UNKNOWN);
      *o = mgs_vdb_detail::wrap(g);
      if (!*o) throw std::bad_alloc();
    }
  } catch (const std::exception &e) {
    if (tsdf) mgs_vdb_grid_destroy(*tsdf), *tsdf = nullptr;
    return mgs_error_set(err, MGS_ERR_NOMEM, "tsdf grids: %s", e.what());
  }
  return MGS_OK;
}

extern "C" mgs_status mgs_vdb_tsdf_to_sdf(const mgs_vdb_tsdf *t, int half_width, float min_weight, mgs_vdb_grid **out,
                                          mgs_error *err) {
  *out = nullptr;
  if (half_width < 1 || half_width > 1000)
    return mgs_error_set(err, MGS_ERR_ARG, "tsdf: band half-width %d outside [1, 1000] voxels", half_width);
  const float tr = (float)t->p.truncation;
  try {
    FloatTree::Ptr value = t->value, weight = t->weight;
    t->thin_voxels = 0;
    if (t->thin_value) thin_parts(*t, min_weight, value, weight);
    // observed (weight >= min_weight) voxels, split by sign
    MaskTree obs(false), pos(false), neg(false);
    {
      tree::ValueAccessor<const FloatTree> va(*value);
      tree::ValueAccessor<MaskTree> oa(obs), pa(pos), na(neg);
      for (auto it = weight->cbeginValueOn(); it; ++it) {
        if (!(*it >= min_weight)) continue;
        const Coord c = it.getCoord();
        oa.setValueOn(c);
        (va.getValue(c) < 0 ? na : pa).setValueOn(c);
      }
    }
    if (obs.activeVoxelCount() == 0)
      return mgs_error_set(err, MGS_ERR_FORMAT, "tsdf: no voxel was observed (by %g views or more)", (double)min_weight);
    if (neg.activeVoxelCount() == 0)
      return mgs_error_set(err, MGS_ERR_FORMAT,
                           "tsdf: no observed voxel lies behind a depth: the fused volume has no surface");
    // The inside behind the truncation is unobserved: fill it from the observed inside
    // through unobserved voxels only (never through observed outside), inside the box of
    // the observed voxels. Per connected region of {unobserved or observed inside} in the
    // box: a region the observed outside encloses (a closed fused surface) is inside
    // whole; a region that reaches the box's margin (an open shell, unseen sides, or a
    // fragment fused from a floater) gets only its observed inside grown by w + 9 voxels
    // (to cover the band's leaves; no flood to the box, which would leak to all of space).
    // Regions are separate, so one open fragment leaves a closed object's inside whole.
    CoordBBox box;
    obs.evalActiveVoxelBoundingBox(box);
    box.expand(1);
    auto inside = std::make_unique<MaskTree>(neg);
    const size_t neg_total = (size_t)neg.activeVoxelCount();
    size_t open_neg = 0, open_regions = 0;
    const double box_voxels = (double)box.dim().x() * box.dim().y() * box.dim().z();
    auto grow_open = [&](MaskTree &seeds, const BoolTree *within) {
      for (int k = 0; k < half_width + 9; k++) {
        tools::dilateActiveValues(seeds, 1, tools::NN_FACE, tools::IGNORE_TILES);
        seeds.topologyDifference(pos);
        if (within) seeds.topologyIntersection(*within);
      }
      inside->topologyUnion(seeds);
    };
    if (box_voxels <= 1e8) {
      BoolTree region(false);
      region.fill(box, true, true);
      region.topologyDifference(pos);
      region.voxelizeActiveTiles();  // segmentActiveVoxels labels leaf voxels only: a tile would be left out
      std::vector<BoolTree::Ptr> parts;
      tools::segmentActiveVoxels(region, parts);
      for (const auto &part : parts) {
        MaskTree seeds(neg);
        seeds.topologyIntersection(*part);
        const size_t nn = (size_t)seeds.activeVoxelCount();
        if (nn == 0) continue;  // a pocket of unobserved space with no observed inside: outside
        CoordBBox pb;
        part->evalActiveVoxelBoundingBox(pb);
        const bool open = pb.min().x() <= box.min().x() || pb.min().y() <= box.min().y() || pb.min().z() <= box.min().z() ||
                          pb.max().x() >= box.max().x() || pb.max().y() >= box.max().y() || pb.max().z() >= box.max().z();
        if (!open) {
          inside->topologyUnion(*part);
          continue;
        }
        open_neg += nn;
        open_regions++;
        grow_open(seeds, part.get());
      }
    } else {  // a box too large to label (a scene, not an object): every region is taken as open
      MaskTree seeds(neg);
      grow_open(seeds, nullptr);
      open_neg = neg_total;
      open_regions = 1;
    }
    if (open_neg > neg_total / 10)
      mgs_warn("tsdf: the fused surface is not closed (its inside reaches unobserved space): the inside is filled "
               "only %d voxels deep; persistence may see a cavity", half_width + 9);
    else if (open_regions)
      mgs_info("tsdf: %zu open fragment(s) (%.2g %% of the observed inside) filled only %d voxels deep; the rest "
               "is closed", open_regions, 100.0 * (double)open_neg / (double)neg_total, half_width + 9);
    // 1/2 - D/(2t) on observed voxels (> 1/2 inside), 1 on the grown inside, 0 elsewhere.
    auto field = std::make_shared<FloatTree>(0.0f);
    {
      tree::ValueAccessor<const FloatTree> va(*value);
      tree::ValueAccessor<FloatTree> fa(*field);
      tree::ValueAccessor<const MaskTree> ob(obs);
      const float inv = 1.0f / (2 * tr);
      for (auto it = obs.cbeginValueOn(); it; ++it) fa.setValue(it.getCoord(), 0.5f - va.getValue(it.getCoord()) * inv);
      for (auto it = inside->cbeginValueOn(); it; ++it)
        if (!ob.isValueOn(it.getCoord())) fa.setValue(it.getCoord(), 1.0f);
    }
    auto g = FloatGrid::create(field);
    g->setTransform(t->xf->copy());
    g->setGridClass(GRID_FOG_VOLUME);
    mgs_vdb_grid a;
    a.grid = g;
    // Every crossing of this field is seeded (a blob's or an open fill's too: they become
    // surfaces, not sign flips without distances), so the band is valid everywhere.
    mgs_vdb_sdf_params sp;
    mgs_vdb_sdf_params_default(&sp);
    sp.tau = 0.5;
    sp.half_width = half_width;
    sp.method = MGS_VDB_SDF_CLOSEST;
    return mgs_vdb_sdf_from_alpha(&a, &sp, out, err);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "tsdf: %s", e.what());
  }
}
