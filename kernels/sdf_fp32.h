// The surface SDF on a device without fp64 (kernels/dialect.h, MCHEX_FP32): single precision
// decides WHICH triangles can hold the answer, the host computes the answer from them in double
// (host/backends/fp32_path.h, for kernels/mchex.cl and shaders/surface_sdf32*.comp), so the value is core/sdf/sdf.h SurfaceSdf's bit for bit.
//
// For every point p the kernel returns a candidate set: the slots whose triangle may be the one
// SurfaceSdf picks (the least squared distance as core computes it in double, the lowest triangle
// id among equal ones), or "overflow" when more than MCHEX_FP32_CANDIDATES slots qualify (the host
// then runs SurfaceSdf itself for p). The set is certain, not probable, because each triangle t
// gets float bounds on the distance d_cpu(t) that core's double arithmetic computes:
//
//   U(t) >= d_cpu(t):  q = the closest point found in float with its barycentric parameters
//        clamped into the triangle, so the exact point Q with those parameters lies on t;
//        D = |p - q| in float. Every coordinate is within 2^-24 |x| of the double input, each
//        float operation within 2^-24 of its result; summed over the operations of q and D (about
//        50 roundings of quantities <= 6 M, M the largest coordinate magnitude of p, a, b, c),
//        |D - |P - Q|| <= D 2^-21 + 50 2^-23 M < D 2^-20 + 2^-16 M. So
//        U = D (1 + 2^-20) + 2^-16 M + delta(t) bounds the true distance plus core's error.
//   L(t) <= d_cpu(t):  for any direction n with |n| <= 1, min over the corners X of n.(p - X) is a
//        lower bound of the distance from p to the triangle (the triangle is the convex hull of
//        its corners, so n.(p - Y) >= min_X n.(p - X) for every Y on it, and |p - Y| >= n.(p - Y)).
//        n = (p - q)/D scaled by 1 - 2^-20 (so |n| <= 1 after rounding): tight when q is near the
//        closest point. Evaluated in float with conversion and rounding errors <= 30 2^-23 M:
//        L = min_X fl(n.(p - X)) - 2^-17 M - delta(t).
//   delta(t) = how far core's double value can be from the true distance: core's
//        closest_point_on_triangle (Ericson's Voronoi walk) leaves the triangle only through its
//        interior branch, by at most (err(va) + err(vb) + err(vc)) / (|ab x ac|^2) (|ab| + |ac|)
//        with err(v*) <= 16 u |ab| |ac| P^2 (u = 2^-53, P the largest |p - corner|); with
//        P^2 <= 12 W^2 (W = max |p| coordinate + the surface's largest coordinate) and margin,
//        delta(t) <= slot_slack[t] W^2 + 2^-44 W, slot_slack[t] = 12 2^-41 / (min(|ab|, |ac|)
//        sin^2(angle at a)) computed on the host in double and rounded up (core/device/device_scene.h
//        DeviceScene32). A near-degenerate triangle gets a large slack and is simply always a
//        candidate when its node is visited.
//
// Then SurfaceSdf's triangle t_d has d_cpu(t_d) <= min_t U(t), and every triangle with
// L(t) > min U(t) is farther in core's arithmetic than t_d: the candidates are the t with
// L(t) <= min U. Nodes are pruned only when their box's float lower distance, less the largest
// slot slack below them (node_slack), exceeds min U. Ties (a point nearest to a vertex or an edge
// is equally near every triangle around it) are all candidates; the host applies core's tie rule.
//
// Buffers: nodes (BvhNode, float bounds rounded outward from the double triangles: core/sdf/bvh.h),
// node_slack (float per node), slot_corners32 (float, 9 per slot), slot_slack (float per slot).
#ifndef MCHEX_SDF_FP32_H
#define MCHEX_SDF_FP32_H

#ifndef MCHEX_SDF_STACK
#define MCHEX_SDF_STACK 72  // > the BVH's maximum depth (64, core/sdf/bvh.cpp): one pending sibling per level
#endif

// A loop budget, for llvmpipe (lavapipe), as kernels/sdf.h's: gallivm ends a shader's loops after
// 65,535 iterations in all per SIMD batch and goes on with what the cut loop had, which here would
// be a candidate set missing triangles. With a budget (0: none, every other device) the walk
// counts, before each step, the most loop iterations the step can take, every loop at its bound:
// the walk's back edge; at a leaf of `slots` slots (0: an inner or pruned node), its slot loop and
// per slot offer32's loop over the candidates. When the count would pass the budget the walk stops
// and says so (overflow 2: the host evaluates the point). GROUP_MAX keeps the count per SIMD batch
// (subgroupMax: llvmpipe's subgroup is its batch, where a loop runs as long as any lane needs it,
// so a step adds the most any lane's step can take); without it each lane counts its own and the
// host divides the budget by the lanes.
#define MCHEX_FP32_LOOPS_PER_STEP(slots) \
  ((slots) == 0u ? 1u : 2u + (slots) * (1u + CAST(uint, MCHEX_FP32_CANDIDATES)))
//   one search's setup: the seed's offer32, and the caller's loop over points and its loop that
//   writes the candidates (each loop counted once more than its bound, for its exit test).
#define MCHEX_FP32_LOOPS_PER_SEARCH (3u + 2u * CAST(uint, MCHEX_FP32_CANDIDATES))
#ifndef GROUP_MAX
#define GROUP_MAX(x) (x)
#endif

#ifdef __OPENCL_C_VERSION__
#define FVEC3 float3
#define F3(x, y, z) ((float3)(x, y, z))
#define SCENE32_PARAMS_ GLOBAL_RO BvhNode *nodes, GLOBAL_RO float *node_slack, GLOBAL_RO float *slot_corners32, \
                        GLOBAL_RO float *slot_slack,
#define SCENE32_ARGS_ nodes, node_slack, slot_corners32, slot_slack,
#define FLOAT_INFINITY INFINITY
#else
#define FVEC3 vec3
#define F3(x, y, z) vec3(x, y, z)
#define SCENE32_PARAMS_
#define SCENE32_ARGS_
#define FLOAT_INFINITY uintBitsToFloat(0x7F800000u)
#endif

// 2^-16, 2^-17, 2^-20, 2^-44 as exact float literals (powers of two read the same in both dialects).
#define MCHEX_F_2M16 1.52587890625e-05
#define MCHEX_F_2M17 7.62939453125e-06
#define MCHEX_F_2M20 9.5367431640625e-07
#define MCHEX_F_2M44 5.684341886080802e-14

INLINE float dot3f(FVEC3 a, FVEC3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
INLINE float max_abs3f(FVEC3 a) { return max(max(FABS(a.x), FABS(a.y)), FABS(a.z)); }
// x clamped to [0, 1]; NaN (0 / 0 on a degenerate triangle) becomes 0.
INLINE float unit01(float x) { return x > 0.0f ? min(x, 1.0f) : 0.0f; }

// Ericson's Voronoi-region walk (core/sdf/sdf.cpp) in float, every parameter clamped into the
// triangle: the result is a point of the triangle up to rounding, whatever the rounding did to
// the region decisions.
INLINE FVEC3 closest_point_f(FVEC3 p, FVEC3 a, FVEC3 b, FVEC3 c) {
  FVEC3 ab = b - a;
  FVEC3 ac = c - a;
  FVEC3 ap = p - a;
  float d1 = dot3f(ab, ap);
  float d2 = dot3f(ac, ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return a;
  FVEC3 bp = p - b;
  float d3 = dot3f(ab, bp);
  float d4 = dot3f(ac, bp);
  if (d3 >= 0.0f && d4 <= d3) return b;
  FVEC3 cp = p - c;
  float d5 = dot3f(ab, cp);
  float d6 = dot3f(ac, cp);
  if (d6 >= 0.0f && d5 <= d6) return c;
  float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) return a + unit01(d1 / (d1 - d3)) * ab;
  float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) return a + unit01(d2 / (d2 - d6)) * ac;
  float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && d4 - d3 >= 0.0f && d5 - d6 >= 0.0f)
    return b + unit01((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  float sum = va + vb + vc;
  float v = unit01(vb / sum);
  float w = unit01(vc / sum);
  if (v + w > 1.0f) {
    float s = v + w;
    v = v / s;
    w = w / s;
  }
  return a + v * ab + w * ac;
}

INLINE FVEC3 slot_corner32(SCENE32_PARAMS_ uint slot, int c) {
  uint i = 9u * slot + 3u * CAST(uint, c);
  return F3(slot_corners32[i], slot_corners32[i + 1u], slot_corners32[i + 2u]);
}

STRUCT(Bounds32) {
  float lower;
  float upper;
};

// L(t) and U(t) of the header comment for slot k; w2 = W^2, w = W.
INLINE Bounds32 triangle_bounds32(SCENE32_PARAMS_ FVEC3 p, float mp, uint k, float w, float w2) {
  FVEC3 a = slot_corner32(SCENE32_ARGS_ k, 0);
  FVEC3 b = slot_corner32(SCENE32_ARGS_ k, 1);
  FVEC3 c = slot_corner32(SCENE32_ARGS_ k, 2);
  float m = max(mp, max(max_abs3f(a), max(max_abs3f(b), max_abs3f(c))));
  FVEC3 d = p - closest_point_f(p, a, b, c);
  float dist = sqrt(dot3f(d, d));
  float delta = slot_slack[k] * w2 + CAST(float, MCHEX_F_2M44) * w;
  Bounds32 r;
  r.upper = dist * (1.0f + CAST(float, MCHEX_F_2M20)) + CAST(float, MCHEX_F_2M16) * m + delta;
  float scale = dist > 0.0f ? (1.0f - CAST(float, MCHEX_F_2M20)) / dist : 0.0f;
  FVEC3 n = d * scale;
  float support = min(dot3f(n, p - a), min(dot3f(n, p - b), dot3f(n, p - c)));
  r.lower = support - CAST(float, MCHEX_F_2M17) * m - delta;
  if (!(r.upper <= FLOAT_INFINITY)) r.upper = FLOAT_INFINITY;  // NaN: no bound
  if (!(r.lower >= -FLOAT_INFINITY)) r.lower = -FLOAT_INFINITY;
  return r;
}

// Lower bound of the distance from p to anything in node n's box, less the node's slack.
INLINE float box_lower32(SCENE32_PARAMS_ uint n, FVEC3 p, float mp, float w, float w2) {
  float dx = max(max(nodes[n].lo[0] - p.x, p.x - nodes[n].hi[0]), 0.0f);
  float dy = max(max(nodes[n].lo[1] - p.y, p.y - nodes[n].hi[1]), 0.0f);
  float dz = max(max(nodes[n].lo[2] - p.z, p.z - nodes[n].hi[2]), 0.0f);
  float d = sqrt(dx * dx + dy * dy + dz * dz);
  return d * (1.0f - CAST(float, MCHEX_F_2M20)) - CAST(float, MCHEX_F_2M20) * mp - node_slack[n] * w2 -
         CAST(float, MCHEX_F_2M44) * w;
}

// overflow: 0, or 1 when more than MCHEX_FP32_CANDIDATES slots qualify, or 2 when the walk ran out
// of its loop budget; either way the slots are not the answer and the host evaluates the point.
// spent: the loop budget's count, carried from one search to the next of the same invocation.
STRUCT(Candidates32) {
  uint slot[MCHEX_FP32_CANDIDATES];
  float lower[MCHEX_FP32_CANDIDATES];
  int count;
  int overflow;
  float upper;
  uint nearest;  // the slot with the least upper bound: the next point's seed
  uint spent;
};

INLINE Candidates32 offer32(Candidates32 s, uint k, Bounds32 b) {
  if (b.upper < s.upper) {
    s.upper = b.upper;
    s.nearest = k;
    int kept = 0;
    for (int i = 0; i < s.count; ++i)
      if (s.lower[i] <= s.upper) {
        s.slot[kept] = s.slot[i];
        s.lower[kept] = s.lower[i];
        ++kept;
      }
    s.count = kept;
  }
  if (b.lower <= s.upper) {
    if (s.count < MCHEX_FP32_CANDIDATES) {
      s.slot[s.count] = k;
      s.lower[s.count] = b.lower;
      ++s.count;
    } else {
      s.overflow = 1;
    }
  }
  return s;
}

// The candidate slots for p (float coordinates of the double point), seeded with any slot.
// scale: the surface's largest coordinate magnitude; budget, spent: the loop budget above
// (budget 0: none). The walk ends as soon as the answer is an overflow: nothing it could
// find after that would change it.
INLINE Candidates32 surface_candidates32_within(SCENE32_PARAMS_ FVEC3 p, uint seed, float scale, uint budget,
                                                uint spent) {
  float mp = max_abs3f(p);
  float w = (mp + scale) * (1.0f + CAST(float, MCHEX_F_2M20));
  float w2 = w * w * (1.0f + CAST(float, MCHEX_F_2M20));
  Candidates32 s;
  s.count = 0;
  s.overflow = 0;
  s.upper = FLOAT_INFINITY;
  s.nearest = seed;
  s.spent = budget != 0u ? GROUP_MAX(spent) + MCHEX_FP32_LOOPS_PER_SEARCH : 0u;
  s = offer32(s, seed, triangle_bounds32(SCENE32_ARGS_ p, mp, seed, w, w2));
  uint stack_node[MCHEX_SDF_STACK];
  float stack_lower[MCHEX_SDF_STACK];
  int top = 1;
  stack_node[0] = 0u;
  stack_lower[0] = -FLOAT_INFINITY;
  while (top > 0 && s.overflow == 0) {
    if (budget != 0u) {
      uint slots = stack_lower[top - 1] > s.upper ? 0u : nodes[stack_node[top - 1]].count;
      s.spent = GROUP_MAX(s.spent) + GROUP_MAX(MCHEX_FP32_LOOPS_PER_STEP(slots));
      if (s.spent > budget) {
        s.overflow = 2;
        break;
      }
    }
    --top;
    if (stack_lower[top] > s.upper) continue;
    uint n = stack_node[top];
    uint count = nodes[n].count;
    if (count > 0u) {
      uint first = nodes[n].index;
      for (uint k = first; k < first + count; ++k)
        if (k != seed) s = offer32(s, k, triangle_bounds32(SCENE32_ARGS_ p, mp, k, w, w2));
      continue;
    }
    uint left = n + 1u, right = nodes[n].index;
    float dl = box_lower32(SCENE32_ARGS_ left, p, mp, w, w2);
    float dr = box_lower32(SCENE32_ARGS_ right, p, mp, w, w2);
    uint near_node = dl <= dr ? left : right, far_node = dl <= dr ? right : left;
    float near_d = dl <= dr ? dl : dr, far_d = dl <= dr ? dr : dl;
    // A full stack would lose a subtree that may hold a candidate: give the point to the host.
    if (far_d <= s.upper) {
      if (top < MCHEX_SDF_STACK) {
        stack_node[top] = far_node;
        stack_lower[top] = far_d;
        ++top;
      } else {
        s.overflow = 1;
      }
    }
    if (near_d <= s.upper) {
      if (top < MCHEX_SDF_STACK) {
        stack_node[top] = near_node;
        stack_lower[top] = near_d;
        ++top;
      } else {
        s.overflow = 1;
      }
    }
  }
  return s;
}

INLINE Candidates32 surface_candidates32(SCENE32_PARAMS_ FVEC3 p, uint seed, float scale) {
  return surface_candidates32_within(SCENE32_ARGS_ p, seed, scale, 0u, 0u);
}

#endif
