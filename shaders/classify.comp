#version 450
// MC33 classification of one cell per invocation: core/mc33.cpp classify() for the fields of a
// CellCode (host/backend.h), and the cell's hex count 8 + 2 * (cut edges) for the prefix sum.
// The decisions are made with the reference's arithmetic: the exact-sign Kahan determinant of
// the asymptotic decider [N] (fma, as std::fma), and Chernyaev's slice test at t* = -b / 2a with
// the same rounding steps (`precise`: no contraction). Every table comes from core through the
// lookup buffer (shaders/classify_layout.h).
#extension GL_GOOGLE_include_directive : require
#include "shaders/classify_layout.h"
layout(local_size_x = 64) in;

// gathered == 0: values[] holds f at every grid point and cells[] 8 point ids per cell;
// gathered == 1: values[] holds the 8 corner values of every cell of the chunk (the host
// gathers them when the point values exceed one storage buffer).
layout(std430, binding = 0) readonly buffer Values { double values[]; };
layout(std430, binding = 1) readonly buffer Cells { uint cell_points[]; };
layout(std430, binding = 2) readonly buffer Tables { uint tables[]; };
layout(std430, binding = 3) writeonly buffer Codes { uint codes[]; };
layout(std430, binding = 4) writeonly buffer Counts { uint counts[]; };
layout(push_constant) uniform Push { uint cells; uint gathered; } pc;

uint edge_end(int e, int k) { return (tables[MCHEX_TABLE_EDGES + e] >> (8 * k)) & 0xFFu; }
uint face_corner(int f, int k) { return (tables[MCHEX_TABLE_FACES + f] >> (8 * k)) & 0xFFu; }

// Sign-exact a*b - c*d (Kahan; relative error <= 2u [JLM]), as kahan_det in mc33.cpp.
double kahan_det(double a, double b, double c, double d) {
  precise const double w = c * d;
  precise const double e = fma(-c, d, w);
  precise const double f = fma(a, b, -w);
  precise const double r = f + e;
  return r;
}

bool connected(uint adj[8], uint from, uint to) {
  uint comp = 1u << from, frontier = comp;
  while (frontier != 0u) {
    uint next = 0u;
    for (uint m = frontier; m != 0u; m &= m - 1u) next |= adj[findLSB(m)];
    next &= ~comp;
    comp |= next;
    frontier = next;
  }
  return (comp >> to & 1u) != 0u;
}

// mc33.cpp interior_join: the extremum of the z-slice saddle quadratic.
bool interior_join(double f[8], out uint c1, out uint c2) {
  c1 = 0u;
  c2 = 0u;
  const double b0 = f[0], b1 = f[1], b2 = f[2], b3 = f[3];
  precise const double d0 = f[4] - f[0], d1 = f[5] - f[1], d2 = f[6] - f[2], d3 = f[7] - f[3];
  precise const double qa = d0 * d2 - d1 * d3;
  precise const double qb = b0 * d2 + b2 * d0 - b1 * d3 - b3 * d1;
  if (qa == 0.0) return false;
  precise const double ts = -qb / (2.0 * qa);
  if (!(ts > 0.0 && ts < 1.0)) return false;
  precise const double v0 = b0 + ts * d0, v1 = b1 + ts * d1, v2 = b2 + ts * d2, v3 = b3 + ts * d3;
  const bool p0 = v0 > 0.0, p1 = v1 > 0.0, p2 = v2 > 0.0, p3 = v3 > 0.0;
  if (p0 != p2 || p1 != p3 || p0 == p1) return false;
  precise const double q = v0 * v2 - v1 * v3;
  uint k1, k2;
  bool positive;
  if (qa < 0.0) {
    if (!(q > 0.0 || (q == 0.0 && p0))) return false;
    k1 = 0u; k2 = 2u; positive = p0;
  } else {
    if (!(q < 0.0 || (q == 0.0 && p1))) return false;
    k1 = 1u; k2 = 3u; positive = p1;
  }
  c1 = ((f[k1] > 0.0) == positive) ? k1 : k1 + 4u;
  c2 = ((f[k2] > 0.0) == positive) ? k2 : k2 + 4u;
  return true;
}

void main() {
  const uint cell = gl_GlobalInvocationID.x;
  if (cell >= pc.cells) return;
  double f[8];
  for (uint c = 0u; c < 8u; ++c)
    f[c] = pc.gathered != 0u ? values[8u * cell + c] : values[cell_points[8u * cell + c]];

  uint mask = 0u;
  for (uint c = 0u; c < 8u; ++c)
    if (f[c] > 0.0) mask |= 1u << c;
  uint cut = 0u, neighbours[8] = uint[8](0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
  for (int e = 0; e < 12; ++e) {
    const uint a = edge_end(e, 0), b = edge_end(e, 1);
    neighbours[a] |= 1u << b;
    neighbours[b] |= 1u << a;
    if ((mask >> a & 1u) != (mask >> b & 1u)) cut |= 1u << e;
  }
  // Links between same-sign corners: edges, then the diagonal each ambiguous face joins.
  uint adj[8];
  for (uint c = 0u; c < 8u; ++c)
    adj[c] = neighbours[c] & ((mask >> c & 1u) != 0u ? mask : (~mask & 0xFFu));
  uint face_joins = 0u;
  for (int fi = 0; fi < 6; ++fi) {
    const uint q0 = face_corner(fi, 0), q1 = face_corner(fi, 1), q2 = face_corner(fi, 2),
               q3 = face_corner(fi, 3);
    const uint s0 = mask >> q0 & 1u, s1 = mask >> q1 & 1u, s2 = mask >> q2 & 1u, s3 = mask >> q3 & 1u;
    if (!(s0 == s2 && s1 == s3 && s0 != s1)) continue;  // not ambiguous
    const bool first_positive = s0 != 0u;
    const uint pa = first_positive ? q0 : q1, pb = first_positive ? q2 : q3;
    const uint na = first_positive ? q1 : q0, nb = first_positive ? q3 : q2;
    const bool joins_positive = kahan_det(f[pa], f[pb], f[na], f[nb]) >= 0.0;
    if (joins_positive) face_joins |= 1u << fi;
    const uint u = joins_positive ? pa : na, v = joins_positive ? pb : nb;
    adj[u] |= 1u << v;
    adj[v] |= 1u << u;
  }

  const uint config = tables[MCHEX_TABLE_CONFIG + mask * 64u + face_joins];
  uint subcase = config & 0xFFu;
  const uint partner = tables[MCHEX_TABLE_SUBCASE + subcase] & 0xFFu;
  int tunnel = 0;
  uint c1, c2;
  if (partner != 0u && interior_join(f, c1, c2) && !connected(adj, c1, c2)) {
    tunnel = (mask >> c1 & 1u) != 0u ? 1 : -1;
    subcase = partner;
  }
  const int rep_tunnel = int((tables[MCHEX_TABLE_SUBCASE + subcase] >> 8) & 0xFFu) - 1;
  const uint inv = tunnel != 0 ? (tunnel != rep_tunnel ? 1u : 0u) : (config >> 24) & 1u;
  const uint symmetry = (config >> (8u + 8u * inv)) & 0xFFu;
  codes[2u * cell] = subcase | mask << MCHEX_CODE_SIGN_SHIFT | face_joins << MCHEX_CODE_FACE_SHIFT |
                     uint(tunnel + 1) << MCHEX_CODE_TUNNEL_SHIFT | inv << MCHEX_CODE_INVERTED_SHIFT;
  codes[2u * cell + 1u] = symmetry | cut << MCHEX_CODE_CUT_SHIFT;
  counts[cell] = 8u + 2u * uint(bitCount(cut));
}
