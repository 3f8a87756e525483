#include "host/backends/vk_context.h"

#include "core/base/error.h"

#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <system_error>
#include <utility>

namespace mchex::vk {

const char* result_name(VkResult r) {
  switch (r) {
#define MCHEX_VK_RESULT(x) \
  case x: return #x;
    MCHEX_VK_RESULT(VK_SUCCESS)
    MCHEX_VK_RESULT(VK_NOT_READY)
    MCHEX_VK_RESULT(VK_TIMEOUT)
    MCHEX_VK_RESULT(VK_INCOMPLETE)
    MCHEX_VK_RESULT(VK_ERROR_OUT_OF_HOST_MEMORY)
    MCHEX_VK_RESULT(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    MCHEX_VK_RESULT(VK_ERROR_INITIALIZATION_FAILED)
    MCHEX_VK_RESULT(VK_ERROR_DEVICE_LOST)
    MCHEX_VK_RESULT(VK_ERROR_MEMORY_MAP_FAILED)
    MCHEX_VK_RESULT(VK_ERROR_LAYER_NOT_PRESENT)
    MCHEX_VK_RESULT(VK_ERROR_EXTENSION_NOT_PRESENT)
    MCHEX_VK_RESULT(VK_ERROR_FEATURE_NOT_PRESENT)
    MCHEX_VK_RESULT(VK_ERROR_INCOMPATIBLE_DRIVER)
    MCHEX_VK_RESULT(VK_ERROR_TOO_MANY_OBJECTS)
    MCHEX_VK_RESULT(VK_ERROR_FORMAT_NOT_SUPPORTED)
    MCHEX_VK_RESULT(VK_ERROR_FRAGMENTED_POOL)
    MCHEX_VK_RESULT(VK_ERROR_UNKNOWN)
    MCHEX_VK_RESULT(VK_ERROR_OUT_OF_POOL_MEMORY)
    MCHEX_VK_RESULT(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    MCHEX_VK_RESULT(VK_ERROR_FRAGMENTATION)
    MCHEX_VK_RESULT(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    MCHEX_VK_RESULT(VK_PIPELINE_COMPILE_REQUIRED)
#undef MCHEX_VK_RESULT
    default: return "an unknown VkResult";
  }
}

void check(VkResult result, const char* call) {
  if (result != VK_SUCCESS)
    throw std::runtime_error(std::string("vulkan: ") + call + " failed: " + result_name(result) + " (" +
                             std::to_string(static_cast<int>(result)) + ")");
}

std::string PhysicalDevice::type_name() const {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "gpu";
    default: return "other";
  }
}

// ---- Instance --------------------------------------------------------------------------------

Instance::Instance() {
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "mchex-gpu";
  app.apiVersion = VK_API_VERSION_1_2;
  VkInstanceCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  info.pApplicationInfo = &app;
  const VkResult created = vkCreateInstance(&info, nullptr, &instance_);
  // No installed driver (no ICD, or none for Vulkan 1.2) means "no Vulkan device here": a
  // usage matter for `--backend vulkan` (exit 1), not an internal failure.
  if (created == VK_ERROR_INCOMPATIBLE_DRIVER)
    throw InputError("backend 'vulkan': no Vulkan 1.2 driver found (vkCreateInstance: VK_ERROR_INCOMPATIBLE_DRIVER)");
  check(created, "vkCreateInstance");

  std::uint32_t n = 0;
  VkResult r = vkEnumeratePhysicalDevices(instance_, &n, nullptr);
  std::vector<VkPhysicalDevice> handles(n);
  if (r == VK_SUCCESS) r = vkEnumeratePhysicalDevices(instance_, &n, handles.data());
  if (r != VK_SUCCESS && r != VK_INCOMPLETE) {
    vkDestroyInstance(instance_, nullptr);
    check(r, "vkEnumeratePhysicalDevices");
  }
  handles.resize(n);
  for (VkPhysicalDevice h : handles) {
    PhysicalDevice d;
    d.handle = h;
    // Compute units are not a core Vulkan property; two vendor extensions state them:
    // VK_NV_shader_sm_builtins (streaming multiprocessors) and VK_AMD_shader_core_properties
    // (shader engines x arrays per engine x compute units per array). Otherwise 0 (unknown).
    std::uint32_t num_extensions = 0;
    vkEnumerateDeviceExtensionProperties(h, nullptr, &num_extensions, nullptr);
    std::vector<VkExtensionProperties> extensions(num_extensions);
    if (num_extensions) vkEnumerateDeviceExtensionProperties(h, nullptr, &num_extensions, extensions.data());
    auto has_extension = [&](const char* name) {
      for (const VkExtensionProperties& e : extensions)
        if (std::strcmp(e.extensionName, name) == 0) return true;
      return false;
    };
    VkPhysicalDeviceShaderSMBuiltinsPropertiesNV nv_sm{};
    nv_sm.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_SM_BUILTINS_PROPERTIES_NV;
    VkPhysicalDeviceShaderCorePropertiesAMD amd_core{};
    amd_core.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_CORE_PROPERTIES_AMD;
    void* vendor = nullptr;
    if (has_extension(VK_NV_SHADER_SM_BUILTINS_EXTENSION_NAME)) vendor = &nv_sm;
    else if (has_extension(VK_AMD_SHADER_CORE_PROPERTIES_EXTENSION_NAME)) vendor = &amd_core;
    VkPhysicalDeviceDriverProperties driver{};
    driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
    driver.pNext = vendor;
    VkPhysicalDeviceIDProperties ids{};
    ids.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ID_PROPERTIES;
    ids.pNext = &driver;
    VkPhysicalDeviceProperties2 props{};
    props.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    props.pNext = &ids;
    vkGetPhysicalDeviceProperties2(h, &props);
    const VkPhysicalDeviceProperties& p = props.properties;
    // Devices below the 1.2 API the backend is written for are listed but never selected.
    d.name = p.deviceName;
    d.driver_name = driver.driverName;
    d.driver_info = driver.driverInfo;
    d.driver_id = driver.driverID;
    d.type = p.deviceType;
    d.api_version = p.apiVersion;
    d.driver_version = p.driverVersion;
    std::memcpy(d.device_uuid, ids.deviceUUID, VK_UUID_SIZE);
    std::memcpy(d.pipeline_cache_uuid, p.pipelineCacheUUID, VK_UUID_SIZE);
    d.vendor_id = p.vendorID;
    d.device_id = p.deviceID;
    d.max_storage_buffer_range = p.limits.maxStorageBufferRange;
    d.max_texel_buffer_elements = p.limits.maxTexelBufferElements;
    for (int i = 0; i < 3; ++i) {
      d.max_work_group_count[i] = p.limits.maxComputeWorkGroupCount[i];
      d.max_work_group_size[i] = p.limits.maxComputeWorkGroupSize[i];
    }
    d.max_work_group_invocations = p.limits.maxComputeWorkGroupInvocations;
    d.max_push_constants_size = p.limits.maxPushConstantsSize;
    if (vendor == &nv_sm) d.compute_units = nv_sm.shaderSMCount;
    if (vendor == &amd_core)
      d.compute_units =
          amd_core.shaderEngineCount * amd_core.shaderArraysPerEngineCount * amd_core.computeUnitsPerShaderArray;
    VkPhysicalDeviceFeatures features{};
    vkGetPhysicalDeviceFeatures(h, &features);
    d.shader_float64 = features.shaderFloat64;
    d.shader_int64 = features.shaderInt64;
    VkPhysicalDeviceMemoryProperties memory{};
    vkGetPhysicalDeviceMemoryProperties(h, &memory);
    d.heaps.assign(memory.memoryHeaps, memory.memoryHeaps + memory.memoryHeapCount);
    std::uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(h, &families, nullptr);
    std::vector<VkQueueFamilyProperties> family(families);
    vkGetPhysicalDeviceQueueFamilyProperties(h, &families, family.data());
    for (std::uint32_t i = 0; i < families; ++i)
      if (family[i].queueFlags & VK_QUEUE_COMPUTE_BIT) {
        d.compute_queue_family = static_cast<int>(i);
        break;
      }
    devices_.push_back(std::move(d));
  }
}

Instance::~Instance() {
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

// ---- Buffer ----------------------------------------------------------------------------------

int buffer_memory_type(const VkPhysicalDeviceMemoryProperties& memory, std::uint32_t allowed) {
  constexpr VkMemoryPropertyFlags kMapped = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  int first = -1;
  for (std::uint32_t i = 0; i < memory.memoryTypeCount && i < 32; ++i) {
    const VkMemoryPropertyFlags f = memory.memoryTypes[i].propertyFlags;
    if (!(allowed >> i & 1) || (f & kMapped) != kMapped) continue;
    if (f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT) return static_cast<int>(i);
    if (first < 0) first = static_cast<int>(i);
  }
  return first;
}

namespace {

VkBufferCreateInfo buffer_info(VkDeviceSize bytes) {
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = bytes ? bytes : 4;  // a zero-sized buffer is invalid; an empty batch binds 4 bytes
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  return info;
}

}  // namespace

Buffer::Buffer(VkDevice device, std::uint32_t memory_type, VkDeviceSize bytes)
    : device_(device), bytes_(bytes), capacity_(bytes ? bytes : 4) {
  const VkBufferCreateInfo info = buffer_info(bytes);
  check(vkCreateBuffer(device, &info, nullptr, &buffer_), "vkCreateBuffer");
  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(device, buffer_, &req);
  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = memory_type;
  try {
    check(vkAllocateMemory(device, &alloc, nullptr, &memory_), "vkAllocateMemory");
    check(vkBindBufferMemory(device, buffer_, memory_, 0), "vkBindBufferMemory");
    check(vkMapMemory(device, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_), "vkMapMemory");
  } catch (...) {
    release();
    throw;
  }
}

void Buffer::release() {
  if (!device_) return;
  if (pool_ && buffer_ && memory_ && mapped_ && pool_->give({buffer_, memory_, capacity_, mapped_})) {
    mapped_ = nullptr;
    buffer_ = VK_NULL_HANDLE;
    memory_ = VK_NULL_HANDLE;
    return;
  }
  if (mapped_) vkUnmapMemory(device_, memory_);
  if (buffer_) vkDestroyBuffer(device_, buffer_, nullptr);
  if (memory_) vkFreeMemory(device_, memory_, nullptr);
  mapped_ = nullptr;
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
}

Buffer::~Buffer() { release(); }

Buffer::Buffer(Buffer&& o) noexcept
    : device_(std::exchange(o.device_, VK_NULL_HANDLE)),
      buffer_(std::exchange(o.buffer_, VK_NULL_HANDLE)),
      memory_(std::exchange(o.memory_, VK_NULL_HANDLE)),
      bytes_(std::exchange(o.bytes_, 0)),
      capacity_(std::exchange(o.capacity_, 0)),
      mapped_(std::exchange(o.mapped_, nullptr)),
      pool_(std::exchange(o.pool_, nullptr)) {}

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    release();
    device_ = std::exchange(o.device_, VK_NULL_HANDLE);
    buffer_ = std::exchange(o.buffer_, VK_NULL_HANDLE);
    memory_ = std::exchange(o.memory_, VK_NULL_HANDLE);
    bytes_ = std::exchange(o.bytes_, 0);
    capacity_ = std::exchange(o.capacity_, 0);
    mapped_ = std::exchange(o.mapped_, nullptr);
    pool_ = std::exchange(o.pool_, nullptr);
  }
  return *this;
}

bool BufferPool::give(const Entry& e) {
  if (bytes_ + e.capacity > kMaxBytes) return false;
  entries_.push_back(e);
  bytes_ += e.capacity;
  return true;
}

bool BufferPool::take(VkDeviceSize bytes, Entry& out) {
  // "Not much more": a small request must not tie up a large buffer that a later large one needs.
  const VkDeviceSize most = 2 * bytes + (VkDeviceSize(1) << 20);
  std::size_t best = entries_.size();
  for (std::size_t i = 0; i < entries_.size(); ++i)
    if (entries_[i].capacity >= bytes && entries_[i].capacity <= most &&
        (best == entries_.size() || entries_[i].capacity < entries_[best].capacity))
      best = i;
  if (best == entries_.size()) return false;
  out = entries_[best];
  bytes_ -= out.capacity;
  entries_.erase(entries_.begin() + static_cast<std::ptrdiff_t>(best));
  return true;
}

void BufferPool::destroy_all(VkDevice device) {
  for (const Entry& e : entries_) {
    vkUnmapMemory(device, e.memory);
    vkDestroyBuffer(device, e.buffer, nullptr);
    vkFreeMemory(device, e.memory, nullptr);
  }
  entries_.clear();
  bytes_ = 0;
}

// ---- Device ----------------------------------------------------------------------------------

VkDeviceSize texel_bytes(VkFormat f) {
  switch (f) {
    case VK_FORMAT_R32_UINT: return 4;
    case VK_FORMAT_R32G32_UINT: return 8;
    case VK_FORMAT_R32G32B32A32_SFLOAT:
    case VK_FORMAT_R32G32B32A32_UINT: return 16;
    default: throw std::logic_error("vulkan: a texel format the backend does not use");
  }
}

std::filesystem::path default_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::filesystem::path(x) / "mchex-gpu";
  if (const char* h = std::getenv("HOME"); h && *h) return std::filesystem::path(h) / ".cache" / "mchex-gpu";
  return {};
}

namespace {

VkDescriptorType descriptor_type(const Pipeline& p, std::uint32_t binding) {
  return p.texel_formats[binding] == VK_FORMAT_UNDEFINED ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                                         : VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
}

// The cache file is keyed by what invalidates a driver's pipeline cache: the device (UUID) and
// the driver version. The driver also checks the header it wrote (Vulkan spec, "Pipeline Cache
// Header") and ignores data from another device or driver, so a stale file costs only a recompile.
std::filesystem::path cache_file_for(const std::filesystem::path& dir, const PhysicalDevice& d) {
  static const char* hex = "0123456789abcdef";
  std::string name = "vulkan-pipelines-";
  for (std::uint8_t b : d.device_uuid) name += hex[b >> 4], name += hex[b & 15];
  name += '-';
  name += std::to_string(d.driver_version);
  name += ".bin";
  return dir / name;
}

}  // namespace

Device::Device(const Instance& instance, const PhysicalDevice& physical, std::filesystem::path cache_dir)
    : physical_(physical) {
  (void)instance;
  if (physical.compute_queue_family < 0)
    throw std::runtime_error("vulkan: device '" + physical.name + "' has no compute queue");
  vkGetPhysicalDeviceMemoryProperties(physical.handle, &memory_);

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue{};
  queue.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  queue.queueFamilyIndex = static_cast<std::uint32_t>(physical.compute_queue_family);
  queue.queueCount = 1;
  queue.pQueuePriorities = &priority;
  VkPhysicalDeviceFeatures features{};
  features.shaderFloat64 = physical.shader_float64;
  features.shaderInt64 = physical.shader_int64;
  VkDeviceCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  info.queueCreateInfoCount = 1;
  info.pQueueCreateInfos = &queue;
  info.pEnabledFeatures = &features;
  check(vkCreateDevice(physical.handle, &info, nullptr, &device_), "vkCreateDevice");
  try {
    // A buffer's allowed memory types depend on its usage and flags, not its size (Vulkan spec,
    // VkMemoryRequirements), so one probe buffer gives every buffer's.
    {
      const VkBufferCreateInfo probe_info = buffer_info(4);
      VkBuffer probe = VK_NULL_HANDLE;
      check(vkCreateBuffer(device_, &probe_info, nullptr, &probe), "vkCreateBuffer");
      VkMemoryRequirements req{};
      vkGetBufferMemoryRequirements(device_, probe, &req);
      vkDestroyBuffer(device_, probe, nullptr);
      const int type = buffer_memory_type(memory_, req.memoryTypeBits);
      if (type < 0)
        throw std::runtime_error("vulkan: device '" + physical.name +
                                 "' has no host-visible, host-coherent memory type");
      buffer_memory_type_ = static_cast<std::uint32_t>(type);
    }
    vkGetDeviceQueue(device_, queue.queueFamilyIndex, 0, &queue_);
    VkCommandPoolCreateInfo pool{};
    pool.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pool.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pool.queueFamilyIndex = queue.queueFamilyIndex;
    check(vkCreateCommandPool(device_, &pool, nullptr, &command_pool_), "vkCreateCommandPool");
    VkCommandBufferAllocateInfo cb{};
    cb.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cb.commandPool = command_pool_;
    cb.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cb.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(device_, &cb, &command_buffer_), "vkAllocateCommandBuffers");
    // One descriptor set at a time (dispatch() waits), so a small pool reset per dispatch does.
    const VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 16},
                                          {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 16}};
    VkDescriptorPoolCreateInfo dp{};
    dp.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    dp.maxSets = 1;
    dp.poolSizeCount = 2;
    dp.pPoolSizes = sizes;
    check(vkCreateDescriptorPool(device_, &dp, nullptr, &descriptor_pool_), "vkCreateDescriptorPool");
    VkFenceCreateInfo fence{};
    fence.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    check(vkCreateFence(device_, &fence, nullptr, &fence_), "vkCreateFence");

    std::vector<char> data;
    if (!cache_dir.empty()) {
      cache_file_ = cache_file_for(cache_dir, physical);
      std::ifstream in(cache_file_, std::ios::binary);
      if (in) data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    VkPipelineCacheCreateInfo pc{};
    pc.sType = VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO;
    pc.initialDataSize = data.size();
    pc.pInitialData = data.empty() ? nullptr : data.data();
    if (vkCreatePipelineCache(device_, &pc, nullptr, &cache_) != VK_SUCCESS) {
      // A corrupt file is not an error: start an empty cache (it is rewritten at exit).
      pc.initialDataSize = 0;
      pc.pInitialData = nullptr;
      data.clear();
      check(vkCreatePipelineCache(device_, &pc, nullptr, &cache_), "vkCreatePipelineCache");
    }
    cache_bytes_loaded_ = data.size();
  } catch (...) {
    release();
    throw;
  }
}

void Device::save_cache() const {
  if (cache_file_.empty() || !cache_) return;
  std::size_t n = 0;
  if (vkGetPipelineCacheData(device_, cache_, &n, nullptr) != VK_SUCCESS || n == 0) return;
  std::vector<char> data(n);
  if (vkGetPipelineCacheData(device_, cache_, &n, data.data()) != VK_SUCCESS) return;
  data.resize(n);
  // A cache is an optimisation: a folder we cannot write costs a recompile next time, never a
  // failure. Written to a temporary name and renamed, so a concurrent run never reads half a file.
  std::error_code ec;
  std::filesystem::create_directories(cache_file_.parent_path(), ec);
  const std::filesystem::path tmp = cache_file_.string() + ".tmp" + std::to_string(static_cast<long>(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return;
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
    if (!out) {
      out.close();
      std::filesystem::remove(tmp, ec);
      return;
    }
  }
  std::filesystem::rename(tmp, cache_file_, ec);
  if (ec) std::filesystem::remove(tmp, ec);
}

Device::~Device() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    save_cache();
  }
  release();
}

void Device::release() {
  if (!device_) return;
  pool_.destroy_all(device_);
  if (cache_) vkDestroyPipelineCache(device_, cache_, nullptr);
  if (fence_) vkDestroyFence(device_, fence_, nullptr);
  if (descriptor_pool_) vkDestroyDescriptorPool(device_, descriptor_pool_, nullptr);
  if (command_pool_) vkDestroyCommandPool(device_, command_pool_, nullptr);
  vkDestroyDevice(device_, nullptr);
  device_ = VK_NULL_HANDLE;
}

Buffer Device::make_buffer(VkDeviceSize bytes) const {
  Buffer b;
  BufferPool::Entry e;
  if (pool_.take(std::max<VkDeviceSize>(bytes, 4), e)) {
    b.device_ = device_;
    b.buffer_ = e.buffer;
    b.memory_ = e.memory;
    b.capacity_ = e.capacity;
    b.mapped_ = e.mapped;
    b.bytes_ = bytes;
  } else {
    b = Buffer(device_, buffer_memory_type_, bytes);
  }
  b.pool_ = &pool_;
  return b;
}

Pipeline Device::make_pipeline(std::span<const std::uint32_t> spirv, std::uint32_t num_buffers,
                               std::uint32_t push_bytes, std::vector<VkFormat> texel_formats) {
  Pipeline p;
  p.num_buffers = num_buffers;
  p.push_bytes = push_bytes;
  texel_formats.resize(num_buffers, VK_FORMAT_UNDEFINED);
  p.texel_formats = std::move(texel_formats);
  try {
    VkShaderModuleCreateInfo sm{};
    sm.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    sm.codeSize = spirv.size_bytes();
    sm.pCode = spirv.data();
    check(vkCreateShaderModule(device_, &sm, nullptr, &p.module), "vkCreateShaderModule");
    std::vector<VkDescriptorSetLayoutBinding> bindings(num_buffers);
    for (std::uint32_t i = 0; i < num_buffers; ++i)
      bindings[i] = {i, descriptor_type(p, i), 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    VkDescriptorSetLayoutCreateInfo dsl{};
    dsl.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    dsl.bindingCount = num_buffers;
    dsl.pBindings = bindings.data();
    check(vkCreateDescriptorSetLayout(device_, &dsl, nullptr, &p.set_layout), "vkCreateDescriptorSetLayout");
    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes};
    VkPipelineLayoutCreateInfo pl{};
    pl.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    pl.setLayoutCount = 1;
    pl.pSetLayouts = &p.set_layout;
    pl.pushConstantRangeCount = push_bytes ? 1 : 0;
    pl.pPushConstantRanges = &range;
    check(vkCreatePipelineLayout(device_, &pl, nullptr, &p.layout), "vkCreatePipelineLayout");
    VkComputePipelineCreateInfo cp{};
    cp.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
    cp.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    cp.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    cp.stage.module = p.module;
    cp.stage.pName = "main";
    cp.layout = p.layout;
    check(vkCreateComputePipelines(device_, cache_, 1, &cp, nullptr, &p.pipeline), "vkCreateComputePipelines");
  } catch (...) {
    destroy(p);
    throw;
  }
  return p;
}

void Device::destroy(Pipeline& p) {
  if (p.pipeline) vkDestroyPipeline(device_, p.pipeline, nullptr);
  if (p.layout) vkDestroyPipelineLayout(device_, p.layout, nullptr);
  if (p.set_layout) vkDestroyDescriptorSetLayout(device_, p.set_layout, nullptr);
  if (p.module) vkDestroyShaderModule(device_, p.module, nullptr);
  p = Pipeline{};
}

void Device::dispatch(const Pipeline& p, std::span<const BufferRange> buffers, const void* push,
                      std::uint32_t groups_x) {
  if (buffers.size() != p.num_buffers) throw std::logic_error("vulkan: dispatch with the wrong number of buffers");
  if (groups_x == 0) return;
  if (groups_x > physical_.max_work_group_count[0])
    throw std::logic_error("vulkan: dispatch over maxComputeWorkGroupCount[0]");
  check(vkResetDescriptorPool(device_, descriptor_pool_, 0), "vkResetDescriptorPool");
  VkDescriptorSetAllocateInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  ai.descriptorPool = descriptor_pool_;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &p.set_layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  check(vkAllocateDescriptorSets(device_, &ai, &set), "vkAllocateDescriptorSets");
  std::vector<VkDescriptorBufferInfo> infos(buffers.size());
  std::vector<VkBufferView> views(buffers.size(), VK_NULL_HANDLE);
  std::vector<VkWriteDescriptorSet> writes(buffers.size());
  // The views live until the dispatch has finished (below) or failed.
  struct Views {
    VkDevice device;
    std::vector<VkBufferView>& views;
    ~Views() {
      for (VkBufferView v : views)
        if (v) vkDestroyBufferView(device, v, nullptr);
    }
  } keep{device_, views};
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    const BufferRange& b = buffers[i];
    VkDeviceSize bytes = b.bytes == VK_WHOLE_SIZE ? b.buffer->size() - b.offset : b.bytes;
    if (bytes == 0) bytes = 4;  // empty ranges are invalid; the shader reads nothing of them
    writes[i] = VkWriteDescriptorSet{};
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstSet = set;
    writes[i].dstBinding = static_cast<std::uint32_t>(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = descriptor_type(p, static_cast<std::uint32_t>(i));
    if (p.texel_formats[i] != VK_FORMAT_UNDEFINED) {
      const VkDeviceSize texel = texel_bytes(p.texel_formats[i]);
      // Texel bindings are whole arrays (offset 0 meets minTexelBufferOffsetAlignment) of at
      // least one texel, at most maxTexelBufferElements.
      if (b.offset != 0 || bytes < texel || bytes / texel > physical_.max_texel_buffer_elements)
        throw std::logic_error("vulkan: a texel binding that is not a whole array within the texel limits");
      VkBufferViewCreateInfo view{};
      view.sType = VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO;
      view.buffer = b.buffer->handle();
      view.format = p.texel_formats[i];
      view.offset = b.offset;
      view.range = bytes / texel * texel;
      check(vkCreateBufferView(device_, &view, nullptr, &views[i]), "vkCreateBufferView");
      writes[i].pTexelBufferView = &views[i];
    } else {
      if (bytes > physical_.max_storage_buffer_range)
        throw std::logic_error("vulkan: a binding over maxStorageBufferRange (chunking bug)");
      infos[i] = {b.buffer->handle(), b.offset, bytes};
      writes[i].pBufferInfo = &infos[i];
    }
  }
  vkUpdateDescriptorSets(device_, static_cast<std::uint32_t>(writes.size()), writes.data(), 0, nullptr);

  check(vkResetCommandBuffer(command_buffer_, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(command_buffer_, &begin), "vkBeginCommandBuffer");
  vkCmdBindPipeline(command_buffer_, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipeline);
  vkCmdBindDescriptorSets(command_buffer_, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 1, &set, 0, nullptr);
  if (p.push_bytes) vkCmdPushConstants(command_buffer_, p.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, p.push_bytes, push);
  vkCmdDispatch(command_buffer_, groups_x, 1, 1);
  // Make the shader's writes visible to the host's reads of the mapped memory.
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  vkCmdPipelineBarrier(command_buffer_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                       &barrier, 0, nullptr, 0, nullptr);
  check(vkEndCommandBuffer(command_buffer_), "vkEndCommandBuffer");
  VkSubmitInfo submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &command_buffer_;
  check(vkResetFences(device_, 1, &fence_), "vkResetFences");
  check(vkQueueSubmit(queue_, 1, &submit, fence_), "vkQueueSubmit");
  check(vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

}  // namespace mchex::vk
