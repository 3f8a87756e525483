#include "host/backends/vulkan.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/base/trace.h"
#include "core/device/cell_words.h"
#include "core/device/device_scene.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"
#include "host/backends/vk_context.h"
#include "host/backends/vk_spirv.h"

namespace mchex {

std::filesystem::path VulkanOptions::default_pipeline_cache_dir() { return vk::default_cache_dir(); }

namespace {

// Workgroup sizes of the shaders (their local_size_x).
constexpr std::uint32_t kGroup = 64, kScanGroup = 256, kScanBlock = 1024;
// Consecutive turns per invocation of the surface SDF: each search is seeded with the previous
// turn's answer (kernels/sdf.h), which on Morton-ordered batches makes the first bound tight.
// On lavapipe 16 measured faster than 1 or 4 (perf/bench_backends). (64 once gave garbage values
// there: llvmpipe's loop limit, which the loop budget below now guards against.)
constexpr std::size_t kSdfPointsPerInvocation = 16;

// llvmpipe (lavapipe) ends a shader's loops after this many iterations in all, per SIMD batch
// (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS), silently; kernels/sdf.h's walk keeps under it by a
// budget. The margin covers the loops its count leaves out (the searches' setup beyond
// MCHEX_SDF_LOOPS_PER_SEARCH is none; this is slack for the wrapper's own).
constexpr std::uint32_t kLlvmpipeLoopLimit = 65535, kLoopBudgetMargin = 1024;

// The texel formats of shaders/surface_sdf.glsl's MCHEX_TEXEL_SCENE bindings.
constexpr std::array<VkFormat, 7> kSceneTexelFormats = {VK_FORMAT_R32G32B32A32_SFLOAT,
                                                        VK_FORMAT_R32G32B32A32_UINT,
                                                        VK_FORMAT_R32G32B32A32_SFLOAT,
                                                        VK_FORMAT_R32_UINT,
                                                        VK_FORMAT_R32_UINT,
                                                        VK_FORMAT_R32G32B32A32_UINT,
                                                        VK_FORMAT_R32_UINT};

VkPhysicalDeviceSubgroupProperties subgroup_properties(const vk::PhysicalDevice& d) {
  VkPhysicalDeviceSubgroupProperties sub{};
  sub.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES;
  VkPhysicalDeviceProperties2 props{};
  props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  props.pNext = &sub;
  vkGetPhysicalDeviceProperties2(d.handle, &props);
  return sub;
}

// Whether a device's compute shaders have what shaders/surface_sdf.comp and
// surface_sdf_single_counted.comp use (subgroup basic and arithmetic operations).
bool has_subgroup_arithmetic(const VkPhysicalDeviceSubgroupProperties& sub) {
  const VkSubgroupFeatureFlags need = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
  return (sub.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) && (sub.supportedOperations & need) == need;
}

std::string api_string(std::uint32_t v) {
  return fmt::format("{}.{}.{}", VK_API_VERSION_MAJOR(v), VK_API_VERSION_MINOR(v), VK_API_VERSION_PATCH(v));
}

DeviceInfo device_info(const vk::PhysicalDevice& d) {
  DeviceInfo info;
  info.backend = "vulkan";
  info.platform = d.driver_name + (d.driver_info.empty() ? "" : " (" + d.driver_info + ")");
  info.name = d.name;
  info.type = d.type_name();
  info.fp64 = d.shader_float64;
  info.max_buffer_bytes = d.max_storage_buffer_range;
  for (const VkMemoryHeap& h : d.heaps)
    if (h.flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) info.global_memory_bytes += h.size;
  info.compute_units = d.compute_units;
  info.version = "Vulkan " + api_string(d.api_version) + ", driver " + d.driver_info;
  if (d.api_version < VK_API_VERSION_1_2) info.note = "below Vulkan 1.2";
  else if (d.compute_queue_family < 0) info.note = "no compute queue";
  // What the backend would run on it: the shaders' double arithmetic and 64-bit prefix sum need
  // both features; without either (or forced) the fp32 path.
  info.precision = d.shader_float64 && d.shader_int64 && !fp32_forced_by_environment() ? "fp64" : "fp32";
  return info;
}

// Adds the seconds f takes to `total`; with a trace on, f is also an event of the timeline
// (core/base/trace.h): an upload or download through mapped memory, `bytes` long.
template <class F>
void timed(double& total, const char* category, const char* name, std::size_t bytes, F&& f) {
  const auto start = std::chrono::steady_clock::now();
  f();
  const auto end = std::chrono::steady_clock::now();
  total += std::chrono::duration<double>(end - start).count();
  if (trace::enabled()) trace::record(name, category, start, end, {{"backend", "vulkan"}, {"bytes", bytes}});
}

template <class T>
T* mapped(const vk::Buffer& b) {
  return static_cast<T*>(b.data());
}

}  // namespace

struct VulkanBackend::Impl {
  vk::Instance instance;
  std::optional<vk::Device> device;
  DeviceInfo info;
  std::size_t max_chunk = 0;
  double pipeline_seconds = 0;
  std::size_t dispatches = 0;
  VulkanBackend::Profile profile;

  vk::Pipeline refinement, classify, classify_crossings, scan_blocks, scan_totals, scan_add, surface_sdf, shape_sdf;
  bool sdf_subgroup = false;          // surface_sdf is shaders/surface_sdf.comp (else surface_sdf_single*.comp)
  vk::Pipeline surface_sdf_texel;     // on llvmpipe: surface_sdf over texel buffers (kSceneTexelFormats)
  std::uint32_t sdf_loop_budget = 0;  // kernels/sdf.h (0: none)
  std::size_t sdf_points_per_invocation = kSdfPointsPerInvocation;
  std::unique_ptr<SurfaceSdf> host_sdf;  // core's, of the scene's surface, for points past the loop budget
  bool fp32 = false;                     // the fp32 path (VulkanOptions::force_fp32)
  vk::Pipeline surface_sdf32;            // shaders/surface_sdf32*.comp, the fp32 path's only pipeline
  Fp32Stats fp32_stats;
  vk::Buffer configs;  // core/device/device_scene.h packed_mc33_configs()

  // The device scene of the last surface (keyed by its address, array addresses and sizes, as
  // core/device/backend.h says), one storage buffer per array of core/device_scene.h.
  struct Scene {
    const TriangleSurface* surface = nullptr;
    const void* vertices = nullptr;
    const void* triangles = nullptr;
    std::size_t num_vertices = 0, num_triangles = 0;
    vk::Buffer wide_boxes, wide_links, leaf_bounds, leaf_slot, slot_triangle, slot_corners, slot_features, face_normals,
        edge_normals, vertex_normals;
    double scale = 0;
    bool texel_fits = false;  // every texel binding within maxTexelBufferElements
  };
  std::optional<Scene> scene;

  // The fp32 path's scene of the last surface: kernels/sdf_fp32.h's buffers, and on the host what
  // turns the device's candidate records into core's values.
  struct Scene32 {
    std::unique_ptr<Fp32Surface> host;
    vk::Buffer nodes, node_slack, slot_corners, slot_slack;
    float scale = 0;
  };
  std::optional<Scene32> scene32;

  // The output buffer of the last signed_distance call when it was one chunk, and the host array
  // it was copied into (ClassifyOptions::values_from_last_sdf).
  std::optional<vk::Buffer> resident;
  const double* resident_data = nullptr;
  std::size_t resident_size = 0;

  // A scene array in a storage buffer of its own. The scene is bound whole (every point may need
  // any triangle): an array over one storage buffer is a resource limit of this device, not a
  // chunking matter. The buffer holds a multiple of `multiple` elements, zeros after the array's.
  template <class T>
  vk::Buffer upload(const std::vector<T>& v, const char* what, std::size_t multiple = 1) {
    const std::size_t padded = (v.size() + multiple - 1) / multiple * multiple;
    const std::size_t bytes = padded * sizeof(T);
    const std::uint32_t limit = device->physical().max_storage_buffer_range;
    if (bytes > limit)
      throw ResourceError(fmt::format("backend 'vulkan': the surface's {} need {} MiB in one storage buffer; "
                                      "device '{}' allows {} MiB (use --backend cpu)",
                                      what, bytes >> 20, info.name, limit >> 20));
    vk::Buffer b = device->make_buffer(std::max<std::size_t>(bytes, sizeof(T)));
    timed(profile.upload, trace::kUpload, what, bytes, [&] {
      std::memcpy(b.data(), v.data(), v.size() * sizeof(T));
      std::fill(static_cast<T*>(b.data()) + v.size(), static_cast<T*>(b.data()) + padded, T{});
    });
    return b;
  }

  Scene32& scene32_of(const TriangleSurface& s) {
    if (scene32 && scene32->host->is_of(s)) return *scene32;
    scene32.reset();
    Scene32 out;
    out.host = std::make_unique<Fp32Surface>(s);
    const Fp32DeviceArrays d = out.host->take_device_arrays();
    out.nodes = upload(d.nodes, "search tree nodes");
    out.node_slack = upload(d.node_slack, "node slacks");
    out.slot_corners = upload(d.slot_corners, "triangle corners");
    out.slot_slack = upload(d.slot_slack, "triangle slacks");
    out.scale = d.scale;
    scene32.emplace(std::move(out));
    return *scene32;
  }

  const Scene& scene_of(const TriangleSurface& s) {
    if (scene && scene->surface == &s && scene->vertices == s.vertices.data() &&
        scene->triangles == s.triangles.data() && scene->num_vertices == s.vertices.size() &&
        scene->num_triangles == s.triangles.size())
      return *scene;
    scene.reset();
    host_sdf.reset();
    const DeviceScene ds = DeviceScene::build(s);
    Scene out;
    out.surface = &s;
    out.vertices = s.vertices.data();
    out.triangles = s.triangles.data();
    out.num_vertices = s.vertices.size();
    out.num_triangles = s.triangles.size();
    out.wide_boxes = upload(ds.wide_boxes, "search tree boxes");
    out.wide_links = upload(ds.wide_links, "search tree links");
    out.leaf_bounds = upload(ds.leaf_bounds, "triangle bounds");
    out.leaf_slot = upload(ds.leaf_slot, "leaf slots");
    out.slot_triangle = upload(ds.slot_triangle, "leaf triangle ids");
    // Padded to an even count: the texel reads take two doubles at a time.
    out.slot_corners = upload(ds.slot_corners, "triangle corners", 2);
    out.slot_features = upload(ds.slot_features, "triangle features");
    out.face_normals = upload(ds.face_normals, "face pseudonormals");
    out.edge_normals = upload(ds.edge_normals, "edge pseudonormals");
    out.vertex_normals = upload(ds.vertex_normals, "vertex pseudonormals");
    out.scale = ds.scale;
    const vk::Buffer* texel_bound[] = {&out.wide_boxes,    &out.wide_links,   &out.leaf_bounds,  &out.leaf_slot,
                                       &out.slot_triangle, &out.slot_corners, &out.slot_features};
    static_assert(std::size(texel_bound) == kSceneTexelFormats.size());
    out.texel_fits = true;
    for (std::size_t i = 0; i < kSceneTexelFormats.size(); ++i)
      out.texel_fits = out.texel_fits && texel_bound[i]->size() / vk::texel_bytes(kSceneTexelFormats[i]) <=
                                             device->physical().max_texel_buffer_elements;
    scene.emplace(std::move(out));
    return *scene;
  }

  explicit Impl(const VulkanOptions& options) {
    std::string want = options.device;
    if (want.empty())
      if (const char* env = std::getenv("MCHEX_VULKAN_DEVICE"); env && *env) want = env;
    const vk::PhysicalDevice* chosen = nullptr;
    for (const auto& d : instance.devices()) {
      if (d.api_version < VK_API_VERSION_1_2 || d.compute_queue_family < 0) continue;
      if (!want.empty()) {
        if (d.name.find(want) != std::string::npos || d.driver_name.find(want) != std::string::npos) {
          chosen = &d;
          break;
        }
      } else if (!chosen || (chosen->type_name() != "gpu" && d.type_name() == "gpu")) {
        chosen = &d;
      }
    }
    if (!chosen)
      throw InputError(want.empty() ? "backend 'vulkan': no Vulkan 1.2 device with a compute queue found"
                                    : "backend 'vulkan': no Vulkan 1.2 device matches '" + want + "'");
    // The fp64 shaders repeat core's double arithmetic and sum hex counts in 64 bits; a device
    // without either feature (or forced) takes the fp32 path, whose one shader has neither.
    info = device_info(*chosen);
    fp32 = !chosen->shader_float64 || !chosen->shader_int64 || options.force_fp32 || fp32_forced_by_environment();
    info.precision = fp32 ? "fp32" : "fp64";
    device.emplace(instance, *chosen, options.cache_dir);
    max_chunk = options.max_chunk;

    const auto start = std::chrono::steady_clock::now();
    const VkPhysicalDeviceSubgroupProperties sub = subgroup_properties(*chosen);
    const bool subgroups = has_subgroup_arithmetic(sub);
    if (fp32) {
      // kernels/sdf_fp32.h under llvmpipe's loop limit, counted per subgroup where the shader can
      // take the subgroup's maximum, else by each lane for its share of the limit, one point per
      // invocation (as the fp64 walk below).
      std::span<const std::uint32_t> code = subgroups ? spirv::surface_sdf32_counted : spirv::surface_sdf32;
      if (chosen->driver_id == VK_DRIVER_ID_MESA_LLVMPIPE) {
        sdf_loop_budget = kLlvmpipeLoopLimit - kLoopBudgetMargin;
        if (!subgroups) {
          sdf_loop_budget /= std::max<std::uint32_t>(sub.subgroupSize, 16);
          sdf_points_per_invocation = 1;
        }
      }
      surface_sdf32 = device->make_pipeline(code, 6, 16);
      info.kernels = fmt::format(
          "surface SDF: float candidate search (shaders/{}.comp), {} point(s) per invocation{}, values on the host "
          "in double; shapes, refinement error and classification on the host{}",
          subgroups ? "surface_sdf32_counted" : "surface_sdf32", sdf_points_per_invocation, budget_text(),
          memory_text());
      pipeline_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      device->save_cache();
      return;
    }
    refinement = device->make_pipeline(spirv::refinement_error, 3, 4);
    // Both with 8 bindings; classify.comp leaves the crossings' (7) unread.
    classify = device->make_pipeline(spirv::classify, 8, 24);
    classify_crossings = device->make_pipeline(spirv::classify_crossings, 8, 24);
    scan_blocks = device->make_pipeline(spirv::scan_blocks, 3, 4);
    scan_totals = device->make_pipeline(spirv::scan_totals, 1, 16);
    scan_add = device->make_pipeline(spirv::scan_add, 2, 4);
    if (options.sdf_walk == VulkanOptions::SdfWalk::kSubgroup && !subgroups)
      throw InputError("backend 'vulkan': device '" + chosen->name +
                       "' has no subgroup arithmetic in compute shaders, which the subgroup SDF walk needs");
    // kAuto: the subgroup walk on GPUs that have subgroup arithmetic (NVIDIA H200: 3.1 ms in the
    // kernel against 7.7 ms for one walk per invocation, perf/GPU_RUNS.md), one walk per
    // invocation on CPU devices (lavapipe: the subgroup walk about 15x the cpu reference's time
    // against 11x, perf/bench_backends).
    sdf_subgroup =
        options.sdf_walk == VulkanOptions::SdfWalk::kSubgroup ||
        (options.sdf_walk == VulkanOptions::SdfWalk::kAuto && subgroups && chosen->type != VK_PHYSICAL_DEVICE_TYPE_CPU);
    // A subgroup's shared walk opens every node in range of any of its points, so one packet per
    // invocation already takes many steps (under llvmpipe's loop budget, 16 ran out for most).
    if (sdf_subgroup) sdf_points_per_invocation = 1;
    // On llvmpipe the walk runs under kernels/sdf.h's loop budget. Its count is exact per SIMD
    // batch where the shader can take the subgroup's maximum (the subgroup walk; the single walk's
    // counted variant), else each lane counts alone and gets its share of the limit, one point
    // per invocation.
    std::span<const std::uint32_t> code = sdf_subgroup ? spirv::surface_sdf : spirv::surface_sdf_single;
    if (chosen->driver_id == VK_DRIVER_ID_MESA_LLVMPIPE) {
      sdf_loop_budget = kLlvmpipeLoopLimit - kLoopBudgetMargin;
      if (!sdf_subgroup && subgroups) {
        code = spirv::surface_sdf_single_counted;
        // The same walk reading the search arrays as texel buffers and without the leaf bounds:
        // on llvmpipe a storage-buffer read is a run-time loop over the SIMD lanes with a branch
        // per lane (gallivm's emit_load_mem), a texel fetch is straight-line code (lavapipe
        // surface SDF 10.4x -> 3.6x the cpu reference's time, perf/bench_backends). Used for
        // every scene whose arrays fit maxTexelBufferElements.
        if (!options.sdf_storage_reads)
          surface_sdf_texel = device->make_pipeline(spirv::surface_sdf_texel_counted, 12, 24,
                                                    {kSceneTexelFormats.begin(), kSceneTexelFormats.end()});
      } else if (!sdf_subgroup) {
        sdf_loop_budget /= std::max<std::uint32_t>(sub.subgroupSize, 16);
        sdf_points_per_invocation = 1;
      }
    }
    surface_sdf = device->make_pipeline(code, 12, 24);
    shape_sdf = device->make_pipeline(spirv::shape_sdf, 2, 8);
    info.kernels = fmt::format(
        "surface SDF: {}, {} point(s) per invocation, {}{}{}",
        sdf_subgroup ? "one walk per subgroup" : "one walk per invocation", sdf_points_per_invocation,
        surface_sdf_texel.pipeline ? "search arrays in texel buffers (storage buffers past maxTexelBufferElements), "
                                     "every triangle of a leaf in range measured"
                                   : "search arrays in storage buffers",
        budget_text(), memory_text());
    pipeline_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // Written now, not only at exit: a run that ends by an error still leaves the cache behind.
    device->save_cache();

    // core's (sign pattern, face outcomes) lookup, as kernels/classify.h reads it.
    const std::vector<std::uint32_t> words = packed_mc33_configs();
    configs = device->make_buffer(words.size() * sizeof(std::uint32_t));
    std::memcpy(configs.data(), words.data(), words.size() * sizeof(std::uint32_t));
  }

  // The loop budget, as the report states it.
  std::string budget_text() const {
    return sdf_loop_budget
               ? fmt::format(", loop budget {} per SIMD batch{}", sdf_loop_budget,
                             device->physical().driver_id == VK_DRIVER_ID_MESA_LLVMPIPE ? " (llvmpipe)" : "")
               : "";
  }
  // The memory the buffers live in (vk::buffer_memory_type), as the report states it.
  std::string memory_text() const {
    const VkMemoryPropertyFlags f = device->buffer_memory_flags();
    return fmt::format("; buffers in host-visible{}{} memory",
                       f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT ? ", host-cached" : ", uncached",
                       f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT ? ", device-local" : "");
  }

  ~Impl() {
    if (!device) return;
    for (vk::Pipeline* p : {&refinement, &classify, &classify_crossings, &scan_blocks, &scan_totals, &scan_add,
                            &surface_sdf, &surface_sdf_texel, &shape_sdf, &surface_sdf32})
      device->destroy(*p);
  }

  // Elements per dispatch: every binding (bytes_per_element each, the largest given) within
  // maxStorageBufferRange, the workgroups within maxComputeWorkGroupCount[0], and the test cap.
  std::size_t chunk_for(std::size_t largest_bytes_per_element, std::uint32_t group) const {
    const vk::PhysicalDevice& d = device->physical();
    return items_per_chunk(d.max_storage_buffer_range, largest_bytes_per_element,
                           std::size_t(d.max_work_group_count[0]) * group, max_chunk);
  }

  // The fp32 path of signed_distance for a surface: kernels/sdf_fp32.h's candidate records on the
  // device, the values from them on the host (host/backends/fp32_path.h). Points go in Morton order, as on
  // the fp64 path, so that each invocation's run of points seed one another.
  void surface_sdf_fp32(const TriangleSurface& s, std::span<const Vec3> points, std::span<double> values) {
    Scene32& sc = scene32_of(s);
    const std::size_t n = points.size();
    const std::size_t per_item = sdf_points_per_invocation;
    const std::size_t chunk = std::min(n, chunk_for(kFp32RecordWords * sizeof(std::uint32_t), kGroup * per_item));
    vk::Buffer in = device->make_buffer(chunk * 3 * sizeof(float));
    vk::Buffer out = device->make_buffer(chunk * kFp32RecordWords * sizeof(std::uint32_t));
    std::vector<std::uint32_t> records(chunk * kFp32RecordWords);
    const MortonBatch sorted(points);
    for (std::size_t begin = 0; begin < n; begin += chunk) {
      const std::size_t count = std::min(chunk, n - begin);
      timed(profile.upload, trace::kUpload, "points32", count * 3 * sizeof(float),
            [&] { sorted.gather(begin, count, mapped<float>(in)); });
      struct {
        std::uint32_t n, per_item, loop_budget;
        float scale;
      } push{static_cast<std::uint32_t>(count), static_cast<std::uint32_t>(per_item), sdf_loop_budget, sc.scale};
      static_assert(sizeof(push) == 16);
      run("surface_sdf32", surface_sdf32,
          {{&sc.nodes}, {&sc.node_slack}, {&sc.slot_corners}, {&sc.slot_slack}, {&in}, {&out}}, &push,
          (count + per_item - 1) / per_item, kGroup);
      timed(profile.download, trace::kDownload, "records32", count * kFp32RecordWords * sizeof(std::uint32_t), [&] {
        const std::span<std::uint32_t> chunk_records = std::span(records).first(count * kFp32RecordWords);
        std::memcpy(chunk_records.data(), out.data(), chunk_records.size_bytes());
        sc.host->values_from_records(points, sorted.order(), begin, chunk_records, values, fp32_stats);
      });
    }
  }

  void run(const char* name, const vk::Pipeline& p, std::initializer_list<vk::BufferRange> buffers, const void* push,
           std::size_t invocations, std::uint32_t group) {
    const std::size_t groups = (invocations + group - 1) / group;
    const auto start = std::chrono::steady_clock::now();
    device->dispatch(p, std::span<const vk::BufferRange>(buffers.begin(), buffers.size()), push,
                     static_cast<std::uint32_t>(groups));
    const auto end = std::chrono::steady_clock::now();
    profile.device += std::chrono::duration<double>(end - start).count();
    // Host time around the submit and its wait (vk::Device::dispatch): one dispatch per submit.
    if (trace::enabled())
      trace::record(
          name, trace::kDispatch, start, end,
          {{"backend", "vulkan"}, {"work_items", invocations}, {"workgroups", groups}, {"local_size", group}});
    ++dispatches;
  }
};

VulkanBackend::VulkanBackend(const VulkanOptions& options) : impl_(std::make_unique<Impl>(options)) {}
VulkanBackend::~VulkanBackend() = default;

const DeviceInfo& VulkanBackend::device() const { return impl_->info; }
std::filesystem::path VulkanBackend::pipeline_cache_file() const { return impl_->device->cache_file(); }
std::size_t VulkanBackend::pipeline_cache_bytes_loaded() const { return impl_->device->cache_bytes_loaded(); }
double VulkanBackend::pipeline_seconds() const { return impl_->pipeline_seconds; }
std::array<std::uint8_t, 16> VulkanBackend::pipeline_cache_uuid() const {
  std::array<std::uint8_t, 16> out{};
  std::memcpy(out.data(), impl_->device->physical().pipeline_cache_uuid, out.size());
  return out;
}
std::size_t VulkanBackend::dispatches() const { return impl_->dispatches; }
bool VulkanBackend::sdf_subgroup_walk() const { return impl_->sdf_subgroup; }
bool VulkanBackend::sdf_texel_reads() const { return impl_->surface_sdf_texel.pipeline != VK_NULL_HANDLE; }
VulkanBackend::Profile VulkanBackend::profile() const { return impl_->profile; }
std::uint32_t VulkanBackend::sdf_loop_budget() const { return impl_->sdf_loop_budget; }
Fp32Stats VulkanBackend::fp32_stats() const { return impl_->fp32_stats; }

bool VulkanBackend::fp32_path() const { return impl_->fp32; }
void VulkanBackend::forget_resident_values() {
  impl_->resident.reset();
  impl_->resident_data = nullptr;
}

void VulkanBackend::device_surface_sdf32(const TriangleSurface& surface, std::span<const Vec3> points,
                                         std::span<double> values) {
  impl_->surface_sdf_fp32(surface, points, values);
}

void VulkanBackend::device_surface_sdf(const TriangleSurface& surface, const MortonBatch& points,
                                       std::span<double> values) {
  Impl& m = *impl_;
  const std::size_t n = points.size();
  const std::size_t per_item = m.sdf_points_per_invocation;
  const std::size_t chunk = std::min(n, m.chunk_for(sizeof(Vec3), kGroup * per_item));
  vk::Buffer in = m.device->make_buffer(chunk * sizeof(Vec3));
  vk::Buffer out = m.device->make_buffer(chunk * sizeof(double));
  const Impl::Scene& scene = m.scene_of(surface);
  // The values come back in search order and are scattered; they are not left resident (the
  // device copy is permuted).
  for (std::size_t begin = 0; begin < n; begin += chunk) {
    const std::size_t count = std::min(chunk, n - begin);
    static_assert(sizeof(Vec3) == 3 * sizeof(double));
    timed(m.profile.upload, trace::kUpload, "points", count * sizeof(Vec3),
          [&] { points.gather(begin, count, mapped<double>(in)); });
    struct {
      std::uint32_t n, per_item, loop_budget, pad;
      double scale;
    } push{static_cast<std::uint32_t>(count), static_cast<std::uint32_t>(per_item), m.sdf_loop_budget, 0, scene.scale};
    const bool texel = m.surface_sdf_texel.pipeline != VK_NULL_HANDLE && scene.texel_fits;
    m.run(texel ? "surface_sdf_texel" : "surface_sdf", texel ? m.surface_sdf_texel : m.surface_sdf,
          {{&scene.wide_boxes},
           {&scene.wide_links},
           {&scene.leaf_bounds},
           {&scene.leaf_slot},
           {&scene.slot_triangle},
           {&scene.slot_corners},
           {&scene.slot_features},
           {&scene.face_normals},
           {&scene.edge_normals},
           {&scene.vertex_normals},
           {&in},
           {&out}},
          &push, (count + per_item - 1) / per_item, kGroup);
    timed(m.profile.download, trace::kDownload, "values", count * sizeof(double),
          [&] { points.scatter(begin, std::span(mapped<const double>(out), count), values); });
  }
  if (m.sdf_loop_budget != 0) {
    // Points whose search ran out of the loop budget came back NaN (shaders/surface_sdf.glsl); a
    // finite point never has a NaN value, so core evaluates exactly those (and non-finite points,
    // whose value core decides anyway).
    std::vector<std::size_t> redo;
    for (std::size_t i = 0; i < n; ++i)
      if (std::isnan(values[i])) redo.push_back(i);
    host_values_at(m.host_sdf, surface, points.points(), redo, values);
    m.profile.host_points += redo.size();
  }
}

void VulkanBackend::device_shape_sdf(ShapeKind shape, std::span<const Vec3> points, std::span<double> values) {
  Impl& m = *impl_;
  const std::size_t n = points.size();
  const std::size_t chunk = std::min(n, m.chunk_for(sizeof(Vec3), kGroup));
  vk::Buffer in = m.device->make_buffer(chunk * sizeof(Vec3));
  vk::Buffer out = m.device->make_buffer(chunk * sizeof(double));
  for (std::size_t begin = 0; begin < n; begin += chunk) {
    const std::size_t count = std::min(chunk, n - begin);
    timed(m.profile.upload, trace::kUpload, "points", count * sizeof(Vec3),
          [&] { std::memcpy(in.data(), points.data() + begin, count * sizeof(Vec3)); });
    const std::int32_t push[2] = {static_cast<std::int32_t>(count), static_cast<std::int32_t>(shape)};
    m.run("shape_sdf", m.shape_sdf, {{&in}, {&out}}, push, count, kGroup);
    timed(m.profile.download, trace::kDownload, "values", count * sizeof(double),
          [&] { std::memcpy(values.data() + begin, out.data(), count * sizeof(double)); });
  }
  if (chunk == n) {
    m.resident.emplace(std::move(out));
    m.resident_data = values.data();
    m.resident_size = n;
  }
}

void VulkanBackend::device_refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice,
                                            std::span<const double> sizes, std::span<double> errors) {
  Impl& m = *impl_;
  const std::size_t n = lattice.size();
  const std::size_t chunk = std::min(n, m.chunk_for(sizeof(lattice[0]), kGroup));
  vk::Buffer in = m.device->make_buffer(chunk * sizeof(lattice[0]));
  vk::Buffer size = m.device->make_buffer(chunk * sizeof(double));
  vk::Buffer out = m.device->make_buffer(chunk * sizeof(double));
  for (std::size_t begin = 0; begin < n; begin += chunk) {
    const std::size_t count = std::min(chunk, n - begin);
    timed(m.profile.upload, trace::kUpload, "lattices", count * (sizeof(lattice[0]) + sizeof(double)), [&] {
      std::memcpy(in.data(), lattice.data() + begin, count * sizeof(lattice[0]));
      std::memcpy(size.data(), sizes.data() + begin, count * sizeof(double));
    });
    const std::uint32_t push = static_cast<std::uint32_t>(count);
    m.run("refinement_error", m.refinement, {{&in}, {&size}, {&out}}, &push, count, kGroup);
    timed(m.profile.download, trace::kDownload, "errors", count * sizeof(double),
          [&] { std::memcpy(errors.data() + begin, out.data(), count * sizeof(double)); });
  }
}

void VulkanBackend::device_classify_cells(const HexComplex& complex, std::span<const double> values,
                                          const CellClassification& out, const ClassifyOptions& options) {
  Impl& m = *impl_;
  const std::size_t cells = complex.cells.size();
  const bool uniform = options.uniform_cells_per_axis > 0;
  const bool want_words = !out.words.empty();
  const bool want_crossings = !out.crossings.empty();

  const vk::PhysicalDevice& d = m.device->physical();
  // Point values bound whole when they fit one storage buffer (and the test cap does not ask
  // for chunks), else gathered per cell on the host, 8 per cell.
  const bool gathered =
      values.size() * sizeof(double) > d.max_storage_buffer_range || (m.max_chunk && values.size() > m.max_chunk);
  // Chunks a multiple of 4 cells, so that a word of four subcase bytes never straddles two.
  std::size_t chunk = std::min(cells, m.chunk_for(want_crossings ? 12 * sizeof(double)
                                                  : gathered     ? 8 * sizeof(double)
                                                                 : sizeof(CellCorners),
                                                  kGroup));
  if (chunk < cells) chunk = std::max<std::size_t>(4, chunk / 4 * 4);
  vk::Buffer value_buf;
  const vk::Buffer* values_bound = &value_buf;
  if (!gathered && options.values_from_last_sdf && m.resident && m.resident_data == values.data() &&
      m.resident_size == values.size()) {
    values_bound = &*m.resident;  // the last SDF's output, still on the device
  } else {
    value_buf = m.device->make_buffer((gathered ? 8 * chunk : values.size()) * sizeof(double));
    if (!gathered)
      timed(m.profile.upload, trace::kUpload, "values", values.size() * sizeof(double),
            [&] { std::memcpy(value_buf.data(), values.data(), values.size() * sizeof(double)); });
  }
  vk::Buffer cell_buf = m.device->make_buffer(uniform || gathered ? 4 : chunk * sizeof(CellCorners));
  vk::Buffer code_buf = m.device->make_buffer(want_words ? chunk * 2 * sizeof(std::uint32_t) : 4);
  vk::Buffer crossing_buf = m.device->make_buffer(want_crossings ? chunk * 12 * sizeof(double) : 8);
  vk::Buffer count_buf = m.device->make_buffer(chunk * sizeof(std::uint32_t));
  vk::Buffer subcase_buf = m.device->make_buffer((chunk + 3) / 4 * sizeof(std::uint32_t));
  vk::Buffer bad_buf = m.device->make_buffer(sizeof(std::uint32_t));
  *mapped<std::uint32_t>(bad_buf) = 0;
  vk::Buffer offset_buf = m.device->make_buffer(chunk * sizeof(std::uint64_t));
  const std::size_t blocks = (chunk + kScanBlock - 1) / kScanBlock;
  vk::Buffer total_buf = m.device->make_buffer(blocks * sizeof(std::uint64_t));

  std::uint64_t carry = 0;
  for (std::size_t begin = 0; begin < cells; begin += chunk) {
    const std::size_t count = std::min(chunk, cells - begin);
    const std::size_t cell_bytes = gathered ? 8 * count * sizeof(double) : uniform ? 0 : count * sizeof(CellCorners);
    timed(m.profile.upload, trace::kUpload, "cells", (count + 3) / 4 * sizeof(std::uint32_t) + cell_bytes, [&] {
      std::memset(subcase_buf.data(), 0, (count + 3) / 4 * sizeof(std::uint32_t));
      if (gathered) {
        double* v = mapped<double>(value_buf);
        for (std::size_t i = 0; i < count; ++i)
          for (int c = 0; c < 8; ++c) v[8 * i + c] = values[complex.cells[begin + i][c]];
      } else if (!uniform) {
        std::memcpy(cell_buf.data(), complex.cells.data() + begin, count * sizeof(CellCorners));
      }
    });
    struct {
      std::uint32_t cells, first, uniform_n, flags;
      double zero_tolerance;
    } push{static_cast<std::uint32_t>(count), static_cast<std::uint32_t>(begin),
           gathered ? 0u : options.uniform_cells_per_axis, (gathered ? 1u : 0u) | (want_words ? 2u : 0u),
           options.zero_tolerance};
    m.run(want_crossings ? "classify_crossings" : "classify", want_crossings ? m.classify_crossings : m.classify,
          {{values_bound},
           {&cell_buf},
           {&m.configs},
           {&code_buf},
           {&count_buf},
           {&subcase_buf},
           {&bad_buf},
           {&crossing_buf}},
          &push, count, kGroup);

    // Exclusive prefix sum of the counts (shaders/scan_*.comp), continuing from the chunks before.
    const std::uint32_t n32 = static_cast<std::uint32_t>(count);
    const std::size_t chunk_blocks = (count + kScanBlock - 1) / kScanBlock;
    m.run("scan_blocks", m.scan_blocks, {{&count_buf}, {&offset_buf}, {&total_buf}}, &n32, chunk_blocks * kScanGroup,
          kScanGroup);
    struct {
      std::uint32_t blocks, pad;
      std::uint64_t carry;
    } totals_push{static_cast<std::uint32_t>(chunk_blocks), 0, carry};
    m.run("scan_totals", m.scan_totals, {{&total_buf}}, &totals_push, kScanGroup, kScanGroup);
    m.run("scan_add", m.scan_add, {{&offset_buf}, {&total_buf}}, &n32, count, kScanGroup);

    const std::size_t out_bytes = count + (want_words ? 2 * count * sizeof(std::uint32_t) : 0) +
                                  (want_crossings ? 12 * count * sizeof(double) : 0) + count * sizeof(std::uint64_t);
    timed(m.profile.download, trace::kDownload, "subcases", out_bytes, [&] {
      std::memcpy(out.subcases.data() + begin, subcase_buf.data(), count);
      if (want_words) std::memcpy(out.words.data() + 2 * begin, code_buf.data(), 2 * count * sizeof(std::uint32_t));
      if (want_crossings)
        std::memcpy(out.crossings.data() + 12 * begin, crossing_buf.data(), 12 * count * sizeof(double));
      std::memcpy(out.offsets.data() + begin, offset_buf.data(), count * sizeof(std::uint64_t));
    });
    carry = out.offsets[begin + count - 1] + mapped<std::uint32_t>(count_buf)[count - 1];
  }
  // core's classify() refuses a cell with a non-finite corner value; the shader flagged them.
  if (*mapped<std::uint32_t>(bad_buf)) throw InputError("MC33 classify: a corner value is not finite");
  out.offsets[cells] = carry;
}

std::vector<DeviceInfo> list_vulkan_devices() {
  std::vector<DeviceInfo> out;
  try {
    vk::Instance instance;
    for (const auto& d : instance.devices()) out.push_back(device_info(d));
  } catch (const std::exception&) {
    // No loader or no driver: Vulkan simply has no devices here.
  }
  return out;
}

std::vector<std::string> describe_vulkan_devices() {
  std::vector<std::string> out;
  try {
    vk::Instance instance;
    for (const auto& d : instance.devices()) {
      std::string heaps;
      for (const VkMemoryHeap& h : d.heaps)
        heaps += fmt::format("{}{:.1f} GiB{}", heaps.empty() ? "" : " + ", double(h.size) / (1u << 30),
                             (h.flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) ? " device-local" : "");
      out.push_back(fmt::format(
          "vulkan: {} [{}] driver {} ({}), API {}, shaderFloat64 {}, shaderInt64 {}, "
          "maxStorageBufferRange {} MiB, maxComputeWorkGroupCount {}x{}x{}, maxComputeWorkGroupSize "
          "{}x{}x{} ({} invocations), heaps {}{}",
          d.name, d.type_name(), d.driver_name, d.driver_info, api_string(d.api_version),
          d.shader_float64 ? "yes" : "no", d.shader_int64 ? "yes" : "no", d.max_storage_buffer_range >> 20,
          d.max_work_group_count[0], d.max_work_group_count[1], d.max_work_group_count[2], d.max_work_group_size[0],
          d.max_work_group_size[1], d.max_work_group_size[2], d.max_work_group_invocations, heaps,
          d.api_version < VK_API_VERSION_1_2 ? " (below Vulkan 1.2: not used)" : ""));
    }
  } catch (const std::exception& e) {
    out.push_back(std::string("vulkan: no devices (") + e.what() + ")");
  }
  return out;
}

}  // namespace mchex
