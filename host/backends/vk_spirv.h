// The SPIR-V of shaders/*.comp, compiled and validated at build time and embedded
// (shaders/CMakeLists.txt, shaders/embed_spirv.cmake): one word array per shader.
#pragma once

#include <cstdint>
#include <span>

namespace mchex::spirv {

extern const std::span<const std::uint32_t> refinement_error;            // shaders/refinement_error.comp
extern const std::span<const std::uint32_t> classify;                    // shaders/classify.comp
extern const std::span<const std::uint32_t> classify_crossings;          // shaders/classify_crossings.comp
extern const std::span<const std::uint32_t> scan_blocks;                 // shaders/scan_blocks.comp
extern const std::span<const std::uint32_t> scan_totals;                 // shaders/scan_totals.comp
extern const std::span<const std::uint32_t> scan_add;                    // shaders/scan_add.comp
extern const std::span<const std::uint32_t> surface_sdf;                 // shaders/surface_sdf.comp
extern const std::span<const std::uint32_t> surface_sdf_single;          // shaders/surface_sdf_single.comp
extern const std::span<const std::uint32_t> surface_sdf_single_counted;  // shaders/surface_sdf_single_counted.comp
extern const std::span<const std::uint32_t> surface_sdf_texel_counted;   // shaders/surface_sdf_texel_counted.comp
extern const std::span<const std::uint32_t> shape_sdf;                   // shaders/shape_sdf.comp
// The fp32 path (no double, no 64-bit integer): shaders/surface_sdf32.comp, *_counted.comp.
extern const std::span<const std::uint32_t> surface_sdf32;
extern const std::span<const std::uint32_t> surface_sdf32_counted;

}  // namespace mchex::spirv
