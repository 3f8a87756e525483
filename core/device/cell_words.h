// The packed words that cross the host/device line in MC33 classification: the lookup table a
// kernel reads (one word per sign pattern and face decision, then one per subcase) and the two
// words per cell a kernel writes. Emitted into the generated kernel headers
// (host/backends/gen_device_tables.cpp), so C++, OpenCL C and GLSL read one definition.
#pragma once

#include <cstdint>
#include <vector>

namespace mchex {

// MC33 lookup of core/cutting/mc33.h mc33_config(mask, face_joins) as one 32-bit word per index
// mask * 64 + face_joins: subcase | map[0] << 8 | map[1] << 16 | preferred << 24.
// After them, one word per subcase s (kNumSubcases of them, at kConfigSubcaseBase + s):
// tunnel_partner | (tunnel + 1) << 8 | hexes << 16 (core/cutting/mc33.h kSubcaseInfo, core/cutting/local_refinement.h
// local_refinement_hexes). They live in the buffer, not in constant arrays, because SIMD compilers
// that run invocations as vector lanes (llvmpipe) copy a constant array into per-invocation memory
// before indexing it by a varying value: on lavapipe that copy cost more than the classification.
inline constexpr int kConfigWords = 256 * 64;
inline constexpr int kConfigMap0Shift = 8, kConfigMap1Shift = 16, kConfigPreferredShift = 24;
inline constexpr int kConfigSubcaseBase = kConfigWords;
inline constexpr int kConfigTunnelShift = 8, kConfigHexesShift = 16;
std::vector<uint32_t> packed_mc33_configs();  // kConfigWords + kNumSubcases words

// A CellCode (core/device/backend.h) as two 32-bit words, the form a kernel writes:
//   word 0: subcase | sign_mask << 8 | face_joins << 16 | (tunnel + 1) << 24 | inverted << 26
//   word 1: symmetry | cut_edges << 16
inline constexpr int kCodeSignShift = 8, kCodeFaceShift = 16, kCodeTunnelShift = 24, kCodeInvertedShift = 26;
inline constexpr int kCodeCutShift = 16;

}  // namespace mchex
