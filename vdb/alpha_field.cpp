// The α-field A(x) = Σ αᵢ exp(−½(x−μᵢ)ᵀΣᵢ⁻¹(x−μᵢ)) rasterized into a sparse FloatGrid.
//
// Parallel by leaf partition (deterministic, no per-thread trees to merge):
//   1. per Gaussian (parallel): filtered covariance, index-space inverse, kσ box, the
//      8³ leaves the box overlaps;
//   2. (leaf key, Gaussian) pairs, sorted by (key, Gaussian) so every leaf sums its
//      contributions in the same order on every run;
//   3. per leaf (parallel): the leaf's Gaussians visit only the voxels inside their kσ
//      ellipsoid (z-range of each row solved from the quadratic form), summing into the
//      leaf buffer; those voxels become active;
//   4. leaves are attached to the tree serially (cheap).
// Memory: the pair list is checked against the budget before it is allocated and the
// leaves after the exact leaf count is known, so an oversized resolution is refused
// with the estimate instead of exhausting the machine.
#include <openvdb/openvdb.h>
#include <tbb/parallel_sort.h>
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <unordered_map>
#include <vector>
#include "core/mgs_log.h"
#include "core/mgs_math.h"
#include "vdb/vdb_internal.hpp"

using namespace openvdb;

// The last build's leaves by key, for mgs_vdb_alpha_field_cached: a leaf whose Gaussians'
// prepared parameters (in index order) hash as before, at the same voxel size, lattice and
// support, is copied instead of recomputed.
struct mgs_vdb_alpha_cache {
  struct Leaf {
    uint64_t hash;
    float v[512];
    uint64_t mask[8];
  };
  double h = 0, shift[3] = {0, 0, 0};
  double k_sigma = 0;
  int small = -1;
  std::unordered_map<uint64_t, Leaf> leaves;
};

namespace {

constexpr int kLeafBits = 21;               // bits per leaf coordinate in a key
constexpr int64_t kLeafBias = 1 << 20;       // leaf coordinates in [-2^20, 2^20)
constexpr double kMaxIndex = 8.0e6;          // |ijk| limit (2^23 voxels per axis)
constexpr double kLeafBytes = 512 * 4 + 64 + 80;  // values + mask + node overhead

struct Prepared {
  double c[3];     // centre in index space
  float m[6];      // index-space inverse covariance (xx, xy, xz, yy, yz, zz)
  float amp;       // filtered amplitude
  int32_t lo[3], hi[3];  // voxel box (inclusive); lo > hi: touches no voxel
};

struct Pair {
  uint64_t key;
  uint32_t idx;
  bool operator<(const Pair &o) const { return key != o.key ? key < o.key : idx < o.idx; }
};

inline int32_t floordiv8(int32_t v) { return v >> 3; }  // arithmetic shift = floor

inline uint64_t leaf_key(int64_t lx, int64_t ly, int64_t lz) {
  return ((uint64_t)(lx + kLeafBias) << (2 * kLeafBits)) | ((uint64_t)(ly + kLeafBias) << kLeafBits) |
         (uint64_t)(lz + kLeafBias);
}
inline Coord key_origin(uint64_t key) {
  const uint64_t mask = (1ull << kLeafBits) - 1;
  return Coord((int32_t)((int64_t)((key >> (2 * kLeafBits)) & mask) - kLeafBias) * 8,
               (int32_t)((int64_t)((key >> kLeafBits) & mask) - kLeafBias) * 8,
               (int32_t)((int64_t)(key & mask) - kLeafBias) * 8);
}

uint64_t fnv(uint64_t h, const void *p, size_t n) {
  const unsigned char *b = static_cast<const unsigned char *>(p);
  for (size_t i = 0; i < n; i++) { h ^= b[i]; h *= 1099511628211ull; }
  return h;
}

uint64_t hash_prepared(uint64_t h, const Prepared &g) {
  h = fnv(h, g.c, sizeof g.c);
  h = fnv(h, g.m, sizeof g.m);
  h = fnv(h, &g.amp, sizeof g.amp);
  h = fnv(h, g.lo, sizeof g.lo);
  return fnv(h, g.hi, sizeof g.hi);
}

double physical_memory() {
  long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? (double)pages * (double)size : 8.0 * (1ull << 30);
}

// Clamps the eigenvalues of a symmetric 3x3 (full row-major) to max_var; true if any was.
bool cap_covariance(double cov[9], double max_var) {
  double w[3], V[9];
  mgs_sym3_eigen(cov, w, V);
  if (std::max(w[0], std::max(w[1], w[2])) <= max_var) return false;
  for (int k = 0; k < 3; k++) w[k] = std::min(std::max(w[k], 0.0), max_var);
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++)
      cov[3 * a + b] = V[3 * a] * V[3 * b] * w[0] + V[3 * a + 1] * V[3 * b + 1] * w[1] + V[3 * a + 2] * V[3 * b + 2] * w[2];
  return true;
}

// Source of Gaussians: mean, full covariance (row-major 3x3), opacity.
struct Source {
  size_t n;
  void (*get)(const void *ctx, size_t i, double mean[3], double cov[9], double *alpha);
  const void *ctx;
  const float *mean;  // for the bounding box
};

mgs_status build(const Source &src, const mgs_vdb_alpha_params *pin, mgs_vdb_grid **out,
                 mgs_vdb_build_info *info_out, mgs_error *err, mgs_vdb_alpha_cache *cache = nullptr) {
  *out = nullptr;
  const double t0 = mgs_now();
  mgs_vdb_alpha_params p;
  if (pin) p = *pin; else mgs_vdb_alpha_params_default(&p);
  if (!(p.k_sigma > 0) || p.k_sigma > 10)
    return mgs_error_set(err, MGS_ERR_ARG, "alpha field: k-sigma %g outside (0, 10]", p.k_sigma);
  if (p.voxel_size <= 0 && p.resolution <= 0)
    return mgs_error_set(err, MGS_ERR_ARG, "alpha field: resolution %d must be positive", p.resolution);
  if (p.voxel_size < 0 || !std::isfinite(p.voxel_size))
    return mgs_error_set(err, MGS_ERR_ARG, "alpha field: voxel size %g invalid", p.voxel_size);
  if (src.n == 0) return mgs_error_set(err, MGS_ERR_FORMAT, "alpha field: the scene has no Gaussians");
  if (src.n > 0xffffffffull) return mgs_error_set(err, MGS_ERR_UNSUPPORTED, "alpha field: more than 2^32 Gaussians");
  const double budget = p.memory_budget > 0 ? p.memory_budget : 0.6 * physical_memory();

  mgs_vdb_build_info info;
  std::memset(&info, 0, sizeof info);
  // Scene box of the means.
  for (int a = 0; a < 3; a++) info.scene_lo[a] = info.scene_hi[a] = src.mean[a];
  for (size_t i = 1; i < src.n; i++)
    for (int a = 0; a < 3; a++) {
      double v = src.mean[3 * i + a];
      info.scene_lo[a] = std::min(info.scene_lo[a], v);
      info.scene_hi[a] = std::max(info.scene_hi[a], v);
    }
  double diag = 0;
  for (int a = 0; a < 3; a++) diag += (info.scene_hi[a] - info.scene_lo[a]) * (info.scene_hi[a] - info.scene_lo[a]);
  diag = std::sqrt(diag);
  if (!std::isfinite(diag)) return mgs_error_set(err, MGS_ERR_NUMERIC, "alpha field: non-finite means");
  double h = p.voxel_size;
  if (h <= 0) {
    double d = diag;
    if (!(d > 0)) {  // a single point: the Gaussians' own extent sets the scale
      for (size_t i = 0; i < src.n; i++) {
        double m[3], cov[9], al;
        src.get(src.ctx, i, m, cov, &al);
        d = std::max(d, 2 * p.k_sigma * std::sqrt(cov[0] + cov[4] + cov[8]));
      }
    }
    if (!(d > 0) || !std::isfinite(d))
      return mgs_error_set(err, MGS_ERR_NUMERIC, "alpha field: the scene has zero extent; give --voxel-size");
    h = d / p.resolution;
  }
  info.voxel_size = h;
  // The grid is translated to the scene centre, so index coordinates stay small for scenes
  // far from the origin (SPEC §7: 1e5 offsets). Snapped to 64 voxels, not one: a centre that
  // drifts as Gaussians move keeps the same lattice, so a cached build's leaves still apply.
  double shift[3];
  for (int a = 0; a < 3; a++) shift[a] = 64.0 * h * std::round(0.5 * (info.scene_lo[a] + info.scene_hi[a]) / (64.0 * h));
  const double lp = (p.small == MGS_VDB_SMALL_NONE) ? 0.0 : 0.25 * h * h;  // (h/2)²
  const double max_var = diag > 0 ? diag * diag : INFINITY;
  const float k2 = (float)(p.k_sigma * p.k_sigma);

  // 1. Prepare every Gaussian.
  std::vector<Prepared> prep;
  std::vector<uint64_t> nleaves;
  try {
    prep.resize(src.n);
    nleaves.resize(src.n + 1);
  } catch (const std::bad_alloc &) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: cannot allocate for %zu Gaussians", src.n);
  }
  std::atomic<size_t> capped{0}, bad{0}, out_of_range{0};
  mgs_vdb_detail::parallel_for(0, src.n, 1024, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; i++) {
      double mu[3], cov[9], al;
      src.get(src.ctx, i, mu, cov, &al);
      Prepared &g = prep[i];
      nleaves[i] = 0;
      g.lo[0] = g.lo[1] = g.lo[2] = 1;
      g.hi[0] = g.hi[1] = g.hi[2] = 0;
      g.amp = 0;
      if (!(al > 0)) continue;  // transparent: contributes nothing
      if (cov[0] + cov[4] + cov[8] > max_var && cap_covariance(cov, max_var)) capped++;
      const double det0 = cov[0] * (cov[4] * cov[8] - cov[5] * cov[7]) - cov[1] * (cov[3] * cov[8] - cov[5] * cov[6]) +
                          cov[2] * (cov[3] * cov[7] - cov[4] * cov[6]);
      double f[9];
      std::memcpy(f, cov, sizeof f);
      f[0] += lp; f[4] += lp; f[8] += lp;
      const double c00 = f[4] * f[8] - f[5] * f[7], c01 = f[2] * f[7] - f[1] * f[8], c02 = f[1] * f[5] - f[2] * f[4];
      const double c11 = f[0] * f[8] - f[2] * f[6], c12 = f[2] * f[3] - f[0] * f[5], c22 = f[0] * f[4] - f[1] * f[3];
      const double det = f[0] * c00 + f[1] * (f[5] * f[6] - f[3] * f[8]) + f[2] * (f[3] * f[7] - f[4] * f[6]);
      if (!(det > 0) || !std::isfinite(det)) { bad++; continue; }
      double amp = al;
      if (p.small == MGS_VDB_SMALL_MASS) amp *= std::sqrt(std::max(det0, 0.0) / det);
      g.amp = (float)amp;
      const double s = h * h / det;  // inverse in index units: (Σ')⁻¹ h²
      g.m[0] = (float)(c00 * s); g.m[1] = (float)(c01 * s); g.m[2] = (float)(c02 * s);
      g.m[3] = (float)(c11 * s); g.m[4] = (float)(c12 * s); g.m[5] = (float)(c22 * s);
      uint64_t cnt = 1;
      for (int a = 0; a < 3; a++) {
        g.c[a] = (mu[a] - shift[a]) / h;
        const double ext = p.k_sigma * std::sqrt(f[4 * a]) / h;
        if (std::fabs(g.c[a]) + ext > kMaxIndex) { out_of_range++; cnt = 0; break; }
        g.lo[a] = (int32_t)std::ceil(g.c[a] - ext);
        g.hi[a] = (int32_t)std::floor(g.c[a] + ext);
        if (g.lo[a] > g.hi[a]) { cnt = 0; break; }
        cnt *= (uint64_t)(floordiv8(g.hi[a]) - floordiv8(g.lo[a]) + 1);
      }
      if (cnt == 0) { g.lo[0] = 1; g.hi[0] = 0; }
      nleaves[i] = cnt;
    }
  });
  if (bad) mgs_warn("alpha field: %zu Gaussians with a singular covariance skipped", (size_t)bad);
  if (out_of_range)
    return mgs_error_set(err, MGS_ERR_NOMEM,
                         "alpha field: %zu Gaussians fall outside the index range at voxel size %g "
                         "(more than %.0f voxels from the origin); lower the resolution",
                         (size_t)out_of_range, h, kMaxIndex);
  info.gaussians_capped = capped;
  if (capped)
    mgs_warn("alpha field: %zu Gaussians larger than the scene (std-dev > diagonal %g) capped", (size_t)capped, diag);

  // Stage-1 budget: the pair list.
  double pairs_d = 0;
  for (size_t i = 0; i < src.n; i++) pairs_d += (double)nleaves[i];
  double est = pairs_d * sizeof(Pair) + (double)src.n * (sizeof(Prepared) + 8);
  if (est > budget)
    return mgs_error_set(err, MGS_ERR_NOMEM,
                         "alpha field: voxel size %g needs an estimated %.2f GiB (%.3g Gaussian-leaf "
                         "pairs) before any voxel is stored, over the memory budget of %.2f GiB; "
                         "lower the resolution",
                         h, est / (1u << 30), pairs_d, budget / (1u << 30));
  // Exclusive prefix sum of leaf counts.
  uint64_t total = 0;
  for (size_t i = 0; i < src.n; i++) { uint64_t c = nleaves[i]; nleaves[i] = total; total += c; }
  nleaves[src.n] = total;

  std::vector<Pair> pairs;
  try { pairs.resize(total); } catch (const std::bad_alloc &) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: cannot allocate %llu pairs", (unsigned long long)total);
  }
  mgs_vdb_detail::parallel_for(0, src.n, 1024, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; i++) {
      const Prepared &g = prep[i];
      uint64_t w = nleaves[i];
      if (nleaves[i + 1] == w) continue;
      for (int32_t lx = floordiv8(g.lo[0]); lx <= floordiv8(g.hi[0]); lx++)
        for (int32_t ly = floordiv8(g.lo[1]); ly <= floordiv8(g.hi[1]); ly++)
          for (int32_t lz = floordiv8(g.lo[2]); lz <= floordiv8(g.hi[2]); lz++) pairs[w++] = Pair{leaf_key(lx, ly, lz), (uint32_t)i};
    }
  });
  tbb::parallel_sort(pairs.begin(), pairs.end());

  // 2. Leaf runs.
  std::vector<size_t> runs;  // start index of each leaf's run, + total at the end
  for (size_t i = 0; i < pairs.size(); i++)
    if (i == 0 || pairs[i].key != pairs[i - 1].key) runs.push_back(i);
  const size_t nleaf = runs.size();
  runs.push_back(pairs.size());
  // Stage-2 budget: the leaves, plus as much again for the SDF built from them.
  est = pairs.size() * sizeof(Pair) + (double)src.n * sizeof(Prepared) + 2.0 * nleaf * kLeafBytes;
  info.estimated_bytes = est;
  if (est > budget)
    return mgs_error_set(err, MGS_ERR_NOMEM,
                         "alpha field: voxel size %g needs an estimated %.2f GiB (%zu leaves of 8^3 "
                         "voxels), over the memory budget of %.2f GiB; lower the resolution",
                         h, est / (1u << 30), nleaf, budget / (1u << 30));

  // 3. Fill leaves in parallel.
  using LeafT = FloatTree::LeafNodeType;
  std::vector<LeafT *> leaves(nleaf, nullptr);
  std::atomic<bool> nomem{false};
  const bool reuse = cache && cache->h == h && cache->k_sigma == p.k_sigma && cache->small == (int)p.small &&
                     cache->shift[0] == shift[0] && cache->shift[1] == shift[1] && cache->shift[2] == shift[2];
  std::vector<uint64_t> hashes(cache ? nleaf : 0);
  std::atomic<size_t> reused{0};
  mgs_vdb_detail::parallel_for(0, nleaf, 8, [&](size_t b, size_t e) {
    for (size_t L = b; L < e; L++) {
      const Coord o = key_origin(pairs[runs[L]].key);
      LeafT *leaf = new (std::nothrow) LeafT(o, 0.0f, false);
      if (!leaf) { nomem = true; continue; }
      float *buf = leaf->buffer().data();
      auto &mask = leaf->getValueMask();
      if (cache) {
        uint64_t hh = 1469598103934665603ull;
        for (size_t r = runs[L]; r < runs[L + 1]; r++) hh = hash_prepared(hh, prep[pairs[r].idx]);
        hashes[L] = hh;
        if (reuse) {
          auto it = cache->leaves.find(pairs[runs[L]].key);
          if (it != cache->leaves.end() && it->second.hash == hh) {
            std::memcpy(buf, it->second.v, sizeof it->second.v);
            for (int w = 0; w < 8; w++) mask.template getWord<uint64_t>(w) = it->second.mask[w];
            reused++;
            leaves[L] = leaf;
            continue;
          }
        }
      }
      for (size_t r = runs[L]; r < runs[L + 1]; r++) {
        const Prepared &g = prep[pairs[r].idx];
        const int32_t x0 = std::max(g.lo[0], o[0]), x1 = std::min(g.hi[0], o[0] + 7);
        const int32_t y0 = std::max(g.lo[1], o[1]), y1 = std::min(g.hi[1], o[1] + 7);
        const float mzz = g.m[5];
        for (int32_t x = x0; x <= x1; x++) {
          const float dx = (float)(x - g.c[0]);
          for (int32_t y = y0; y <= y1; y++) {
            const float dy = (float)(y - g.c[1]);
            // q(dz) = mzz dz² + 2 B dz + C  <=  k²
            const float B = g.m[2] * dx + g.m[4] * dy;
            const float C = g.m[0] * dx * dx + 2 * g.m[1] * dx * dy + g.m[3] * dy * dy;
            const float disc = B * B - mzz * (C - k2);
            if (disc < 0) continue;
            const float sq = std::sqrt(disc);
            const double zlo = g.c[2] + (-B - sq) / mzz, zhi = g.c[2] + (-B + sq) / mzz;
            const int32_t z0 = std::max((int32_t)std::ceil(zlo), std::max(g.lo[2], o[2]));
            const int32_t z1 = std::min((int32_t)std::floor(zhi), std::min(g.hi[2], o[2] + 7));
            const int base = ((x & 7) << 6) | ((y & 7) << 3);
            for (int32_t z = z0; z <= z1; z++) {
              const float dz = (float)(z - g.c[2]);
              const float q = C + dz * (2 * B + mzz * dz);
              const int off = base | (z & 7);
              buf[off] += g.amp * std::exp(-0.5f * std::max(q, 0.0f));
              mask.setOn(off);
            }
          }
        }
      }
      leaves[L] = leaf;
    }
  });
  std::vector<Pair>().swap(pairs);
  std::vector<Prepared>().swap(prep);
  if (nomem) {
    for (auto *l : leaves) delete l;
    return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: out of memory allocating %zu leaves", nleaf);
  }

  // 4. Attach leaves (the tree takes ownership).
  mgs_vdb_detail::init();
  FloatGrid::Ptr grid;
  try {
    grid = FloatGrid::create(0.0f);
    grid->setTransform(mgs_vdb_detail::make_transform(h, shift));
    grid->setName("alpha");
    grid->setGridClass(GRID_FOG_VOLUME);
    auto &tree = grid->tree();
    size_t i = 0;
    std::unordered_map<uint64_t, mgs_vdb_alpha_cache::Leaf> next;
    if (cache) next.reserve(nleaf);
    for (; i < nleaf; i++) {
      if (leaves[i]->isEmpty()) { delete leaves[i]; leaves[i] = nullptr; continue; }  // no voxel inside an ellipsoid
      if (cache) {
        mgs_vdb_alpha_cache::Leaf &c = next[leaf_key(leaves[i]->origin()[0] >> 3, leaves[i]->origin()[1] >> 3, leaves[i]->origin()[2] >> 3)];
        c.hash = hashes[i];
        std::memcpy(c.v, leaves[i]->buffer().data(), sizeof c.v);
        for (int w = 0; w < 8; w++) c.mask[w] = leaves[i]->getValueMask().getWord<uint64_t>(w);
      }
      tree.addLeaf(leaves[i]);
      leaves[i] = nullptr;
    }
    if (cache) {
      cache->leaves.swap(next);
      cache->h = h;
      cache->k_sigma = p.k_sigma;
      cache->small = (int)p.small;
      for (int a = 0; a < 3; a++) cache->shift[a] = shift[a];
    }
    info.leaves_reused = reused;
  } catch (const std::exception &e) {
    for (auto *l : leaves) delete l;
    return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: %s", e.what());
  }
  *out = mgs_vdb_detail::wrap(grid);
  if (!*out) return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: out of memory");

  info.gaussians_used = src.n - bad;
  info.active_voxels = (size_t)grid->activeVoxelCount();
  info.leaves = (size_t)grid->tree().leafCount();
  CoordBBox bb;
  if (grid->tree().evalActiveVoxelBoundingBox(bb)) info.dense_voxels = (double)bb.dim()[0] * bb.dim()[1] * bb.dim()[2];
  info.seconds = mgs_now() - t0;
  if (info_out) *info_out = info;
  return MGS_OK;
}

void get_raw(const void *ctx, size_t i, double mean[3], double cov[9], double *alpha) {
  const float *const *a = static_cast<const float *const *>(ctx);
  const float *m = a[0] + 3 * i, *c = a[1] + 6 * i;
  for (int k = 0; k < 3; k++) mean[k] = m[k];
  cov[0] = c[0]; cov[1] = c[1]; cov[2] = c[2];
  cov[3] = c[1]; cov[4] = c[3]; cov[5] = c[4];
  cov[6] = c[2]; cov[7] = c[4]; cov[8] = c[5];
  *alpha = a[2][i];
}

// Covariance R diag(s²) Rᵀ of row i with log-scales ls, and its opacity.
void model_row(const mgs_gaussians *g, size_t i, const float ls[3], double mean[3], double cov[9], double *alpha) {
  for (int k = 0; k < 3; k++) mean[k] = g->mean[3 * i + k];
  double q[4] = {g->rot[4 * i], g->rot[4 * i + 1], g->rot[4 * i + 2], g->rot[4 * i + 3]};
  double qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(qn > 0)) { q[0] = 1; q[1] = q[2] = q[3] = 0; qn = 1; }
  for (double &v : q) v /= qn;
  double R[9];
  mgs_quat_to_mat3d(q, R);
  double s2[3];
  for (int k = 0; k < 3; k++) {
    double s = std::exp(std::min((double)ls[k], 300.0));
    s2[k] = s * s;
  }
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++)
      cov[3 * a + b] = R[3 * a] * R[3 * b] * s2[0] + R[3 * a + 1] * R[3 * b + 1] * s2[1] + R[3 * a + 2] * R[3 * b + 2] * s2[2];
  *alpha = 1.0 / (1.0 + std::exp(-(double)g->opacity[i]));
}

void get_model(const void *ctx, size_t i, double mean[3], double cov[9], double *alpha) {
  const mgs_gaussians *g = static_cast<const mgs_gaussians *>(ctx);
  model_row(g, i, g->log_scale + 3 * i, mean, cov, alpha);
}

// A 2DGS surfel has no thickness: its third standard deviation is taken as half a voxel
// (a disc one voxel thick, seen by every voxel centre it crosses even without the
// low-pass filter), whatever its unused log_scale[2] holds.
struct SurfelCtx {
  const mgs_gaussians *g;
  double s3;
};
void get_surfel(const void *ctx, size_t i, double mean[3], double cov[9], double *alpha) {
  const SurfelCtx *c = static_cast<const SurfelCtx *>(ctx);
  const float ls[3] = {c->g->log_scale[3 * i], c->g->log_scale[3 * i + 1], (float)std::log(c->s3)};
  model_row(c->g, i, ls, mean, cov, alpha);
}

}  // namespace

extern "C" double mgs_vdb_surfel_thickness(const mgs_gaussians *g, const mgs_vdb_alpha_params *p) {
  return 0.5 * mgs_vdb_voxel_size_for(g->n, g->mean, p);
}

extern "C" void mgs_vdb_alpha_params_default(mgs_vdb_alpha_params *p) {
  std::memset(p, 0, sizeof *p);
  p->resolution = 256;
  p->voxel_size = 0;
  p->k_sigma = 3.0;
  p->small = MGS_VDB_SMALL_PEAK;
  p->memory_budget = 0;
  p->half_width = 3;
}

extern "C" mgs_status mgs_vdb_check_gaussians(const mgs_gaussians *g, const char *source, mgs_error *err) {
  const char *src = source ? source : "scene";
  if (!g || g->n == 0) return mgs_error_set(err, MGS_ERR_FORMAT, "%s: the scene has no Gaussians", src);
  for (size_t i = 0; i < g->n; i++) {
    for (int k = 0; k < 3; k++)
      if (!std::isfinite(g->mean[3 * i + k]))
        return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: Gaussian %zu has a non-finite position (%c = %g)", src, i,
                             "xyz"[k], (double)g->mean[3 * i + k]);
    for (int k = 0; k < 3; k++) {
      const float s = g->log_scale[3 * i + k];
      if (std::isnan(s))
        return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: Gaussian %zu has scale_%d = NaN", src, i, k);
      if (s == -INFINITY)
        return mgs_error_set(err, MGS_ERR_NUMERIC,
                             "%s: Gaussian %zu has a zero or negative scale (scale_%d = log-scale -inf)", src, i, k);
      if (!std::isfinite(s) || s > 80.0f)
        return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: Gaussian %zu has an overflowing scale (scale_%d = %g, log)",
                             src, i, k, (double)s);
    }
    double qn = 0;
    for (int k = 0; k < 4; k++) {
      const float q = g->rot[4 * i + k];
      if (!std::isfinite(q))
        return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: Gaussian %zu has a non-finite rotation (rot_%d = %g)", src, i,
                             k, (double)q);
      qn += (double)q * q;
    }
    if (!(qn > 0)) return mgs_error_set(err, MGS_ERR_NUMERIC, "%s: Gaussian %zu has a zero rotation quaternion", src, i);
    if (!std::isfinite(g->opacity[i]))
      return mgs_error_set(err, MGS_ERR_NUMERIC,
                           "%s: Gaussian %zu has opacity out of range (logit %g; expected a finite logit)", src, i,
                           (double)g->opacity[i]);
  }
  return MGS_OK;
}

extern "C" double mgs_vdb_voxel_size_for(size_t n, const float *mean, const mgs_vdb_alpha_params *p) {
  if (p && p->voxel_size > 0) return p->voxel_size;
  if (n == 0) return 0;
  double lo[3], hi[3];
  for (int a = 0; a < 3; a++) lo[a] = hi[a] = mean[a];
  for (size_t i = 1; i < n; i++)
    for (int a = 0; a < 3; a++) { lo[a] = std::min(lo[a], (double)mean[3 * i + a]); hi[a] = std::max(hi[a], (double)mean[3 * i + a]); }
  double d = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  return d / (p && p->resolution > 0 ? p->resolution : 256);
}

extern "C" mgs_status mgs_vdb_alpha_field_cov(size_t n, const float *mean, const float *cov, const float *alpha,
                                              const mgs_vdb_alpha_params *p, mgs_vdb_grid **out,
                                              mgs_vdb_build_info *info, mgs_error *err) {
  const float *arrays[3] = {mean, cov, alpha};
  for (size_t i = 0; i < n; i++) {
    bool ok = std::isfinite(alpha[i]);
    for (int k = 0; k < 3; k++) ok = ok && std::isfinite(mean[3 * i + k]);
    for (int k = 0; k < 6; k++) ok = ok && std::isfinite(cov[6 * i + k]);
    if (!ok) return mgs_error_set(err, MGS_ERR_NUMERIC, "alpha field: Gaussian %zu has a non-finite parameter", i);
  }
  Source s{n, get_raw, arrays, mean};
  try {
    return build(s, p, out, info, err);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: %s", e.what());
  }
}

extern "C" mgs_status mgs_vdb_alpha_field(const mgs_gaussians *g, const mgs_vdb_alpha_params *p, mgs_vdb_grid **out,
                                          mgs_vdb_build_info *info, mgs_error *err) {
  *out = nullptr;
  mgs_status st = mgs_vdb_check_gaussians(g, "alpha field", err);
  if (st != MGS_OK) return st;
  SurfelCtx sc{g, mgs_vdb_surfel_thickness(g, p)};
  Source s = g->kind == MGS_MODEL_2DGS && sc.s3 > 0 ? Source{g->n, get_surfel, &sc, g->mean} : Source{g->n, get_model, g, g->mean};
  try {
    return build(s, p, out, info, err);
  } catch (const std::exception &e) {
    return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: %s", e.what());
  }
}

extern "C" mgs_vdb_alpha_cache *mgs_vdb_alpha_cache_create(void) { return new (std::nothrow) mgs_vdb_alpha_cache(); }
extern "C" void mgs_vdb_alpha_cache_destroy(mgs_vdb_alpha_cache *c) { delete c; }

extern "C" mgs_status mgs_vdb_alpha_field_cached(const mgs_gaussians *g, const mgs_vdb_alpha_params *p,
                                                 mgs_vdb_alpha_cache *cache, mgs_vdb_grid **out, mgs_vdb_build_info *info,
                                                 mgs_error *err) {
  *out = nullptr;
  if (!cache) return mgs_error_set(err, MGS_ERR_ARG, "alpha field: no cache");
  mgs_status st = mgs_vdb_check_gaussians(g, "alpha field", err);
  if (st != MGS_OK) return st;
  SurfelCtx sc{g, mgs_vdb_surfel_thickness(g, p)};
  Source s = g->kind == MGS_MODEL_2DGS && sc.s3 > 0 ? Source{g->n, get_surfel, &sc, g->mean} : Source{g->n, get_model, g, g->mean};
  try {
    return build(s, p, out, info, err, cache);
  } catch (const std::exception &e) {
    cache->leaves.clear();
    cache->h = 0;
    return mgs_error_set(err, MGS_ERR_NOMEM, "alpha field: %s", e.what());
  }
}
