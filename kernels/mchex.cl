// OpenCL C 1.2 kernels of the opencl backend (host/backends/opencl.cpp): thin wrappers around the
// shared device logic. The host builds the program from, in order, the generated
// mchex_tables.cl.h, dialect.h, sdf.h, refine.h, classify.h and this file (embedded into the
// binary at build time), so there are no #include lines here.
//
// Work decomposition: one work item per refinement cell or MC cell; for the surface SDF,
// `per_item` consecutive points (in Morton order) per work item, searched MCHEX_SDF_PACKET at a
// time (kernels/sdf.h: one shared walk per packet), each packet's points seeded by the previous
// packet's answers (on a grid nearly always the answer again; the result does not depend on it).
// Sizes are 32-bit: the host dispatches chunks that fit the device's allocation limit.

#ifndef MCHEX_FP32
__kernel void sdf_surface(SCENE_PARAMS_ __global const double *points, __global double *values, uint n,
                          uint per_item, double scale) {
  uint first = (uint)get_global_id(0) * per_item;
  if (first >= n) return;
  uint last = min(n, first + per_item);
  SurfacePacket q;
  for (int l = 0; l < MCHEX_SDF_PACKET; ++l) q.seed[l] = 0u;
  q.budget = 0u;  // OpenCL drivers do not cut loops (kernels/sdf.h)
  q.spent = 0u;
  for (uint i = first; i < last; i += MCHEX_SDF_PACKET) {
    q.lanes = (int)min((uint)MCHEX_SDF_PACKET, last - i);
    for (int l = 0; l < q.lanes; ++l) {
      uint j = i + (uint)l;
      q.p[l] = (double3)(points[3 * j], points[3 * j + 1], points[3 * j + 2]);
    }
    q = closest_on_surface(SCENE_ARGS_ q, scale);
    for (int l = 0; l < q.lanes; ++l) {
      values[i + (uint)l] = signed_value_of(SCENE_ARGS_ q.p[l], q.hit[l]);
      q.seed[l] = q.hit[l].slot;
    }
  }
}

__kernel void sdf_shape(int kind, __global const double *points, __global double *values, uint n) {
  uint i = (uint)get_global_id(0);
  if (i >= n) return;
  values[i] = shape_sdf(kind, (double3)(points[3 * i], points[3 * i + 1], points[3 * i + 2]));
}

__kernel void refinement_error(__global const double *lattice, __global const double *sizes,
                               __global double *errors, uint n) {
  uint i = (uint)get_global_id(0);
  if (i >= n) return;
  ChildLattice L;
  for (int k = 0; k < 64; ++k) L.f[k] = lattice[64 * i + (uint)k];
  errors[i] = refinement_error_of(L, sizes[i]);
}

// MC33 classification of the cells [first, first + n) of the complex (core/device/backend.h
// classify_cells). Corner point ids come from `cells` (8 per cell of the chunk), or, when
// uniform_n > 0, from the uniform grid's numbering (no corner list at all); values holds the
// points [value_base, ...) that the chunk's cells use. zero_tolerance > 0 applies the mesher's
// zero rule (core/cutting/mchex_mesher.h apply_zero_rule: |f| < t becomes -t) to each corner value as it
// is read, so the host need not make a ruled copy. Writes one byte per cell (its Subcase: all the
// mesher needs), the packed CellCode words when want_words != 0, and sets bad[0] when a corner
// value is not finite (the host turns that into core's InputError).
// classify_crossings also writes the 12 crossing parameters per cell (kernels/classify.h
// edge_crossing); a kernel of its own, so that the mesher's classify carries no code for them.
// Each work item takes a run of per_item consecutive cells: on a uniform grid it finds its first
// cell's (x, y, z) by division and its corners' offsets once, and steps along the row after that.
INLINE void classify_run(CLASSIFY_PARAMS_ __global const uint *cells, __global const double *values, uint value_base,
                         uint first, uint uniform_n, double zero_tolerance, __global uchar *subcases,
                         __global uint *codes, uint want_words, __global double *crossings, bool with_crossings,
                         __global uint *bad, uint n, uint per_item) {
  uint begin = (uint)get_global_id(0) * per_item;
  if (begin >= n) return;
  uint end = min(begin + per_item, n);
  uint m = uniform_n + 1u;
  uint x = 0u, y = 0u, z = 0u;
  if (uniform_n > 0u) {
    uint cell = first + begin, rest = cell / uniform_n;
    x = cell % uniform_n;
    y = rest % uniform_n;
    z = rest / uniform_n;
  }
  uint corner_offset[8];
  for (int c = 0; c < 8; ++c) corner_offset[c] = uniform_n > 0u ? uniform_corner_offset(uniform_n, c) : 0u;
  bool finite = true;
  for (uint i = begin; i < end; ++i) {
    CellValues v;
    int mask = 0;
    uint base = x + m * (y + m * z);
    for (int c = 0; c < 8; ++c) {
      uint p = uniform_n > 0u ? base + corner_offset[c] : cells[8 * i + (uint)c];
      double f = values[p - value_base];
      finite = finite && isfinite(f);
      f = fabs(f) < zero_tolerance ? -zero_tolerance : f;
      v.f[c] = f;
      if (f > 0.0) mask |= 1 << c;
    }
    CellWords w = classify_pattern(CLASSIFY_ARGS_ v, mask);
    subcases[i] = (uchar)(w.w0 & 255u);
    if (want_words != 0u) {
      codes[2 * i] = w.w0;
      codes[2 * i + 1] = w.w1;
    }
    if (with_crossings)
      for (int e = 0; e < 12; ++e) crossings[12 * i + (uint)e] = edge_crossing(v, mask, e);
    if (++x == uniform_n) {
      x = 0u;
      if (++y == uniform_n) {
        y = 0u;
        ++z;
      }
    }
  }
  if (!finite) bad[0] = 1u;
}

__kernel void classify(CLASSIFY_PARAMS_ __global const uint *cells, __global const double *values, uint value_base,
                       uint first, uint uniform_n, double zero_tolerance, __global uchar *subcases,
                       __global uint *codes, uint want_words, __global uint *bad, uint n, uint per_item) {
  classify_run(CLASSIFY_ARGS_ cells, values, value_base, first, uniform_n, zero_tolerance, subcases, codes, want_words,
               (__global double *)0, false, bad, n, per_item);
}

__kernel void classify_crossings(CLASSIFY_PARAMS_ __global const uint *cells, __global const double *values,
                                 uint value_base, uint first, uint uniform_n, double zero_tolerance,
                                 __global uchar *subcases, __global uint *codes, uint want_words,
                                 __global double *crossings, __global uint *bad, uint n, uint per_item) {
  classify_run(CLASSIFY_ARGS_ cells, values, value_base, first, uniform_n, zero_tolerance, subcases, codes, want_words,
               crossings, true, bad, n, per_item);
}

#else
// The single-precision surface SDF (kernels/sdf_fp32.h): per point, the number of candidate slots
// (MCHEX_FP32_CANDIDATES + 1: overflow, the host evaluates the point itself) and the slots, in
// MCHEX_FP32_CANDIDATES + 1 words. points: the double points rounded to float by the host.
__kernel void sdf_surface32(SCENE32_PARAMS_ __global const float *points, __global uint *candidates, uint n,
                            uint per_item, float scale) {
  uint first = (uint)get_global_id(0) * per_item;
  if (first >= n) return;
  uint last = min(n, first + per_item);
  uint seed = 0u;
  for (uint i = first; i < last; ++i) {
    float3 p = (float3)(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
    Candidates32 s = surface_candidates32(SCENE32_ARGS_ p, seed, scale);
    uint out = (MCHEX_FP32_CANDIDATES + 1) * i;
    candidates[out] = s.overflow != 0 ? (uint)(MCHEX_FP32_CANDIDATES + 1) : (uint)s.count;
    for (int k = 0; k < MCHEX_FP32_CANDIDATES; ++k) candidates[out + 1 + (uint)k] = k < s.count ? s.slot[k] : 0u;
    seed = s.nearest;
  }
}

#endif

// Exclusive prefix sum of cell_hexes over the classified cells, in three passes: per-block sums
// (one work item per block of consecutive cells), a scan of the block sums (one work item; there
// are few blocks) starting at `base` (the previous chunks' total), and per-block offsets.
__kernel void hex_block_sums(__global const uchar *subcases, uint n, uint block, __global ulong *sums) {
  uint b = (uint)get_global_id(0);
  uint first = b * block;
  if (first >= n) return;
  uint last = min(n, first + block);
  uint s = 0;  // block * max hexes per cell < 2^32
  for (uint i = first; i < last; ++i) s += (uint)kSubcaseHexes[subcases[i]];
  sums[b] = s;
}

__kernel void hex_scan_sums(__global ulong *sums, uint blocks, ulong base) {
  if (get_global_id(0) != 0) return;
  ulong run = base;
  for (uint b = 0; b < blocks; ++b) {
    ulong s = sums[b];
    sums[b] = run;
    run += s;
  }
  sums[blocks] = run;
}

__kernel void hex_block_offsets(__global const uchar *subcases, uint n, uint block, __global const ulong *sums,
                                __global ulong *offsets) {
  uint b = (uint)get_global_id(0);
  uint first = b * block;
  if (first >= n) return;
  uint last = min(n, first + block);
  ulong run = sums[b];
  for (uint i = first; i < last; ++i) {
    offsets[i] = run;
    run += (ulong)kSubcaseHexes[subcases[i]];
  }
}
