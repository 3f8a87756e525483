// Signed distance on a device, in the common dialect of kernels/dialect.h (OpenCL C and GLSL):
// the same arithmetic, in the same order, as core/sdf/sdf.cpp and core/sdf/shapes.cpp, so that every
// value equals the CPU reference bit for bit.
//
// Surface SDF: the search of core/sdf/sdf.cpp's reference, over the same kind of tree
// (core/device/device_scene.h: four children per node, each bounded by a box in a frame of its own, and
// a plane-and-edge-lines bound per triangle below each leaf): a nearest-first walk in float that
// prunes a node or triangle only when its float lower bound exceeds the best squared distance
// found so far (rounded up), and measures the survivors exactly, in double, with
// closest_point_on_triangle (Ericson's Voronoi-region walk, the same regions as core). The answer
// is the minimum squared distance and, among equal ones, the LOWEST triangle id (SurfaceSdf's
// tie rule), which makes the result independent of the walk, the tree, the packet and the seed;
// the sign is the angle-weighted pseudonormal's of the closest feature (core/device/device_scene.h).
//
// Packets: one walk serves MCHEX_SDF_PACKET points at once (neighbours in Morton order, as in the
// reference's packets): a node is opened when it is in range of any of them, each point
// stops where its own bound rules a node out, and measures only the triangles in its own range.
// OpenCL on a CPU builds with -DMCHEX_SDF_PACKET=8 (the per-point loops are over a fixed count);
// GPUs and GLSL take 1. In GLSL the packet can instead be the SUBGROUP (MCHEX_SDF_SUBGROUP: the
// wrapper defines GROUP_MIN as subgroupMin): every invocation holds one point, the children's
// keys are the subgroup's minimum so the walk, its order and its stack of node ids are uniform,
// and each invocation prunes for its own point: the walk a GPU takes (on an H200 2.5x faster in
// the kernel than one walk per invocation); on llvmpipe, which runs a subgroup as one SIMD vector
// under masks, it measured slower than one walk per invocation (host/backends/vulkan.cpp picks).
//
// Pruning is conservative: every bound is float, computed on the host in double from the float
// vectors the kernel projects on and rounded outward; the kernel subtracts a slack of 1e-6 of the
// coordinates' magnitude (the reference's: it covers the float rounding of the projections, an
// fma a GLSL driver may fuse, the axes' departure from unit length, and core's double rounding of
// a triangle's distance, so no triangle at the answer's distance, or tied with a lower id, is
// ever skipped), and a tiny absolute amount for drivers that flush float denormals to zero.
//
// Buffers (names as below): wide_boxes (float4), wide_links (uint), leaf_bounds (float4),
// leaf_slot (uint), slot_triangle (uint), slot_corners (double, 9 per slot), slot_features (uint,
// 6 per slot), face_normals (double, 3 per slot), edge_normals, vertex_normals (double, 3 per edge
// / vertex); layouts in core/device_scene.h.
#ifndef MCHEX_SDF_H
#define MCHEX_SDF_H
#ifndef MCHEX_FP32  // double precision throughout (kernels/dialect.h)

#ifndef MCHEX_SDF_PACKET
#define MCHEX_SDF_PACKET 1
#endif
// Whether the walk bounds each triangle of a leaf child in range (core/device/device_scene.h
// leaf_bounds: 17 float4 per leaf) before measuring it exactly, or measures them all. On lavapipe
// (texel reads) measuring all is faster (4.7x -> 3.8x the cpu reference's time): the bounds cost
// more fetches than the 1-2 exact tests per leaf they save, under a mask that the slowest lane
// sets. The OpenCL kernels and every other shader keep them.
#ifndef MCHEX_SDF_LEAF_BOUNDS
#define MCHEX_SDF_LEAF_BOUNDS 1
#endif
#ifndef GROUP_MIN
#define GROUP_MIN(x) (x)  // no subgroup: each invocation (or OpenCL work item) walks for its own packet
#endif
#ifndef GROUP_MAX
#define GROUP_MAX(x) (x)
#endif

// A loop budget, for llvmpipe (lavapipe): gallivm ends a shader's loops after 65,535 iterations
// in all (LP_MAX_TGSI_LOOP_ITERATIONS, one counter shared by every loop of a SIMD batch of
// invocations) and goes on with whatever the cut loop had, so a long walk would return a wrong
// value silently. With a budget the walk counts, before each step, the most loop iterations the
// step can take (every loop at its bound, whether or not a compiler unrolls it), stops when the
// count would pass the budget and says so (`incomplete`: the host evaluates that point itself).
// The count is kept per SIMD batch with GROUP_MAX (subgroupMax: llvmpipe's subgroup is its SIMD
// batch), where a loop runs as long as any lane needs it; without GROUP_MAX each lane counts its
// own and the host divides the budget by the lanes. Budget 0: no limit (every other device).
//   one step: the walk's back edge; per point, children_distance2's 3 and clearing its bits;
//   4 for finding the leaf children, and per leaf child (at most 4) its point loop; per child pushed, its point loop (the fixed part); then per point its exact tests,
//   each one iteration plus closest_point_on_triangle's loop of 3, at least one and at most 16
//   (the loop body runs once even when no point keeps a triangle).
#define MCHEX_SDF_LOOPS_PER_TEST (1 + 3)
#define MCHEX_SDF_LOOPS_PER_STEP_FIXED \
  (1 + MCHEX_SDF_PACKET * (1 + 3) + MCHEX_SDF_PACKET + 4 + 4 * (1 + MCHEX_SDF_PACKET) + 4 * (1 + MCHEX_SDF_PACKET))
#define MCHEX_SDF_LOOPS_PER_STEP \
  (MCHEX_SDF_LOOPS_PER_STEP_FIXED + MCHEX_SDF_PACKET * (1 + 16 * MCHEX_SDF_LOOPS_PER_TEST))
//   one search's setup: per point, the seed's closest_point_on_triangle, and the stack's first
//   entry; one more for the caller's loop over searches.
#define MCHEX_SDF_LOOPS_PER_SEARCH (MCHEX_SDF_PACKET * (1 + 3) + MCHEX_SDF_PACKET + 1)

// Reads of the scene's search arrays: array elements (OpenCL buffers, GLSL storage buffers),
// unless the GLSL wrapper has defined them to fetch from texel buffers instead
// (shaders/surface_sdf.glsl MCHEX_TEXEL_SCENE). WIDE_LINKS4(i): wide_links[4 i .. 4 i + 3].
#ifndef WIDE_BOX
#define WIDE_BOX(i) wide_boxes[i]
#define LEAF_BOUND(i) leaf_bounds[i]
#define LEAF_SLOT(i) leaf_slot[i]
#define SLOT_TRIANGLE(i) slot_triangle[i]
#define SLOT_CORNER(i) slot_corners[i]
#define SLOT_FEATURE(i) slot_features[i]
#ifdef __OPENCL_C_VERSION__
#define WIDE_LINKS4(i) vload4(i, wide_links)
#else
#define WIDE_LINKS4(i) uvec4(wide_links[4u * (i)], wide_links[4u * (i) + 1u], wide_links[4u * (i) + 2u], wide_links[4u * (i) + 3u])
#endif
#endif
#if MCHEX_WIDE_NODE_LINKS != 8
#error "the walk reads a node's links as two 4-vectors: child[4], count[4]"
#endif

#ifdef __OPENCL_C_VERSION__
#define DVEC3 double3
#define D3(x, y, z) ((double3)(x, y, z))
#define SCENE_PARAMS_                                                                                    \
  GLOBAL_RO float4 *wide_boxes, GLOBAL_RO uint *wide_links, GLOBAL_RO float4 *leaf_bounds,              \
      GLOBAL_RO uint *leaf_slot, GLOBAL_RO uint *slot_triangle, GLOBAL_RO double *slot_corners,          \
      GLOBAL_RO uint *slot_features, GLOBAL_RO double *face_normals, GLOBAL_RO double *edge_normals,     \
      GLOBAL_RO double *vertex_normals,
#define SCENE_ARGS_                                                                                      \
  wide_boxes, wide_links, leaf_bounds, leaf_slot, slot_triangle, slot_corners, slot_features, face_normals, \
      edge_normals, vertex_normals,
#define ISFINITE(x) isfinite(x)
#define FVEC3 float3
#define F3(x, y, z) ((float3)(x, y, z))
#define FVEC4 float4
#define F4(x) ((float4)(x))
#define UVEC4 uint4
#define MCHEX_F_INF INFINITY
// d where d <= b, else +inf (NaN too: a NaN bound never puts a child in range).
#define IN_RANGE4(d, b) select(F4(MCHEX_F_INF), d, (d) <= F4(b))
#else
#define DVEC3 dvec3
#define D3(x, y, z) dvec3(x, y, z)
#define SCENE_PARAMS_
#define SCENE_ARGS_
#define ISFINITE(x) (!(isinf(x) || isnan(x)))
#define FVEC3 vec3
#define F3(x, y, z) vec3(x, y, z)
#define FVEC4 vec4
#define F4(x) vec4(x)
#define UVEC4 uvec4
#define MCHEX_F_INF uintBitsToFloat(0x7F800000u)
#define IN_RANGE4(d, b) mix(F4(MCHEX_F_INF), d, lessThanEqual(d, F4(b)))
#endif

// Left to right, as core/base/geometry.h dot(): no dot() builtin, whose summation order is the
// driver's.
INLINE double dot3(DVEC3 a, DVEC3 b) {
  EXACT double s = a.x * b.x + a.y * b.y + a.z * b.z;
  return s;
}

// The surface SDF below names the scene buffers; a GLSL shader of the analytic shapes alone
// (shaders/shape_sdf.comp) defines MCHEX_SHAPES_ONLY and declares none of them.
#ifndef MCHEX_SHAPES_ONLY

STRUCT(ClosestPoint) {
  DVEC3 point;
  double squared_distance;
  int region;  // 0..2 vertex a/b/c, 3 edge ab, 4 edge bc, 5 edge ca, 6 interior (core/sdf/sdf.h)
};

INLINE ClosestPoint closest_point(DVEC3 q, double squared_distance, int region) {
  ClosestPoint r;
  r.point = q;
  r.squared_distance = squared_distance;
  r.region = region;
  return r;
}

// core/sdf/sdf.cpp closest_point_on_triangle, operation for operation.
INLINE ClosestPoint closest_point_on_triangle(DVEC3 p, DVEC3 a, DVEC3 b, DVEC3 c) {
  EXACT DVEC3 ab = b - a;
  EXACT DVEC3 ac = c - a;
  EXACT DVEC3 ap = p - a;
  EXACT double d1 = dot3(ab, ap);
  EXACT double d2 = dot3(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return closest_point(a, dot3(ap, ap), 0);
  EXACT DVEC3 bp = p - b;
  EXACT double d3 = dot3(ab, bp);
  EXACT double d4 = dot3(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return closest_point(b, dot3(bp, bp), 1);
  EXACT DVEC3 cp = p - c;
  EXACT double d5 = dot3(ab, cp);
  EXACT double d6 = dot3(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return closest_point(c, dot3(cp, cp), 2);
  EXACT double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    EXACT double t = d1 / (d1 - d3);
    EXACT DVEC3 q = a + t * ab;
    EXACT DVEC3 pq = p - q;
    return closest_point(q, dot3(pq, pq), 3);
  }
  EXACT double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    EXACT double t = d2 / (d2 - d6);
    EXACT DVEC3 q = a + t * ac;
    EXACT DVEC3 pq = p - q;
    return closest_point(q, dot3(pq, pq), 5);
  }
  EXACT double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
    EXACT double num = d4 - d3;
    EXACT double t = num / (num + (d5 - d6));
    EXACT DVEC3 bc = c - b;
    EXACT DVEC3 q = b + t * bc;
    EXACT DVEC3 pq = p - q;
    return closest_point(q, dot3(pq, pq), 4);
  }
  EXACT double sum = va + vb + vc;
  if (sum > 0.0 && ISFINITE(sum)) {
    EXACT double v = vb / sum;
    EXACT double w = vc / sum;
    EXACT DVEC3 q = (a + v * ab) + w * ac;
    EXACT DVEC3 pq = p - q;
    return closest_point(q, dot3(pq, pq), 6);
  }
  // Zero-area triangle that slipped past every edge test through rounding: the nearest of its
  // three edges (strictly nearer replaces, in the order ab, bc, ca, as in core).
  ClosestPoint best = closest_point(a, dot3(ap, ap), 0);
  for (int e = 0; e < 3; ++e) {
    EXACT DVEC3 u = e == 0 ? a : (e == 1 ? b : c);
    EXACT DVEC3 v = e == 0 ? b : (e == 1 ? c : a);
    EXACT DVEC3 uv = v - u;
    EXACT double len2 = dot3(uv, uv);
    EXACT double t = 0.0;
    if (len2 > 0.0) {
      EXACT double r = dot3(p - u, uv) / len2;
      t = r < 0.0 ? 0.0 : (1.0 < r ? 1.0 : r);  // std::clamp, NaN passes through
    }
    EXACT DVEC3 q = u + t * uv;
    EXACT DVEC3 pq = p - q;
    EXACT double d = dot3(pq, pq);
    if (d < best.squared_distance) best = closest_point(q, d, 3 + e);
  }
  return best;
}

// closest_point_on_triangle of the triangle in a slot (slot_corners: 9 doubles per slot).
#ifdef SLOT_CORNER_PAIRS
// The wrapper reads the corners two doubles at a time (SLOT_CORNER_PAIRS(k, lo, hi): doubles 2 k
// and 2 k + 1; the array padded to an even count): 5 reads per triangle instead of 9.
INLINE ClosestPoint closest_point_on_slot(SCENE_PARAMS_ DVEC3 p, uint slot) {
  uint first = 9u * slot, k = first >> 1u;
  bool odd = (first & 1u) != 0u;
  double d0, d1, d2, d3, d4, d5, d6, d7, d8, d9;
  SLOT_CORNER_PAIRS(k, d0, d1);
  SLOT_CORNER_PAIRS(k + 1u, d2, d3);
  SLOT_CORNER_PAIRS(k + 2u, d4, d5);
  SLOT_CORNER_PAIRS(k + 3u, d6, d7);
  SLOT_CORNER_PAIRS(k + 4u, d8, d9);
  DVEC3 a = odd ? D3(d1, d2, d3) : D3(d0, d1, d2);
  DVEC3 b = odd ? D3(d4, d5, d6) : D3(d3, d4, d5);
  DVEC3 c = odd ? D3(d7, d8, d9) : D3(d6, d7, d8);
  return closest_point_on_triangle(p, a, b, c);
}
#else
INLINE DVEC3 slot_corner(SCENE_PARAMS_ uint slot, int c) {
  uint i = 9u * slot + 3u * CAST(uint, c);
  return D3(SLOT_CORNER(i), SLOT_CORNER(i + 1u), SLOT_CORNER(i + 2u));
}

INLINE ClosestPoint closest_point_on_slot(SCENE_PARAMS_ DVEC3 p, uint slot) {
  return closest_point_on_triangle(p, slot_corner(SCENE_ARGS_ slot, 0), slot_corner(SCENE_ARGS_ slot, 1),
                                   slot_corner(SCENE_ARGS_ slot, 2));
}
#endif

// Component c of v (OpenCL C 1.2 has no run-time index into a vector).
INLINE float lane4(FVEC4 v, int c) { return c == 0 ? v.x : (c == 1 ? v.y : (c == 2 ? v.z : v.w)); }
INLINE uint ulane4(UVEC4 v, int c) { return c == 0 ? v.x : (c == 1 ? v.y : (c == 2 ? v.z : v.w)); }

// Lower bounds of the squared distance from p to the triangles under each of wide node n's four
// children (core/device/device_scene.h wide_boxes), less the slack; +inf for an absent child.
INLINE FVEC4 children_distance2(SCENE_PARAMS_ uint n, FVEC3 p, float slack) {
  uint b = CAST(uint, MCHEX_WIDE_NODE_FLOAT4S) * n;
  FVEC4 d2 = F4(0.0f);
  for (uint a = 0u; a < 3u; ++a) {
    FVEC4 t = WIDE_BOX(b + 3u * a) * p.x + WIDE_BOX(b + 3u * a + 1u) * p.y + WIDE_BOX(b + 3u * a + 2u) * p.z;
    FVEC4 d = max(max(WIDE_BOX(b + 9u + a) - t, t - WIDE_BOX(b + 12u + a)) - F4(slack), F4(0.0f));
    d2 += d * d;
  }
  return d2;
}

// Lower bounds of the squared distance from p to each of leaf l's triangles (core/device/device_scene.h
// leaf_bounds: plane interval and edge lines), less the slack; +inf for an absent lane.
INLINE FVEC4 triangles_distance2(SCENE_PARAMS_ uint l, FVEC3 p, float slack) {
  uint b = CAST(uint, MCHEX_LEAF_BOUND_FLOAT4S) * l;
  FVEC4 t = LEAF_BOUND(b) * p.x + LEAF_BOUND(b + 1u) * p.y + LEAF_BOUND(b + 2u) * p.z;
  FVEC4 dp = max(max(LEAF_BOUND(b + 3u) - t, t - LEAF_BOUND(b + 4u)) - F4(slack), F4(0.0f));
  FVEC4 de = LEAF_BOUND(b + 5u) * p.x + LEAF_BOUND(b + 6u) * p.y + LEAF_BOUND(b + 7u) * p.z - LEAF_BOUND(b + 14u);
  de = max(de, LEAF_BOUND(b + 8u) * p.x + LEAF_BOUND(b + 9u) * p.y + LEAF_BOUND(b + 10u) * p.z - LEAF_BOUND(b + 15u));
  de = max(de, LEAF_BOUND(b + 11u) * p.x + LEAF_BOUND(b + 12u) * p.y + LEAF_BOUND(b + 13u) * p.z - LEAF_BOUND(b + 16u));
  de = max(de - F4(slack), F4(0.0f));
  return dp * dp + de * de;
}

// A float at least the double squared distance d, so that comparing a float bound with it never
// prunes at the bound: float(d) may round down by an ulp (or toward zero, in GLSL), the factor
// 1 + 2^-20 more than makes up for it, and the floor 2^-126 for a d that flushes to zero.
INLINE float bound_up(double d) {
  float f = CAST(float, d) * (1.0f + CAST(float, 9.5367431640625e-07));
  return max(f, CAST(float, 1.1754943508222875e-38));
}

// The four children's indices, by key (ties in either order: the walk's result does not depend
// on its order).
STRUCT(SortedChildren) {
  int o0, o1, o2, o3;
  float k0, k1, k2, k3;
};

INLINE SortedChildren compare_exchange(SortedChildren s, int a, int b) {
  float ka = a == 0 ? s.k0 : (a == 1 ? s.k1 : s.k2);
  float kb = b == 1 ? s.k1 : (b == 2 ? s.k2 : s.k3);
  if (!(kb < ka)) return s;
  int oa = a == 0 ? s.o0 : (a == 1 ? s.o1 : s.o2);
  int ob = b == 1 ? s.o1 : (b == 2 ? s.o2 : s.o3);
  if (a == 0) s.o0 = ob, s.k0 = kb;
  if (a == 1) s.o1 = ob, s.k1 = kb;
  if (a == 2) s.o2 = ob, s.k2 = kb;
  if (b == 1) s.o1 = oa, s.k1 = ka;
  if (b == 2) s.o2 = oa, s.k2 = ka;
  if (b == 3) s.o3 = oa, s.k3 = ka;
  return s;
}

INLINE SortedChildren sort_children(FVEC4 key) {
  SortedChildren s;
  s.o0 = 0;
  s.o1 = 1;
  s.o2 = 2;
  s.o3 = 3;
  s.k0 = key.x;
  s.k1 = key.y;
  s.k2 = key.z;
  s.k3 = key.w;
  s = compare_exchange(s, 0, 1);
  s = compare_exchange(s, 2, 3);
  s = compare_exchange(s, 0, 2);
  s = compare_exchange(s, 1, 3);
  s = compare_exchange(s, 1, 2);
  return s;
}

STRUCT(SurfaceHit) {
  ClosestPoint best;
  uint slot;
};

// A packet of points searched together: in p[0 .. lanes), seed (any slot per point: the result
// does not depend on it, but a neighbour's answer makes the first bound tight); out hit.
// budget and spent: the loop budget above (0: none) and the iterations counted so far, carried
// from one search to the next of the same invocation; incomplete: set when the budget ran out
// (the hits are then meaningless).
STRUCT(SurfacePacket) {
  DVEC3 p[MCHEX_SDF_PACKET];
  uint seed[MCHEX_SDF_PACKET];
  SurfaceHit hit[MCHEX_SDF_PACKET];
  int lanes;
  uint budget;
  uint spent;
  int incomplete;
};

INLINE SurfacePacket closest_on_surface(SCENE_PARAMS_ SurfacePacket q, double scale) {
  FVEC3 pf[MCHEX_SDF_PACKET];
  float slack[MCHEX_SDF_PACKET], best2[MCHEX_SDF_PACKET];
  uint best_triangle[MCHEX_SDF_PACKET];
  q.incomplete = 0;
  if (q.budget != 0u) q.spent = GROUP_MAX(q.spent) + CAST(uint, MCHEX_SDF_LOOPS_PER_SEARCH);
  for (int l = 0; l < MCHEX_SDF_PACKET; ++l) {
    pf[l] = F3(0.0f, 0.0f, 0.0f);
    slack[l] = 0.0f;
    best2[l] = -1.0f;  // lanes past q.lanes are never in range of anything
    best_triangle[l] = 0u;
    if (l >= q.lanes) continue;
    DVEC3 x = q.p[l];
    pf[l] = F3(CAST(float, x.x), CAST(float, x.y), CAST(float, x.z));
    // (In GLSL 1e-6 is a float widened to double: any value near 1e-6 serves as the margin.)
    slack[l] = CAST(float, 1e-6 * (3.0 * max(max(FABS(x.x), FABS(x.y)), FABS(x.z)) + 2.0 * scale)) +
               CAST(float, 1e-30);
    uint s = q.seed[l];
    q.hit[l].slot = s;
    q.hit[l].best = closest_point_on_slot(SCENE_ARGS_ x, s);
    best_triangle[l] = SLOT_TRIANGLE(s);
    best2[l] = bound_up(q.hit[l].best.squared_distance);
  }
  // Pending nodes, each with every point's lower bound of it when it was pushed (a point whose
  // best has shrunk below that since skips the node). core/device/device_scene.h sizes the stack.
  uint stack_node[MCHEX_SDF_WIDE_STACK];
  float stack_d2[MCHEX_SDF_WIDE_STACK * MCHEX_SDF_PACKET];
  stack_node[0] = 0u;
  for (int l = 0; l < MCHEX_SDF_PACKET; ++l) stack_d2[l] = 0.0f;
  int top = 1;
  while (top > 0) {
    if (q.budget != 0u) {
      // The step's fixed loops now; its exact tests when they are known (below). Stop unless the
      // most a step can take still fits.
      q.spent = GROUP_MAX(q.spent);
      if (q.spent + CAST(uint, MCHEX_SDF_LOOPS_PER_STEP) > q.budget) {
        q.incomplete = 1;
        break;
      }
      q.spent += CAST(uint, MCHEX_SDF_LOOPS_PER_STEP_FIXED);
    }
    --top;
    uint node = stack_node[top];
    FVEC4 d2[MCHEX_SDF_PACKET];
    FVEC4 key = F4(MCHEX_F_INF);  // each child's distance from the nearest point it is in range of
    for (int l = 0; l < MCHEX_SDF_PACKET; ++l) {
      if (stack_d2[top * MCHEX_SDF_PACKET + l] > best2[l]) {
        d2[l] = F4(MCHEX_F_INF);
      } else {
        d2[l] = children_distance2(SCENE_ARGS_ node, pf[l], slack[l]);
        key = min(key, IN_RANGE4(d2[l], best2[l]));
      }
    }
    key = GROUP_MIN(key);
    // Children nearest first: leaves measured at once (shrinking the bounds), inner children
    // pushed farthest first so that the nearest is popped next. The order comes from a sorting
    // network on scalars (Knuth, TAOCP 5.3.4: five comparators sort four keys): no loop over a
    // local array written at run-time indices: an insertion sort written that way gave wrong
    // orders (and wrong values) on lavapipe (Mesa 22.3), not on PoCL; not investigated further.
    SortedChildren s = sort_children(key);
    int order[4];
    order[0] = s.o0;
    order[1] = s.o1;
    order[2] = s.o2;
    order[3] = s.o3;
    // The node's links (core/device/device_scene.h wide_links): child[4], then count[4].
    UVEC4 child = WIDE_LINKS4(2u * node), count4 = WIDE_LINKS4(2u * node + 1u);
    // The leaf children's triangles that each point's float bound keeps, as bits 4 c + t, then
    // measured exactly in one loop per point. Collecting first and measuring once costs a few
    // more exact tests than measuring child by child (the bound does not shrink between leaf
    // children of one node), but a SIMD compiler that runs every if-body under a mask (llvmpipe)
    // then runs the exact test max(1, kept) times per step instead of once per triangle slot.
    uint kept[MCHEX_SDF_PACKET];
    for (int l = 0; l < MCHEX_SDF_PACKET; ++l) kept[l] = 0u;
#if MCHEX_SDF_LEAF_BOUNDS
    // The leaf children in range, visited by a loop over their bits (not an if per child, which
    // a masked SIMD compiler would run four times per step whatever the bits).
    uint leaves = 0u;
    for (int c = 0; c < 4; ++c)
      if (lane4(key, c) != MCHEX_F_INF && ulane4(count4, c) != 0u) leaves |= 1u << CAST(uint, c);
    while (leaves != 0u) {
      int c = LOWEST_BIT(leaves);
      leaves &= leaves - 1u;
      uint count = ulane4(count4, c);
      uint leaf = ulane4(child, c);
      for (int l = 0; l < MCHEX_SDF_PACKET; ++l) {
        if (lane4(d2[l], c) <= best2[l]) {
          FVEC4 t2 = triangles_distance2(SCENE_ARGS_ leaf, pf[l], slack[l]);
          uint bits = (t2.x <= best2[l] ? 1u : 0u) | (t2.y <= best2[l] ? 2u : 0u) | (t2.z <= best2[l] ? 4u : 0u) |
                      (t2.w <= best2[l] ? 8u : 0u);
          kept[l] |= (bits & ((1u << count) - 1u)) << (4u * CAST(uint, c));
        }
      }
    }
#else
    // Every triangle of each leaf child in range of the point.
    for (int l = 0; l < MCHEX_SDF_PACKET; ++l)
      for (int c = 0; c < 4; ++c)
        if (lane4(d2[l], c) <= best2[l]) kept[l] |= ((1u << ulane4(count4, c)) - 1u) << (4u * CAST(uint, c));
#endif
    for (int l = 0; l < MCHEX_SDF_PACKET; ++l) {
      uint bits = kept[l];
      if (q.budget != 0u) q.spent += 1u + CAST(uint, MCHEX_SDF_LOOPS_PER_TEST) * max(1u, POPCOUNT(bits));
      while (bits != 0u) {
        int b = LOWEST_BIT(bits);
        bits &= bits - 1u;
        uint slot = LEAF_SLOT(ulane4(child, b >> 2)) + CAST(uint, b & 3);
        ClosestPoint cp = closest_point_on_slot(SCENE_ARGS_ q.p[l], slot);
        uint id = SLOT_TRIANGLE(slot);
        if (cp.squared_distance < q.hit[l].best.squared_distance ||
            (cp.squared_distance == q.hit[l].best.squared_distance && id < best_triangle[l])) {
          q.hit[l].best = cp;
          q.hit[l].slot = slot;
          best_triangle[l] = id;
          best2[l] = bound_up(cp.squared_distance);
        }
      }
    }
    for (int i = 3; i >= 0; --i) {
      int c = order[i];
      if (lane4(key, c) != MCHEX_F_INF && ulane4(count4, c) == 0u) {
        stack_node[top] = ulane4(child, c);
        for (int l = 0; l < MCHEX_SDF_PACKET; ++l) stack_d2[top * MCHEX_SDF_PACKET + l] = lane4(d2[l], c);
        ++top;
      }
    }
  }
  return q;
}

// core/device/device_scene.h pseudonormal_signed_value on the hit.
INLINE double signed_value_of(SCENE_PARAMS_ DVEC3 p, SurfaceHit hit) {
  EXACT double d = sqrt(hit.best.squared_distance);
  if (d == 0.0) return 0.0;
  int region = hit.best.region;
  DVEC3 normal;
  if (region < 6) {
    uint id = SLOT_FEATURE(6u * hit.slot + CAST(uint, region));
    if (region < 3)
      normal = D3(vertex_normals[3u * id], vertex_normals[3u * id + 1u], vertex_normals[3u * id + 2u]);
    else
      normal = D3(edge_normals[3u * id], edge_normals[3u * id + 1u], edge_normals[3u * id + 2u]);
  } else {
    normal = D3(face_normals[3u * hit.slot], face_normals[3u * hit.slot + 1u], face_normals[3u * hit.slot + 2u]);
  }
  EXACT DVEC3 offset = p - hit.best.point;
  return dot3(offset, normal) > 0.0 ? -d : d;
}

#endif  // MCHEX_SHAPES_ONLY

// ---- Analytic shapes: core/sdf/shapes.cpp, operation for operation -------------------------------

INLINE double planar_norm(double a, double b) {
  EXACT double s = a * a + b * b;
  return sqrt(s);
}

INLINE double circle_distance(DVEC3 p, double cx, double radius) {
  EXACT double r = planar_norm(p.x - cx, p.y) - radius;
  return planar_norm(r, p.z);
}

// kind: core/sdf/shapes.h ShapeKind (0 sphere, 1 torus, 2 rounded box, 3 two-holed).
INLINE double shape_sdf(int kind, DVEC3 p) {
  if (kind == 0) {
    EXACT double r = MCHEX_SPHERE_RADIUS - sqrt(dot3(p, p));
    return r;
  }
  if (kind == 1) {
    EXACT double r = MCHEX_TORUS_MINOR - planar_norm(planar_norm(p.x, p.y) - MCHEX_TORUS_MAJOR, p.z);
    return r;
  }
  if (kind == 2) {
    EXACT double qx = FABS(p.x) - (MCHEX_BOX_HALF_X - MCHEX_BOX_ROUNDING);
    EXACT double qy = FABS(p.y) - (MCHEX_BOX_HALF_Y - MCHEX_BOX_ROUNDING);
    EXACT double qz = FABS(p.z) - (MCHEX_BOX_HALF_Z - MCHEX_BOX_ROUNDING);
    // std::max(q, 0.0), std::max({...}) and std::min(m, 0.0) with their comparison order.
    EXACT DVEC3 o = D3(qx < 0.0 ? 0.0 : qx, qy < 0.0 ? 0.0 : qy, qz < 0.0 ? 0.0 : qz);
    EXACT double m = qx;
    if (m < qy) m = qy;
    if (m < qz) m = qz;
    EXACT double inner = 0.0 < m ? 0.0 : m;
    EXACT double r = -((sqrt(dot3(o, o)) + inner) - MCHEX_BOX_ROUNDING);
    return r;
  }
  EXACT double d0 = circle_distance(p, -MCHEX_EIGHT_RING, MCHEX_EIGHT_RING);
  EXACT double d1 = circle_distance(p, MCHEX_EIGHT_RING, MCHEX_EIGHT_RING);
  EXACT double d = d1 < d0 ? d1 : d0;
  EXACT double r = MCHEX_EIGHT_TUBE - d;
  return r;
}

#endif  // MCHEX_FP32
#endif
