// Double-precision geometry of core/sdf.cpp and core/shapes.cpp for the SDF shaders, written to
// round exactly as the reference does: the same operations in the same order, every result
// `precise` (no fused multiply-add), dot products left to right as core/geometry.h's dot().
// The reference is compiled without FMA contraction (GCC on x86-64 without -mfma), so plain
// IEEE double +, -, *, / and sqrt give the same bits here.
#ifndef MCHEX_SHADERS_SDF_GEOMETRY_GLSL
#define MCHEX_SHADERS_SDF_GEOMETRY_GLSL

double dot3(dvec3 a, dvec3 b) {
  precise const double r = a.x * b.x + a.y * b.y + a.z * b.z;
  return r;
}

dvec3 sub3(dvec3 a, dvec3 b) {
  precise const dvec3 r = a - b;
  return r;
}

// a + s * v, componentwise, multiply then add (as core/geometry.h's operator+ and operator*).
dvec3 axpy3(dvec3 a, double s, dvec3 v) {
  precise const dvec3 r = a + s * v;
  return r;
}

// std::clamp(v, lo, hi) for lo <= hi: v < lo ? lo : (hi < v ? hi : v).
double clamp_like_std(double v, double lo, double hi) { return v < lo ? lo : (hi < v ? hi : v); }

bool is_finite(double x) { return !isnan(x) && !isinf(x); }

// core/sdf.cpp closest_point_on_triangle: Ericson's Voronoi-region walk (Real-Time Collision
// Detection 5.1.5). region: 0..2 vertex a/b/c, 3 edge ab, 4 edge bc, 5 edge ca, 6 interior.
struct ClosestPoint {
  dvec3 point;
  double squared_distance;
  int region;
};

ClosestPoint closest_point_on_triangle(dvec3 p, dvec3 a, dvec3 b, dvec3 c) {
  const dvec3 ab = sub3(b, a), ac = sub3(c, a), ap = sub3(p, a);
  const double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return ClosestPoint(a, dot3(ap, ap), 0);
  const dvec3 bp = sub3(p, b);
  const double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return ClosestPoint(b, dot3(bp, bp), 1);
  const dvec3 cp = sub3(p, c);
  const double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return ClosestPoint(c, dot3(cp, cp), 2);
  precise const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    precise const double t = d1 / (d1 - d3);
    const dvec3 q = axpy3(a, t, ab);
    const dvec3 pq = sub3(p, q);
    return ClosestPoint(q, dot3(pq, pq), 3);
  }
  precise const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    precise const double t = d2 / (d2 - d6);
    const dvec3 q = axpy3(a, t, ac);
    const dvec3 pq = sub3(p, q);
    return ClosestPoint(q, dot3(pq, pq), 5);
  }
  precise const double va = d3 * d6 - d5 * d4;
  precise const double d43 = d4 - d3, d56 = d5 - d6;
  if (va <= 0.0 && d43 >= 0.0 && d56 >= 0.0) {
    precise const double t = d43 / (d43 + d56);
    const dvec3 q = axpy3(b, t, sub3(c, b));
    const dvec3 pq = sub3(p, q);
    return ClosestPoint(q, dot3(pq, pq), 4);
  }
  precise const double sum = va + vb + vc;
  if (sum > 0.0 && is_finite(sum)) {
    precise const double s = vb / sum, t = vc / sum;
    // a + s * ab + t * ac, evaluated as (a + s * ab) + t * ac.
    const dvec3 q = axpy3(axpy3(a, s, ab), t, ac);
    const dvec3 pq = sub3(p, q);
    return ClosestPoint(q, dot3(pq, pq), 6);
  }
  // Zero-area triangle that slipped past every edge test through rounding: nearest edge.
  ClosestPoint best = ClosestPoint(a, dot3(ap, ap), 0);
  for (int e = 0; e < 3; ++e) {
    const dvec3 u = e == 0 ? a : (e == 1 ? b : c);
    const dvec3 v = e == 0 ? b : (e == 1 ? c : a);
    const dvec3 uv = sub3(v, u);
    const double len2 = dot3(uv, uv);
    precise const double ratio = dot3(sub3(p, u), uv) / len2;
    const double t = len2 > 0.0 ? clamp_like_std(ratio, 0.0, 1.0) : 0.0;
    const dvec3 q = axpy3(u, t, uv);
    const dvec3 pq = sub3(p, q);
    const double d = dot3(pq, pq);
    if (d < best.squared_distance) best = ClosestPoint(q, d, 3 + e);
  }
  return best;
}

// core/sdf.cpp's sign rule: 0 on the surface; outside (positive distance) unless the offset to
// the closest point points against the feature's pseudonormal.
double signed_value(dvec3 p, ClosestPoint cp, dvec3 pseudonormal) {
  precise const double d = sqrt(cp.squared_distance);
  if (d == 0.0) return 0.0;
  return dot3(sub3(p, cp.point), pseudonormal) > 0.0 ? -d : d;
}

// std::hypot as glibc 2.36 computes it for operands in [2^-511, 2^511] (its generic dbl-64
// code, no FMA): Borges' corrected square root (C. F. Borges, An Improved Algorithm for
// hypot(a, b), arXiv:1904.09481, 2019, the fma-free correction), which is correctly rounded in
// all but rare cases; test_vulkan checks it against std::hypot bit for bit.
double hypot_kernel(double ax, double ay) {
  precise double h = sqrt(ax * ax + ay * ay);
  precise double t1, t2;
  if (h <= 2.0 * ay) {
    precise const double delta = h - ay;
    t1 = ax * (2.0 * delta - ax);
    t2 = (delta - 2.0 * (ax - ay)) * delta;
  } else {
    precise const double delta = h - ax;
    t1 = 2.0 * delta * (ax - 2.0 * ay);
    t2 = (4.0 * delta - ay) * ay + delta * delta;
  }
  precise const double r = h - (t1 + t2) / (2.0 * h);
  return r;
}

double hypot_like_glibc(double x, double y) {
  if (isinf(x) || isinf(y)) return packDouble2x32(uvec2(0u, 0x7ff00000u));
  if (isnan(x) || isnan(y)) return x + y;
  x = abs(x);
  y = abs(y);
  const double ax = x < y ? y : x, ay = x < y ? x : y;
  // Scale by powers of two (exact) out of the range where ax * ax could overflow or ay * ay
  // underflow, as glibc does.
  // 2^-600, 2^511, 2^-511, 2^-54 (GLSL has no hexadecimal float literals): biased exponent
  // e in bits 20..30 of the high word, zero mantissa.
  const double kScale = packDouble2x32(uvec2(0u, 423u << 20)), kLarge = packDouble2x32(uvec2(0u, 1534u << 20)),
               kTiny = packDouble2x32(uvec2(0u, 512u << 20)), kEps = packDouble2x32(uvec2(0u, 969u << 20));
  if (ax > kLarge) {
    if (ay <= ax * kEps) { precise const double r = ax + ay; return r; }
    precise const double r = hypot_kernel(ax * kScale, ay * kScale) / kScale;
    return r;
  }
  if (ay < kTiny) {
    if (ax >= ay / kEps) { precise const double r = ax + ay; return r; }
    precise const double r = hypot_kernel(ax / kScale, ay / kScale) * kScale;
    return r;
  }
  if (ay <= ax * kEps) { precise const double r = ax + ay; return r; }
  return hypot_kernel(ax, ay);
}

#endif
