/* The discrete gradient of the V construction (lower-star filtration), one vertex at a time:
 * ProcessLowerStars of Robins, Wood & Sheppard (2011) on the lower star of a voxel.
 *
 * Why: sorting and reducing every cell of the band (~8 per voxel) dominated the engine. The
 * lower star L(v) of vertex v holds the cells whose highest vertex is v in the total vertex
 * order (value, key); all of them have the value f(v). Pairing cells inside each L(v) gives
 * an acyclic matching of cells of equal value (pairs never cross lower stars, and inside a
 * lower star a cell is paired only after all its other faces there are classified), so by
 * Mischaikow-Nanda (2013) the Morse complex of the critical cells, filtered by value, has
 * exactly the persistence diagram of the cubical complex. Only critical cells are sorted
 * and paired (topo/morse_boundary.c computes their boundaries by V-path traversal).
 *
 * The lower star is computed from the 27 values of the 3x3x3 neighbourhood of v (index
 * (dx+1)*9 + (dy+1)*3 + dz+1, which is also the key order, so ties in value are broken by
 * the index as everywhere in the engine). Cells of the star of v use the same index: the
 * cell with doubled coordinates 2v + (dx,dy,dz). A vertex is deterministic in its
 * neighbourhood, so any thread (or leaf) recomputing L(v) gets the same pairs.
 *
 * T construction (voxels as 3-cells, a cell's value the min of its voxels): the T complex is
 * dual to the V complex of g = -f (T cell 2v + 1 + d <-> V cell 2v + d, dimension 3 - k, faces
 * and cofaces swapped, T value = -g value). The lower-star gradient of g, read through that
 * duality, pairs T cells of equal value and is acyclic, so the same argument holds; callers
 * pass the negated neighbourhood and offset the keys by one (base). */
#include <pthread.h>
#include <string.h>
#include "topo/cubical_internal.h"

static struct {
  uint32_t vmask[27];      /* neighbour vertices of the cell (bit u, u != 13) */
  uint8_t nv[27], verts[27][7];
  uint8_t dim[27];
  uint8_t nf[27], faces[27][3];   /* faces that contain v */
  uint8_t nc[27], cofaces[27][6]; /* cofaces (in the star of v) */
} T;
static pthread_once_t tables_once = PTHREAD_ONCE_INIT;

static void tables_init(void) {
  for (int ci = 0; ci < 27; ci++) {
    int d[3] = {ci / 9 - 1, ci / 3 % 3 - 1, ci % 3 - 1};
    T.dim[ci] = (uint8_t)((d[0] != 0) + (d[1] != 0) + (d[2] != 0));
    T.vmask[ci] = 0;
    T.nv[ci] = 0;
    for (int s = 0; s < 8; s++) {
      int e[3];
      int ok = 1;
      for (int k = 0; k < 3; k++) {
        e[k] = (s >> k & 1) ? d[k] : 0;
        if ((s >> k & 1) && d[k] == 0) ok = 0;
      }
      if (!ok || s == 0) continue;
      int u = (e[0] + 1) * 9 + (e[1] + 1) * 3 + e[2] + 1;
      T.vmask[ci] |= 1u << u;
      T.verts[ci][T.nv[ci]++] = (uint8_t)u;
    }
    T.nf[ci] = T.nc[ci] = 0;
    for (int k = 0; k < 3; k++) {
      int q[3] = {d[0], d[1], d[2]};
      if (d[k] != 0) {
        q[k] = 0;
        T.faces[ci][T.nf[ci]++] = (uint8_t)((q[0] + 1) * 9 + (q[1] + 1) * 3 + q[2] + 1);
      } else {
        for (int sg = -1; sg <= 1; sg += 2) {
          q[k] = sg;
          T.cofaces[ci][T.nc[ci]++] = (uint8_t)((q[0] + 1) * 9 + (q[1] + 1) * 3 + q[2] + 1);
        }
      }
    }
  }
}

void cub_lower_star_tables(void) { pthread_once(&tables_once, tables_init); }

static inline int nunp(const cub_ls *ls, int ci) {
  int n = 0;
  for (int i = 0; i < T.nf[ci]; i++) n += ls->state[T.faces[ci][i]] == CUB_LS_FREE;
  return n;
}
static inline int first_free_face(const cub_ls *ls, int ci) {
  for (int i = 0; i < T.nf[ci]; i++)
    if (ls->state[T.faces[ci][i]] == CUB_LS_FREE) return T.faces[ci][i];
  return -1;
}
static inline int argmin_g(uint32_t set, const uint32_t *g) {
  int best = -1;
  uint32_t bg = UINT32_MAX;
  while (set) {
    int ci = __builtin_ctz(set);
    set &= set - 1;
    if (best < 0 || g[ci] < bg) { best = ci; bg = g[ci]; }
  }
  return best;
}

static inline uint32_t lower_mask(const float nb[27]) {
  const float fv = nb[13];
  uint32_t lower = 0;
  for (int u = 0; u < 27; u++) lower |= (uint32_t)(nb[u] < fv || (nb[u] == fv && u < 13)) << u;
  return lower;
}

static inline uint32_t lower_star_cells(uint32_t lower) {
  uint32_t inl = 1u << 13;
  for (int ci = 0; ci < 27; ci++)
    if (ci != 13 && (T.vmask[ci] & ~lower) == 0) inl |= 1u << ci;
  return inl;
}

/* Whether L(v) has no critical cell, without pairing it: in 3D, ProcessLowerStars leaves as
 * many critical cells in L(v) as the reduced Betti numbers of the lower link (RWS 2011), so
 * none exactly when the lower link is acyclic: non-empty, connected and of Euler
 * characteristic 1 (a proper subcomplex of the link sphere has no H2, so b1 = 0). The link's
 * vertices, edges and 2-cells are the edges, squares and cubes of L(v). tests/topo checks
 * this filter against cub_lower_star. */
static int regular(uint32_t inl) {
  int ne = 0, nsq = 0, ncu = 0;
  uint8_t parent[27];
  for (uint32_t m = inl & ~(1u << 13); m;) {
    int ci = __builtin_ctz(m);
    m &= m - 1;
    int d = T.dim[ci];
    if (d == 1) { ne++; parent[ci] = (uint8_t)ci; }
    else if (d == 2) nsq++;
    else ncu++;
  }
  if (ne == 0 || ne - nsq + ncu != 1) return 0;
  int comps = ne;
  for (uint32_t m = inl; m;) {
    int ci = __builtin_ctz(m);
    m &= m - 1;
    if (T.dim[ci] != 2) continue;
    /* a square's two edges through v: its faces in the star of v */
    int a = T.faces[ci][0], b = T.faces[ci][1];
    while (parent[a] != a) a = parent[a];
    while (parent[b] != b) b = parent[b];
    if (a != b) { parent[a] = (uint8_t)b; comps--; }
  }
  return comps == 1;
}

int cub_lower_star_count(const float nb[27], size_t *ncells) {
  uint32_t inl = lower_star_cells(lower_mask(nb));
  *ncells = (size_t)__builtin_popcount(inl);
  return !regular(inl);
}

void cub_lower_star(const float nb[27], cub_ls *ls) {
  uint32_t lower = lower_mask(nb);
  memset(ls->state, CUB_LS_OUT, sizeof ls->state);
  uint32_t inl = lower_star_cells(lower);
  ls->n = (uint8_t)__builtin_popcount(inl);
  for (uint32_t m = inl; m;) {
    int ci = __builtin_ctz(m);
    m &= m - 1;
    ls->state[ci] = CUB_LS_FREE;
  }
  uint8_t t = 0;
  if (ls->n == 1) { ls->state[13] = CUB_LS_CRIT; ls->time[13] = 0; return; }
  /* G(cell) = set of the ranks of its lower vertices as bits: comparing these numbers is
   * comparing the descending vertex lists lexicographically (RWS) */
  uint64_t key[32]; /* (value, index) as one integer; not lower: max (fixed-length loop) */
  for (int u = 0; u < 32; u++) key[u] = UINT64_MAX;
  for (uint32_t m = lower; m;) {
    int u = __builtin_ctz(m);
    m &= m - 1;
    uint32_t bits;
    memcpy(&bits, &nb[u], 4);
    bits = (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u); /* order-preserving */
    key[u] = ((uint64_t)bits << 5) | (uint64_t)u;
  }
  uint32_t rbit[27];
  for (uint32_t m = lower; m;) {
    int u = __builtin_ctz(m);
    m &= m - 1;
    uint32_t r = 0;
    for (int w = 0; w < 32; w++) r += key[w] < key[u];
    rbit[u] = 1u << r;
  }
  uint32_t g[27];
  for (uint32_t m = inl & ~(1u << 13); m;) {
    int ci = __builtin_ctz(m);
    m &= m - 1;
    uint32_t x = 0;
    for (int i = 0; i < T.nv[ci]; i++) x |= rbit[T.verts[ci][i]];
    g[ci] = x;
  }
  uint32_t edges = 0;
  for (int i = 0; i < 6; i++) {
    int ci = T.cofaces[13][i];
    if (inl >> ci & 1) edges |= 1u << ci;
  }
  int delta = argmin_g(edges, g);
  ls->state[13] = ls->state[delta] = CUB_LS_PAIR;
  ls->partner[13] = (int8_t)delta;
  ls->partner[delta] = 13;
  ls->time[13] = ls->time[delta] = t++;
  uint32_t zero = edges & ~(1u << delta), one = 0;
  for (int i = 0; i < T.nc[delta]; i++) {
    int c = T.cofaces[delta][i];
    if ((inl >> c & 1) && nunp(ls, c) == 1) one |= 1u << c;
  }
  for (;;) {
    while (one) {
      int a = argmin_g(one, g);
      one &= ~(1u << a);
      if (ls->state[a] != CUB_LS_FREE) continue;
      if (nunp(ls, a) == 0) { zero |= 1u << a; continue; }
      int p = first_free_face(ls, a);
      ls->state[a] = ls->state[p] = CUB_LS_PAIR;
      ls->partner[a] = (int8_t)p;
      ls->partner[p] = (int8_t)a;
      ls->time[a] = ls->time[p] = t++;
      zero &= ~(1u << p);
      for (int k = 0; k < 2; k++) {
        int x = k ? p : a;
        for (int i = 0; i < T.nc[x]; i++) {
          int c = T.cofaces[x][i];
          if ((inl >> c & 1) && ls->state[c] == CUB_LS_FREE && nunp(ls, c) == 1) one |= 1u << c;
        }
      }
    }
    uint32_t z = 0;
    for (uint32_t m = zero; m;) {
      int ci = __builtin_ctz(m);
      m &= m - 1;
      if (ls->state[ci] == CUB_LS_FREE) z |= 1u << ci;
    }
    zero = z;
    if (!zero) break;
    int c = argmin_g(zero, g);
    zero &= ~(1u << c);
    ls->state[c] = CUB_LS_CRIT;
    ls->time[c] = t++;
    for (int i = 0; i < T.nc[c]; i++) {
      int x = T.cofaces[c][i];
      if ((inl >> x & 1) && ls->state[x] == CUB_LS_FREE && nunp(ls, x) == 1) one |= 1u << x;
    }
  }
  /* RWS classify every cell; keep the matching valid whatever happens */
  for (int ci = 0; ci < 27; ci++)
    if (ls->state[ci] == CUB_LS_FREE) { ls->state[ci] = CUB_LS_CRIT; ls->time[ci] = t++; }
}

int cub_ls_dim(int ci) { return T.dim[ci]; }

size_t cub_ls_critical(const cub_ls *ls, int32_t x, int32_t y, int32_t z, int base, float v, cub_cell *out) {
  size_t n = 0;
  for (int ci = 0; ci < 27; ci++) {
    if (ls->state[ci] != CUB_LS_CRIT) continue;
    if (out) {
      out[n].key = cub_key(2 * x + base + ci / 9 - 1, 2 * y + base + ci / 3 % 3 - 1, 2 * z + base + ci % 3 - 1);
      out[n].v = v;
    }
    n++;
  }
  return n;
}
