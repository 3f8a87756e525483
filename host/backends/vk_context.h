// The Vulkan boilerplate of the vulkan backend, written once (as in Vulkan-Samples,
// vk-bootstrap): instance, physical devices, one logical device with a compute queue,
// host-visible storage buffers, compute pipelines from embedded SPIR-V with a pipeline cache kept
// on disk, and one synchronous dispatch call. Every Vulkan call's result is checked; a failure
// becomes one std::runtime_error line that names the call and the VkResult.
//
// Target: the Vulkan 1.2 API on any device (Mesa lavapipe here). Compute only; no window system.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>

namespace mchex::vk {

// "vkCreateDevice failed: VK_ERROR_OUT_OF_HOST_MEMORY"
void check(VkResult result, const char* call);
const char* result_name(VkResult result);

// What `mchex-gpu devices` shows of one physical device, and what the backend needs to know.
struct PhysicalDevice {
  VkPhysicalDevice handle = VK_NULL_HANDLE;
  std::string name, driver_name, driver_info;
  VkDriverId driver_id{};
  VkPhysicalDeviceType type{};
  std::uint32_t api_version = 0, driver_version = 0;
  std::uint8_t device_uuid[VK_UUID_SIZE] = {};
  std::uint8_t pipeline_cache_uuid[VK_UUID_SIZE] = {};
  std::uint32_t vendor_id = 0, device_id = 0;
  bool shader_float64 = false, shader_int64 = false;
  std::uint32_t max_storage_buffer_range = 0;
  std::uint32_t max_texel_buffer_elements = 0;
  std::uint32_t max_work_group_count[3] = {}, max_work_group_size[3] = {};
  std::uint32_t max_work_group_invocations = 0;
  std::uint32_t max_push_constants_size = 0;
  std::vector<VkMemoryHeap> heaps;
  int compute_queue_family = -1;  // -1: the device has no compute queue
  // Not a core Vulkan property: NVIDIA's SM count (VK_NV_shader_sm_builtins) or AMD's compute
  // units (VK_AMD_shader_core_properties) where the driver has them, else 0 (unknown).
  std::uint32_t compute_units = 0;

  std::string type_name() const;  // "cpu" | "gpu" | "other"
};

// One VkInstance (API 1.2) and the physical devices it sees.
class Instance {
 public:
  Instance();
  ~Instance();
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;
  VkInstance handle() const { return instance_; }
  const std::vector<PhysicalDevice>& devices() const { return devices_; }

 private:
  VkInstance instance_ = VK_NULL_HANDLE;
  std::vector<PhysicalDevice> devices_;
};

class BufferPool;

// The memory type of the backends' buffers among `allowed` (a VkMemoryRequirements'
// memoryTypeBits): host-visible and host-coherent, since inputs are written and results read
// through the mapping; among those, host-cached first. A discrete GPU's plain host-visible type
// is write-combined system memory, which the CPU reads uncached, and a driver may list it before
// the cached one (AMD's tables do); the cached type is the same system memory read through the
// CPU's caches, at the same PCIe speed for the GPU. On the H200 (NVIDIA driver) the first pick and
// this one ran at the same speed (perf/GPU_RUNS.md); on a CPU device (lavapipe) every type is
// cached. -1 where no type qualifies.
int buffer_memory_type(const VkPhysicalDeviceMemoryProperties& memory, std::uint32_t allowed);

// A buffer in host-visible, host-coherent memory of type `memory_type` (buffer_memory_type),
// mapped for its whole life, usable as a storage buffer and as a uniform texel buffer. size() is
// the size asked for; a buffer from the device's pool may have more memory behind it.
class Buffer {
 public:
  Buffer() = default;
  Buffer(VkDevice device, std::uint32_t memory_type, VkDeviceSize bytes);
  ~Buffer();
  Buffer(Buffer&& o) noexcept;
  Buffer& operator=(Buffer&& o) noexcept;
  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return bytes_; }
  void* data() const { return mapped_; }

 private:
  friend class Device;
  void release();
  VkDevice device_ = VK_NULL_HANDLE;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkDeviceSize bytes_ = 0, capacity_ = 0;
  void* mapped_ = nullptr;
  BufferPool* pool_ = nullptr;  // where release() gives the memory back to, if anywhere
};

// Buffers released by their owners, kept mapped for Device::make_buffer to hand out again: a
// driver on host memory (lavapipe) backs a new allocation with pages only as they are first
// touched, and those page faults cost more than the copies into the buffer (lavapipe: a fresh
// 13 MiB batch of points took 3 ms to fill). At most kMaxBytes are kept.
class BufferPool {
 public:
  static constexpr VkDeviceSize kMaxBytes = VkDeviceSize(256) << 20;
  struct Entry {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize capacity = 0;
    void* mapped = nullptr;
  };
  // Takes e when there is room, else returns false (the caller frees it).
  bool give(const Entry& e);
  // The smallest kept buffer of at least `bytes` and not much more, removed from the pool.
  bool take(VkDeviceSize bytes, Entry& out);
  void destroy_all(VkDevice device);
  VkDeviceSize bytes() const { return bytes_; }

 private:
  std::vector<Entry> entries_;
  VkDeviceSize bytes_ = 0;
};

// A compute pipeline whose bindings 0..num_buffers-1 are buffers and whose push constant block is
// push_bytes long. A binding is a storage buffer, or a uniform texel buffer where its entry of
// texel_formats is a format (VK_FORMAT_UNDEFINED: storage buffer; empty: all storage buffers).
struct Pipeline {
  VkShaderModule module = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  std::uint32_t num_buffers = 0, push_bytes = 0;
  std::vector<VkFormat> texel_formats;
};

// Bytes per texel of the formats the shaders read texel buffers in (std::logic_error for others).
VkDeviceSize texel_bytes(VkFormat f);

// A range of a buffer bound to one binding.
struct BufferRange {
  const Buffer* buffer = nullptr;
  VkDeviceSize offset = 0, bytes = VK_WHOLE_SIZE;
};

// The logical device, its compute queue and the pipeline cache, for one physical device.
class Device {
 public:
  // cache_dir: where the pipeline cache file lives (created if missing); empty: no disk cache.
  Device(const Instance& instance, const PhysicalDevice& physical, std::filesystem::path cache_dir);
  ~Device();  // writes the pipeline cache back to disk
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  const PhysicalDevice& physical() const { return physical_; }
  // A buffer of `bytes`, from the pool when it holds one that fits.
  Buffer make_buffer(VkDeviceSize bytes) const;
  // The property flags of the memory type that make_buffer allocates from.
  VkMemoryPropertyFlags buffer_memory_flags() const { return memory_.memoryTypes[buffer_memory_type_].propertyFlags; }
  VkDeviceSize pooled_bytes() const { return pool_.bytes(); }  // memory the pool holds now
  Pipeline make_pipeline(std::span<const std::uint32_t> spirv, std::uint32_t num_buffers, std::uint32_t push_bytes,
                         std::vector<VkFormat> texel_formats = {});
  void destroy(Pipeline& p);
  // Records, submits and waits for one dispatch of groups_x workgroups. A texel binding's range
  // must hold at most maxTexelBufferElements texels (std::logic_error otherwise).
  void dispatch(const Pipeline& p, std::span<const BufferRange> buffers, const void* push, std::uint32_t groups_x);

  // The file the pipeline cache is read from and written to (empty when there is none), and how
  // many bytes of it this device loaded at creation (0: no file, or one the driver rejected).
  const std::filesystem::path& cache_file() const { return cache_file_; }
  std::size_t cache_bytes_loaded() const { return cache_bytes_loaded_; }
  void save_cache() const;

 private:
  void release();
  PhysicalDevice physical_;
  VkPhysicalDeviceMemoryProperties memory_{};
  std::uint32_t buffer_memory_type_ = 0;  // buffer_memory_type for the buffers' usage
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool command_pool_ = VK_NULL_HANDLE;
  VkCommandBuffer command_buffer_ = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkPipelineCache cache_ = VK_NULL_HANDLE;
  mutable BufferPool pool_;
  std::filesystem::path cache_file_;
  std::size_t cache_bytes_loaded_ = 0;
};

// The default pipeline cache folder: $XDG_CACHE_HOME/mchex-gpu, else $HOME/.cache/mchex-gpu,
// else none.
std::filesystem::path default_cache_dir();

}  // namespace mchex::vk
