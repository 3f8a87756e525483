// The common dialect of the device logic in kernels/*.h: plain C functions that OpenCL C 1.2 and
// GLSL 4.50 both accept, so that kernels/*.cl and shaders/*.comp are thin wrappers around ONE
// implementation of the SDF, the refinement error and MC33 classification.
//
// Rules the shared headers follow (and a new one must follow):
//   - no pointers, no recursion, no goto, no implicit int <-> bool; struct values passed and
//     returned by value; arrays only as locals or struct members;
//   - types: int, uint, bool, double, float; casts through CAST(type, x); structs declared with
//     STRUCT(name) { ... }; and named `name` afterwards;
//   - every double that must equal the CPU reference bit for bit goes through an EXACT variable:
//     GLSL `precise` (SPIR-V NoContraction), so no driver fuses a * b + c into an fma; OpenCL
//     gets the same guarantee from `#pragma OPENCL FP_CONTRACT OFF` (below). GCC on x86-64 does
//     not contract either without -mfma, and C++ in ISO mode (-std=c++20) defaults to
//     -ffp-contract=off. +, -, *, / and sqrt are correctly rounded in IEEE double on both APIs'
//     fp64 (OpenCL 1.2 section 7.4, Table 7.2: 0 ulp for sqrt and divide), so the same sequence
//     of operations gives the same bits as core/;
//   - no fractional double literals where the value matters: GLSL reads 0.4 as a float and widens
//     it, and glslang cannot paste an lf suffix onto a macro argument. Exact constants come from
//     the generated tables (printed with the dialect's suffix) or as CAST(double, integer);
//   - buffers are read through names the wrapper provides: in OpenCL they are kernel arguments,
//     passed down through the *_PARAMS_ / *_ARGS_ macros of each header (which end in a comma);
//     in GLSL they are global storage buffers with the same names and the macros are empty.
#ifndef MCHEX_DIALECT_H
#define MCHEX_DIALECT_H

// MCHEX_FP32 (a device without fp64, or the forced single-precision path): no double anywhere;
// kernels/sdf_fp32.h finds candidate triangles in float and the host computes the values in
// double. Without it, every header computes in double as core does.
#ifdef __OPENCL_C_VERSION__
#ifndef MCHEX_FP32
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif
#pragma OPENCL FP_CONTRACT OFF
#define EXACT
#define STRUCT(name) \
  typedef struct name name; \
  struct name
#define CAST(type, x) ((type)(x))
#define GLOBAL_RO __global const
#define GLOBAL_RW __global
#define INLINE inline
#define MCHEX_FMA(a, b, c) fma(a, b, c)
#define FABS(x) fabs(x)
#define LOWEST_BIT(x) (31 - CAST(int, clz((x) & (0u - (x)))))  // index of the lowest set bit of x != 0
#define POPCOUNT(x) CAST(uint, popcount(x))
#else
#define EXACT precise
#define STRUCT(name) struct name
#define CAST(type, x) type(x)
#define INLINE
#define FABS(x) abs(x)
#define LOWEST_BIT(x) findLSB(x)
#define POPCOUNT(x) uint(bitCount(x))
// Vulkan does not promise a fused, once-rounded fma (GLSL.std.450 Fma may be split), so the
// sign-exact determinant of kernels/classify.h uses Dekker's product there instead.
#endif

#endif
