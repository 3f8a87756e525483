// MC33 classification of one cell on a device, in the common dialect of kernels/dialect.h: a port
// of core/cutting/mc33.cpp classify() that returns the fields of core/device/backend.h CellCode (packed as in
// core/device/device_scene.h). Tables come from the generated mchex_tables header; the (sign pattern,
// face outcomes) -> (subcase, symmetry) lookup is core's own table, uploaded as the `configs`
// buffer (core/device/device_scene.h packed_mc33_configs()).
//
// The decisions must equal the CPU's exactly:
//   - the face test is the sign of p0 p1 - n0 n1, computed exactly. OpenCL has a correctly
//     rounded fma, so it runs core's Kahan determinant (Jeannerod, Louvet & Muller 2013: relative
//     error <= 2u, hence the exact sign) operation for operation. Vulkan does not promise a fused
//     fma, so there (and in OpenCL built with -DMCHEX_NO_FMA, which the tests use to check this
//     path) the sign comes from Dekker's exact products and an exact expansion sum (Shewchuk 1997,
//     Grow-Expansion): exact too, so both give the same decision whenever the products neither
//     overflow nor underflow (|values| between ~1e-150 and ~1e150, as for core's Kahan);
//   - the interior test (core/cutting/mc33.cpp interior_join) is the same double arithmetic in the same
//     order.
#ifndef MCHEX_CLASSIFY_H
#define MCHEX_CLASSIFY_H
#ifndef MCHEX_FP32  // double precision throughout (kernels/dialect.h)

#ifdef __OPENCL_C_VERSION__
#define CLASSIFY_PARAMS_ GLOBAL_RO uint *configs,
#define CLASSIFY_ARGS_ configs,
#if !defined(MCHEX_NO_FMA)
#define MCHEX_HAS_FMA 1
#endif
#else
#define CLASSIFY_PARAMS_
#define CLASSIFY_ARGS_
#endif

STRUCT(CellValues) {
  double f[8];  // corner values, core/cutting/mc33.h corner order; f > 0 inside
};

#ifdef __OPENCL_C_VERSION__
#define MCHEX_CROSSING_NAN ((double)NAN)
#else
#define MCHEX_CROSSING_NAN double(uintBitsToFloat(0x7FC00000u))
#endif

// core/cutting/mc33.cpp classify()'s crossing parameter on Table 1's edge e (a constant after unrolling:
// see classify_pattern on indices): f_a / (f_a - f_b) from the edge's first corner where the edge
// is cut, a quiet NaN where it is not.
INLINE double edge_crossing(CellValues v, int mask, int e) {
  int a = kCubeEdges[2 * e], b = kCubeEdges[2 * e + 1];
  if (((mask >> a) & 1) == ((mask >> b) & 1)) return MCHEX_CROSSING_NAN;
  EXACT double s = v.f[a] / (v.f[a] - v.f[b]);
  return s;
}

STRUCT(CellWords) {
  uint w0;  // subcase | sign_mask << 8 | face_joins << 16 | (tunnel + 1) << 24 | inverted << 26
  uint w1;  // symmetry | cut_edges << 16
};

#ifdef MCHEX_HAS_FMA
// core/cutting/mc33.cpp kahan_det, operation for operation.
INLINE bool det_nonnegative(double a, double b, double c, double d) {
  EXACT double w = c * d;
  EXACT double e = fma(-c, d, w);
  EXACT double f = fma(a, b, -w);
  EXACT double r = f + e;
  return r >= 0.0;
}
#else
STRUCT(TwoTerms) {
  double hi;
  double lo;
};

INLINE TwoTerms two_sum(double a, double b) {
  TwoTerms r;
  EXACT double s = a + b;
  EXACT double bv = s - a;
  EXACT double av = s - bv;
  EXACT double t = (a - av) + (b - bv);
  r.hi = s;
  r.lo = t;
  return r;
}

// Dekker's product: a * b == hi + lo exactly (Veltkamp split with 2^27 + 1).
INLINE TwoTerms two_product(double a, double b) {
  TwoTerms r;
  EXACT double p = a * b;
  EXACT double ta = CAST(double, 134217729) * a;
  EXACT double ahi = ta - (ta - a);
  EXACT double alo = a - ahi;
  EXACT double tb = CAST(double, 134217729) * b;
  EXACT double bhi = tb - (tb - b);
  EXACT double blo = b - bhi;
  EXACT double err = ((ahi * bhi - p) + ahi * blo + alo * bhi) + alo * blo;
  r.hi = p;
  r.lo = err;
  return r;
}

// Sign of a b - c d from the exact expansion of the four product terms: the sum of a
// nonoverlapping expansion has the sign of its largest (last non-zero) component.
INLINE bool det_nonnegative_exact(double a, double b, double c, double d) {
  TwoTerms ab = two_product(a, b);
  TwoTerms cd = two_product(c, d);
  double x[4];
  x[0] = ab.lo;
  x[1] = -cd.lo;
  x[2] = ab.hi;
  x[3] = -cd.hi;
  double h[4];
  h[0] = x[0];
  int n = 1;
  for (int i = 1; i < 4; ++i) {
    double q = x[i];  // a copy, no arithmetic (precise here sends glslang 12 out of memory)
    for (int j = 0; j < n; ++j) {
      TwoTerms s = two_sum(q, h[j]);
      q = s.hi;
      h[j] = s.lo;
    }
    h[n] = q;
    ++n;
  }
  for (int j = 3; j >= 0; --j)
    if (h[j] != 0.0) return h[j] > 0.0;
  return true;
}

// A filter in front of the expansion (Shewchuk 1997, Section 4.2's idea): r = fl(fl(ab) - fl(cd))
// differs from ab - cd by at most u |ab| + u |cd| + u |r| <= 2u (1 + u) (|ab| + |cd|) (u = 2^-53,
// each operation correctly rounded, no contraction). MCHEX_DET_FILTER = 2^-50 (generated) makes
// the bound 8u (|ab| + |cd|), four times that even after its own rounding, so when |r| exceeds it
// r has the exact sign; only the rest (ties and near-ties: few cells) pay for the expansion. The
// same decision as the exact path whenever that one holds (no overflow or underflow of the
// products, see above).
INLINE bool det_nonnegative(double a, double b, double c, double d) {
  EXACT double ab = a * b;
  EXACT double cd = c * d;
  EXACT double r = ab - cd;
  EXACT double bound = (FABS(ab) + FABS(cd)) * MCHEX_DET_FILTER;
  if (FABS(r) > bound) return r > 0.0;
  return det_nonnegative_exact(a, b, c, d);
}
#endif

// core/cutting/mc33.cpp face_joins_positive.
INLINE bool face_joins_positive(double p0, double p1, double n0, double n1) {
  return det_nonnegative(p0, p1, n0, n1);
}

// core/cutting/mc33.cpp interior_join: -1 when the extremum joins nothing, else c1 | c2 << 4.
INLINE int interior_join(CellValues v) {
  EXACT double b0 = v.f[0];
  EXACT double b1 = v.f[1];
  EXACT double b2 = v.f[2];
  EXACT double b3 = v.f[3];
  EXACT double d0 = v.f[4] - v.f[0];
  EXACT double d1 = v.f[5] - v.f[1];
  EXACT double d2 = v.f[6] - v.f[2];
  EXACT double d3 = v.f[7] - v.f[3];
  EXACT double qa = d0 * d2 - d1 * d3;
  EXACT double qb = b0 * d2 + b2 * d0 - b1 * d3 - b3 * d1;
  if (qa == 0.0) return -1;
  EXACT double ts = -qb / (2.0 * qa);
  if (!(ts > 0.0 && ts < 1.0)) return -1;
  EXACT double s0 = b0 + ts * d0;
  EXACT double s1 = b1 + ts * d1;
  EXACT double s2 = b2 + ts * d2;
  EXACT double s3 = b3 + ts * d3;
  bool p0 = s0 > 0.0, p1 = s1 > 0.0, p2 = s2 > 0.0, p3 = s3 > 0.0;
  if (p0 != p2 || p1 != p3 || p0 == p1) return -1;
  EXACT double q = s0 * s2 - s1 * s3;
  int k1;
  int k2;
  bool positive;
  if (qa < 0.0) {
    if (!(q > 0.0 || (q == 0.0 && p0))) return -1;
    k1 = 0;
    k2 = 2;
    positive = p0;
  } else {
    if (!(q < 0.0 || (q == 0.0 && p1))) return -1;
    k1 = 1;
    k2 = 3;
    positive = p1;
  }
  // v.f[k1], v.f[k2] picked by selects, not indexed: see classify_pattern on constant indices.
  EXACT double f1 = qa < 0.0 ? v.f[0] : v.f[1];
  EXACT double f2 = qa < 0.0 ? v.f[2] : v.f[3];
  int c1 = ((f1 > 0.0) == positive) ? k1 : k1 + 4;
  int c2 = ((f2 > 0.0) == positive) ? k2 : k2 + 4;
  return c1 | (c2 << 4);
}

// The corners connected to corner c through the links in adj (bit masks per corner).
INLINE int component_of(int adj[8], int c) {
  int comp = 1 << c;
  int frontier = comp;
  while (frontier != 0) {
    int next = 0;
    for (int k = 0; k < 8; ++k)
      if (((frontier >> k) & 1) != 0) next |= adj[k];
    next &= ~comp;
    comp |= next;
    frontier = next;
  }
  return comp;
}

// core/cutting/mc33.cpp classify() without crossings and regions (the host derives those from the values
// and the code), for a cell whose sign pattern (bit c: f[c] > 0) is `mask`. Values must be finite
// (the host checks). A cell with one sign everywhere (mask 0 or 255, nearly every cell of a grid)
// takes the short way: no edge is cut, no face is ambiguous and the subcase has no tunnel partner,
// so the loops below would change nothing.
//
// Arrays (the values, the links, the tables) are only ever indexed by loop counters that unroll to
// constants: SIMD compilers that run invocations as vector lanes (llvmpipe) spill an array indexed
// by a varying value to per-invocation memory, which on lavapipe cost more than the work itself.
// Per-subcase facts come from the `configs` buffer for the same reason (core/device/device_scene.h).
INLINE CellWords classify_pattern(CLASSIFY_PARAMS_ CellValues v, int mask) {
  if (mask == 0 || mask == 255) {
    uint e = configs[mask * 64];
    int pre = CAST(int, (e >> MCHEX_CONFIG_PREFERRED_SHIFT) & 255u);
    CellWords u;
    u.w0 = CAST(uint, CAST(int, e & 255u) | (mask << MCHEX_CODE_SIGN_SHIFT) | (1 << MCHEX_CODE_TUNNEL_SHIFT) |
                          (pre << MCHEX_CODE_INVERTED_SHIFT));
    u.w1 = (e >> (pre != 0 ? MCHEX_CONFIG_MAP1_SHIFT : MCHEX_CONFIG_MAP0_SHIFT)) & 255u;
    return u;
  }
  int cut = 0;
  for (int e = 0; e < 12; ++e)
    if (((mask >> kCubeEdges[2 * e]) & 1) != ((mask >> kCubeEdges[2 * e + 1]) & 1)) cut |= 1 << e;
  int adj[8];
  for (int c = 0; c < 8; ++c) {
    int same = ((mask >> c) & 1) != 0 ? mask : (~mask & 255);
    adj[c] = kEdgeNeighbours[c] & same;
  }
  int face_joins = 0;
  for (int fi = 0; fi < 6; ++fi) {
    int q0 = kHexFaces[4 * fi], q1 = kHexFaces[4 * fi + 1], q2 = kHexFaces[4 * fi + 2], q3 = kHexFaces[4 * fi + 3];
    // Ambiguous (core/cutting/mc33.cpp compute_ambiguous_faces): both diagonals are same-sign pairs of
    // opposite signs.
    int s0 = (mask >> q0) & 1, s1 = (mask >> q1) & 1, s2 = (mask >> q2) & 1, s3 = (mask >> q3) & 1;
    if (s0 != s2 || s1 != s3 || s0 == s1) continue;
    bool first_positive = s0 != 0;
    int pa = first_positive ? q0 : q1;
    int pb = first_positive ? q2 : q3;
    int na = first_positive ? q1 : q0;
    int nb = first_positive ? q3 : q2;
    bool joins = face_joins_positive(first_positive ? v.f[q0] : v.f[q1], first_positive ? v.f[q2] : v.f[q3],
                                     first_positive ? v.f[q1] : v.f[q0], first_positive ? v.f[q3] : v.f[q2]);
    if (joins) face_joins |= 1 << fi;
    int u = joins ? pa : na;
    int w = joins ? pb : nb;
    for (int k = 0; k < 8; ++k) {
      if (k == u) adj[k] |= 1 << w;
      if (k == w) adj[k] |= 1 << u;
    }
  }
  uint entry = configs[mask * 64 + face_joins];
  int subcase = CAST(int, entry & 255u);
  int partner = CAST(int, configs[MCHEX_CONFIG_SUBCASE_BASE + subcase] & 255u);
  int tunnel = 0;
  if (partner != 0) {
    int join = interior_join(v);
    if (join >= 0) {
      int c1 = join & 15, c2 = join >> 4;
      if (((component_of(adj, c1) >> c2) & 1) == 0) {
        tunnel = ((mask >> c1) & 1) != 0 ? 1 : -1;
        subcase = partner;
      }
    }
  }
  int preferred = CAST(int, (entry >> MCHEX_CONFIG_PREFERRED_SHIFT) & 255u);
  int representative_tunnel =
      CAST(int, (configs[MCHEX_CONFIG_SUBCASE_BASE + subcase] >> MCHEX_CONFIG_TUNNEL_SHIFT) & 255u) - 1;
  int inv = tunnel != 0 ? (tunnel != representative_tunnel ? 1 : 0) : preferred;
  int symmetry = CAST(int, (entry >> (inv != 0 ? MCHEX_CONFIG_MAP1_SHIFT : MCHEX_CONFIG_MAP0_SHIFT)) & 255u);
  CellWords words;
  words.w0 = CAST(uint, subcase | (mask << MCHEX_CODE_SIGN_SHIFT) | (face_joins << MCHEX_CODE_FACE_SHIFT) |
                          ((tunnel + 1) << MCHEX_CODE_TUNNEL_SHIFT) | (inv << MCHEX_CODE_INVERTED_SHIFT));
  words.w1 = CAST(uint, symmetry | (cut << MCHEX_CODE_CUT_SHIFT));
  return words;
}

INLINE CellWords classify_cell(CLASSIFY_PARAMS_ CellValues v) {
  int mask = 0;
  for (int c = 0; c < 8; ++c)
    if (v.f[c] > 0.0) mask |= 1 << c;
  return classify_pattern(CLASSIFY_ARGS_ v, mask);
}

// Hexes the mesher makes from the cell (core/cutting/local_refinement.h local_refinement_hexes: 8 + 2 * cut
// edges for a cell cut directly, the sum over its leaves for one refined locally), a function of
// the subcase alone, so the prefix sum of these is where each cell's hexes start in the output.
INLINE uint cell_hexes(CLASSIFY_PARAMS_ CellWords w) {
  return configs[MCHEX_CONFIG_SUBCASE_BASE + (w.w0 & 255u)] >> MCHEX_CONFIG_HEXES_SHIFT;
}

// The uniform grid's point numbering (core/grid/grid.h UniformGrid: cells x fastest, points
// i + (n+1)(j + (n+1)k), corners as UniformGrid::cell_corners), so a uniform complex needs no
// corner list on the device: cell `cell`'s corner 0, then corner c at a fixed offset from it.
INLINE uint uniform_cell_base(uint cell, uint n) {
  uint i = cell % n;
  uint rest = cell / n;
  return i + (n + 1u) * ((rest % n) + (n + 1u) * (rest / n));
}

INLINE uint uniform_corner_offset(uint n, int c) {
  uint m = n + 1u;
  return CAST(uint, kCubeCorners[3 * c]) + m * (CAST(uint, kCubeCorners[3 * c + 1]) + m * CAST(uint, kCubeCorners[3 * c + 2]));
}

#endif  // MCHEX_FP32
#endif
