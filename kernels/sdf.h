// Signed distance on a device, in the common dialect of kernels/dialect.h (OpenCL C and GLSL):
// the same arithmetic, in the same order, as core/sdf.cpp and core/shapes.cpp, so that every
// value equals the CPU reference bit for bit.
//
// Surface SDF: nearest-first traversal of core/bvh.h's binary BVH with a small stack; every
// candidate triangle measured in double by closest_point_on_triangle (Ericson's Voronoi-region
// walk, the same regions as core); the answer is the minimum squared distance and, among equal
// ones, the LOWEST triangle id (SurfaceSdf's tie rule), which is what makes the result independent
// of the traversal order and of the seed; the sign from the angle-weighted pseudonormal of the
// closest feature (core/device_scene.h).
//
// Pruning is conservative by construction: node bounds are floats rounded outward from the double
// triangles (core/bvh.cpp), and the distance to a box is reduced by a slack of 1e-12 of the
// coordinates' magnitude, far above the few ulps by which a computed triangle distance can
// undercut the true one, so no node that holds the answer (or a tie with a lower id) is skipped.
//
// Buffers (names as below): nodes (BvhNode), slot_triangle (uint), slot_corners (double, 9 per
// slot), slot_features (uint, 6 per slot), face_normals (double, 3 per slot), edge_normals,
// vertex_normals (double, 3 per edge / vertex).
#ifndef MCHEX_SDF_H
#define MCHEX_SDF_H
#ifndef MCHEX_FP32  // double precision throughout (kernels/dialect.h)

#ifdef __OPENCL_C_VERSION__
#define DVEC3 double3
#define D3(x, y, z) ((double3)(x, y, z))
#define SCENE_PARAMS_                                                                            \
  GLOBAL_RO BvhNode *nodes, GLOBAL_RO uint *slot_triangle, GLOBAL_RO double *slot_corners,        \
      GLOBAL_RO uint *slot_features, GLOBAL_RO double *face_normals, GLOBAL_RO double *edge_normals, \
      GLOBAL_RO double *vertex_normals,
#define SCENE_ARGS_ nodes, slot_triangle, slot_corners, slot_features, face_normals, edge_normals, vertex_normals,
#define ISFINITE(x) isfinite(x)
#else
#define DVEC3 dvec3
#define D3(x, y, z) dvec3(x, y, z)
#define SCENE_PARAMS_
#define SCENE_ARGS_
#define ISFINITE(x) (!(isinf(x) || isnan(x)))
#endif

// Left to right, as core/geometry.h dot(): no dot() builtin, whose summation order is the
// driver's.
INLINE double dot3(DVEC3 a, DVEC3 b) {
  EXACT double s = a.x * b.x + a.y * b.y + a.z * b.z;
  return s;
}

STRUCT(ClosestPoint) {
  DVEC3 point;
  double squared_distance;
  int region;  // 0..2 vertex a/b/c, 3 edge ab, 4 edge bc, 5 edge ca, 6 interior (core/sdf.h)
};

INLINE ClosestPoint closest_point(DVEC3 q, double squared_distance, int region) {
  ClosestPoint r;
  r.point = q;
  r.squared_distance = squared_distance;
  r.region = region;
  return r;
}

// core/sdf.cpp closest_point_on_triangle, operation for operation.
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

INLINE DVEC3 slot_corner(SCENE_PARAMS_ uint slot, int c) {
  uint i = 9u * slot + 3u * CAST(uint, c);
  return D3(slot_corners[i], slot_corners[i + 1u], slot_corners[i + 2u]);
}

// Lower bound of the squared distance from p to anything inside node n's box, less the slack.
INLINE double box_distance2(SCENE_PARAMS_ uint n, DVEC3 p, double slack) {
  EXACT double dx = max(max(CAST(double, nodes[n].lo[0]) - p.x, p.x - CAST(double, nodes[n].hi[0])) - slack, 0.0);
  EXACT double dy = max(max(CAST(double, nodes[n].lo[1]) - p.y, p.y - CAST(double, nodes[n].hi[1])) - slack, 0.0);
  EXACT double dz = max(max(CAST(double, nodes[n].lo[2]) - p.z, p.z - CAST(double, nodes[n].hi[2])) - slack, 0.0);
  EXACT double d2 = dx * dx + dy * dy + dz * dz;
  return d2;
}

STRUCT(SurfaceHit) {
  ClosestPoint best;
  uint slot;
};

#define MCHEX_SDF_STACK 72  // > the BVH's maximum depth (64, core/bvh.cpp): one pending sibling per level

// The closest triangle to p, starting from the seed slot (any slot: the result does not depend on
// it, but the previous point's answer makes the first bound tight on a grid).
INLINE SurfaceHit closest_on_surface(SCENE_PARAMS_ DVEC3 p, uint seed, double scale) {
  SurfaceHit hit;
  hit.slot = seed;
  hit.best = closest_point_on_triangle(p, slot_corner(SCENE_ARGS_ seed, 0), slot_corner(SCENE_ARGS_ seed, 1),
                                       slot_corner(SCENE_ARGS_ seed, 2));
  uint best_triangle = slot_triangle[seed];
  // (In GLSL 1e-12 is a float widened to double: any value near 1e-12 serves as the margin.)
  EXACT double slack = 1e-12 * (3.0 * max(max(FABS(p.x), FABS(p.y)), FABS(p.z)) + 2.0 * scale);
  uint stack_node[MCHEX_SDF_STACK];
  double stack_d2[MCHEX_SDF_STACK];
  int top = 0;
  stack_node[0] = 0u;
  stack_d2[0] = 0.0;
  top = 1;
  while (top > 0) {
    --top;
    if (stack_d2[top] > hit.best.squared_distance) continue;
    uint n = stack_node[top];
    uint count = nodes[n].count;
    if (count > 0u) {
      uint first = nodes[n].index;
      for (uint k = first; k < first + count; ++k) {
        ClosestPoint cp = closest_point_on_triangle(p, slot_corner(SCENE_ARGS_ k, 0), slot_corner(SCENE_ARGS_ k, 1),
                                                    slot_corner(SCENE_ARGS_ k, 2));
        uint t = slot_triangle[k];
        if (cp.squared_distance < hit.best.squared_distance ||
            (cp.squared_distance == hit.best.squared_distance && t < best_triangle)) {
          hit.best = cp;
          hit.slot = k;
          best_triangle = t;
        }
      }
      continue;
    }
    uint left = n + 1u, right = nodes[n].index;
    double dl = box_distance2(SCENE_ARGS_ left, p, slack);
    double dr = box_distance2(SCENE_ARGS_ right, p, slack);
    // Farther child first, so that the nearer one is popped next.
    uint near_node = dl <= dr ? left : right, far_node = dl <= dr ? right : left;
    double near_d2 = dl <= dr ? dl : dr, far_d2 = dl <= dr ? dr : dl;
    if (far_d2 <= hit.best.squared_distance && top < MCHEX_SDF_STACK) {
      stack_node[top] = far_node;
      stack_d2[top] = far_d2;
      ++top;
    }
    if (near_d2 <= hit.best.squared_distance && top < MCHEX_SDF_STACK) {
      stack_node[top] = near_node;
      stack_d2[top] = near_d2;
      ++top;
    }
  }
  return hit;
}

// core/device_scene.h pseudonormal_signed_value on the hit.
INLINE double signed_value_of(SCENE_PARAMS_ DVEC3 p, SurfaceHit hit) {
  EXACT double d = sqrt(hit.best.squared_distance);
  if (d == 0.0) return 0.0;
  int region = hit.best.region;
  DVEC3 normal;
  if (region < 6) {
    uint id = slot_features[6u * hit.slot + CAST(uint, region)];
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

// ---- Analytic shapes: core/shapes.cpp, operation for operation -------------------------------

INLINE double planar_norm(double a, double b) {
  EXACT double s = a * a + b * b;
  return sqrt(s);
}

INLINE double circle_distance(DVEC3 p, double cx, double radius) {
  EXACT double r = planar_norm(p.x - cx, p.y) - radius;
  return planar_norm(r, p.z);
}

// kind: core/shapes.h ShapeKind (0 sphere, 1 torus, 2 rounded box, 3 two-holed).
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
