#include "host/backends/opencl.h"

#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

#include <fmt/format.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/base/trace.h"
#include "core/device/cell_words.h"
#include "core/device/device_scene.h"
#include "core/grid/refinement_error.h"
#include "core/sdf/sdf.h"
#include "core/sdf/shapes.h"

namespace mchex::embedded {
extern const char* const kOpenclSources[];
extern const std::size_t kOpenclSources_count;
}  // namespace mchex::embedded

namespace mchex {
namespace {

namespace fs = std::filesystem;

// One line for any OpenCL failure: the call and its error code.
[[noreturn]] void fail(const cl::Error& e, const std::string& what) {
  throw std::runtime_error(fmt::format("OpenCL: {} failed in {} (error {})", what, e.what(), e.err()));
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ' || s.back() == '\n')) s.pop_back();
  return s;
}

bool has_fp64(const cl::Device& d) {
  return d.getInfo<CL_DEVICE_EXTENSIONS>().find("cl_khr_fp64") != std::string::npos &&
         d.getInfo<CL_DEVICE_DOUBLE_FP_CONFIG>() != 0;
}

DeviceInfo describe(const cl::Platform& p, const cl::Device& d) {
  DeviceInfo info;
  info.backend = "opencl";
  info.platform = trim(p.getInfo<CL_PLATFORM_NAME>());
  info.name = trim(d.getInfo<CL_DEVICE_NAME>());
  const cl_device_type t = d.getInfo<CL_DEVICE_TYPE>();
  info.type = (t & CL_DEVICE_TYPE_GPU) ? "gpu" : (t & CL_DEVICE_TYPE_CPU) ? "cpu" : "other";
  info.fp64 = has_fp64(d);
  info.max_buffer_bytes = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
  info.global_memory_bytes = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
  info.compute_units = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
  info.version = trim(d.getInfo<CL_DEVICE_VERSION>()) + ", driver " + trim(d.getInfo<CL_DRIVER_VERSION>());
  return info;
}

std::vector<cl::Platform> platforms() {
  std::vector<cl::Platform> out;
  // The ICD loader reports "no platform" as an error (CL_PLATFORM_NOT_FOUND_KHR): that is an
  // empty list here, not a failure.
  cl_uint n = 0;
  if (clGetPlatformIDs(0, nullptr, &n) != CL_SUCCESS || n == 0) return out;
  try {
    cl::Platform::get(&out);
  } catch (const cl::Error& e) {
    fail(e, "listing platforms");
  }
  return out;
}

std::vector<cl::Device> devices_of(const cl::Platform& p) {
  std::vector<cl::Device> out;
  cl_uint n = 0;
  if (clGetDeviceIDs(p(), CL_DEVICE_TYPE_ALL, 0, nullptr, &n) != CL_SUCCESS || n == 0) return out;
  p.getDevices(CL_DEVICE_TYPE_ALL, &out);
  return out;
}

// FNV-1a, 64 bits: the cache key only has to change when any of its inputs does.
std::uint64_t fnv1a(const std::string& s, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

fs::path default_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "mchex-gpu";
  if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "mchex-gpu";
  return {};
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return {};
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Identity of a surface for the scene cache (see SdfSource).
struct SurfaceKey {
  const TriangleSurface* surface = nullptr;
  const void* vertices = nullptr;
  const void* triangles = nullptr;
  std::size_t nv = 0, nt = 0;
  friend bool operator==(const SurfaceKey&, const SurfaceKey&) = default;
};

SurfaceKey key_of(const TriangleSurface* s) {
  return {s, s->vertices.data(), s->triangles.data(), s->vertices.size(), s->triangles.size()};
}

}  // namespace

struct OpenclBackend::Impl {
  OpenclOptions options;
  DeviceInfo info;
  cl::Platform platform;
  cl::Device device;
  cl::Context context;
  cl::CommandQueue queue;
  cl::Program program;
  bool from_cache = false;
  std::string cache_path;
  OpenclProfile profile;
  cl::Buffer configs;
  std::map<std::string, cl::Kernel> kernels;  // made once per program (PoCL: ~ms each)
  bool host_unified = false;                  // CL_DEVICE_HOST_UNIFIED_MEMORY: buffers may live in host memory
  bool fp32 = false;                          // the single-precision path (kernels/sdf_fp32.h)
  Fp32Stats fp32_stats;

  // The fp32 path's scene of the last surface: DeviceScene's nodes with DeviceScene32's float
  // corners and slacks on the device; on the host what turns candidates into core's values.
  struct Scene32 {
    std::vector<cl::Buffer> buffers;  // nodes, node_slack, slot_corners32, slot_slack
    std::unique_ptr<Fp32Surface> host;
    float scale = 0;
  } scene32;

  // The output buffer of the last signed_distance call (when it was one chunk on a device with its
  // own memory) and the host array it was read into: ClassifyOptions::values_from_last_sdf.
  cl::Buffer resident;
  const double* resident_data = nullptr;
  std::size_t resident_size = 0;
  bool resident_matches(std::span<const double> v) const {
    return resident_data && resident_data == v.data() && resident_size == v.size();
  }

  // The device scene of the last surface.
  SurfaceKey scene_key;
  std::vector<cl::Buffer>
      scene;  // kernels/sdf.h SCENE_PARAMS_ order: wide tree, leaf bounds and slots, slot arrays, normals
  double scene_scale = 0;

  std::size_t max_alloc() const { return std::size_t(info.max_buffer_bytes); }

  // Items per chunk when each item needs `bytes` bytes in its largest buffer.
  // (At most 2^30: 32-bit indices in the kernels.)
  std::size_t chunk(std::size_t bytes) const {
    return items_per_chunk(info.max_buffer_bytes, bytes, std::size_t(1) << 30, options.max_chunk);
  }

  void pick_device() {
    bool any_platform = false;
    std::vector<std::pair<cl::Platform, cl::Device>> usable;
    std::string seen;
    for (const cl::Platform& p : platforms()) {
      const std::string name = trim(p.getInfo<CL_PLATFORM_NAME>());
      if (!options.platform.empty() && name.find(options.platform) == std::string::npos) continue;
      any_platform = true;
      for (const cl::Device& d : devices_of(p)) {
        seen += (seen.empty() ? "" : ", ") + trim(d.getInfo<CL_DEVICE_NAME>());
        usable.emplace_back(p, d);
      }
    }
    if (!any_platform)
      throw InputError(options.platform.empty()
                           ? "opencl backend: no OpenCL platform found (is an ICD such as PoCL installed?)"
                           : "opencl backend: no OpenCL platform named '" + options.platform + "'");
    if (usable.empty()) throw InputError("opencl backend: the OpenCL platform has no devices");
    // A GPU first (when preferred), then a device with fp64 (the direct path) before one without.
    auto rank = [&](const cl::Device& d) {
      return (options.prefer_gpu && (d.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) ? 0 : 2) + (has_fp64(d) ? 0 : 1);
    };
    auto it = std::min_element(usable.begin(), usable.end(),
                               [&](const auto& a, const auto& b) { return rank(a.second) < rank(b.second); });
    platform = it->first;
    device = it->second;
    info = describe(platform, device);
    fp32 = !info.fp64 || options.force_fp32 || fp32_forced_by_environment();
    info.precision = fp32 ? "fp32" : "fp64";
    host_unified = options.zero_copy && device.getInfo<CL_DEVICE_HOST_UNIFIED_MEMORY>() == CL_TRUE;
    info.kernels =
        fp32 ? "surface SDF: float candidate search (kernels/sdf_fp32.h), values on the host in double; shapes, "
               "refinement error and classification on the host"
             : fmt::format("surface SDF: walks of {} point(s), {} points per work item; classification: {} cells per "
                           "work item{}",
                           sdf_packet(), sdf_points_per_item(), classify_cells_per_item(),
                           host_unified ? "; the host's arrays used in place" : "");
  }

  // MC33 classification: runs of cells per work item on CPU devices (core's loop, in effect),
  // one each on GPUs.
  cl_uint classify_cells_per_item() const { return info.type == "gpu" ? 1 : 16; }

  int sdf_packet() const { return info.type == "gpu" ? 1 : 8; }
  // Surface points per work item: several packets on a CPU device (each seeded by the one
  // before), one on a GPU.
  cl_uint sdf_points_per_item() const { return info.type == "gpu" ? 1 : cl_uint(4 * sdf_packet()); }

  std::string source_text() const {
    std::string s;
    for (std::size_t i = 0; i < embedded::kOpenclSources_count; ++i) s += embedded::kOpenclSources[i], s += "\n";
    return s;
  }

  std::string build_log() const {
    std::string log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device);
    for (char& c : log)
      if (c == '\n') c = ' ';
    return trim(log.substr(0, 600));
  }

  void build_program() {
    // -cl-std=CL1.2; no fast-math flags: the kernels must round like the CPU reference (and the
    // fp32 path's error bounds assume IEEE rounding). -DMCHEX_FP32: no double anywhere.
    // MCHEX_SDF_PACKET: points per shared walk of the surface SDF (kernels/sdf.h). A CPU device
    // runs a work item's code as scalar code, so eight Morton neighbours sharing one walk share
    // its loads and branches (the cpu reference's packets); a GPU keeps one point per item.
    const std::string build = "-cl-std=CL1.2 " + std::string(fp32 ? "-DMCHEX_FP32 " : "") +
                              fmt::format("-DMCHEX_SDF_PACKET={} ", sdf_packet()) + options.build_options;
    const std::string source = source_text();
    const fs::path dir = options.cache_dir.empty() ? default_cache_dir() : fs::path(options.cache_dir);
    std::uint64_t key = fnv1a(source);
    for (const std::string& part :
         {build, info.platform, trim(platform.getInfo<CL_PLATFORM_VERSION>()), info.name, info.version})
      key = fnv1a(part + '\x1f', key);
    if (!dir.empty()) cache_path = (dir / fmt::format("opencl-{:016x}.bin", key)).string();

    if (!cache_path.empty()) {
      const std::string binary = read_file(cache_path);
      if (!binary.empty()) {
        try {
          cl::Program::Binaries bins{std::vector<unsigned char>(binary.begin(), binary.end())};
          program = cl::Program(context, {device}, bins);
          program.build({device}, build.c_str());
          from_cache = true;
          return;
        } catch (const cl::Error&) {
          // A stale or corrupt cache file: rebuild from source below and overwrite it.
        }
      }
    }
    program = cl::Program(context, source);
    try {
      program.build({device}, build.c_str());
    } catch (const cl::Error&) {
      throw std::runtime_error("OpenCL: building the kernels failed on " + info.name + ": " + build_log());
    }
    if (cache_path.empty()) return;
    // Saved through a temporary name and a rename, so a concurrent run never reads half a file.
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return;
    const auto binaries = program.getInfo<CL_PROGRAM_BINARIES>();
    if (binaries.empty() || binaries[0].empty()) return;
    const fs::path tmp = cache_path + fmt::format(".{}.tmp", ::getpid());
    {
      std::ofstream out(tmp, std::ios::binary);
      out.write(reinterpret_cast<const char*>(binaries[0].data()), std::streamsize(binaries[0].size()));
      if (!out) {
        fs::remove(tmp, ec);
        return;
      }
    }
    fs::rename(tmp, cache_path, ec);
    if (ec) fs::remove(tmp, ec);
  }

  // The command's device time into the profile; with a trace on, also an event of the timeline
  // (core/base/trace.h) from t0, taken before the enqueue, to its completion on the host clock:
  // the device's own clock has another origin, so its time goes into the event's args.
  void record(const std::string& name, const cl::Event& e, const char* category, trace::Clock::time_point t0,
              nlohmann::json args) {
    e.wait();
    const double s =
        double(e.getProfilingInfo<CL_PROFILING_COMMAND_END>() - e.getProfilingInfo<CL_PROFILING_COMMAND_START>()) *
        1e-9;
    auto& entry = profile.kernels[name];
    entry.calls++;
    entry.seconds += s;
    if (trace::enabled()) {
      args["backend"] = "opencl";
      args["device_us"] = s * 1e6;
      trace::record(name, category, t0, trace::Clock::now(), std::move(args));
    }
  }

  template <class T>
  void write(const cl::Buffer& b, const T* data, std::size_t count) {
    if (count == 0) return;
    cl::Event e;
    const auto t0 = trace::Clock::now();
    queue.enqueueWriteBuffer(b, CL_TRUE, 0, count * sizeof(T), data, nullptr, &e);
    record("write", e, trace::kUpload, t0, {{"bytes", count * sizeof(T)}});
  }
  template <class T>
  void read(const cl::Buffer& b, T* data, std::size_t count) {
    if (count == 0) return;
    cl::Event e;
    const auto t0 = trace::Clock::now();
    queue.enqueueReadBuffer(b, CL_TRUE, 0, count * sizeof(T), data, nullptr, &e);
    record("read", e, trace::kDownload, t0, {{"bytes", count * sizeof(T)}});
  }
  // A fixed work-group size, the global size rounded up to it (the kernels skip the surplus
  // items): PoCL compiles a work-group function per local size, so letting the driver pick one
  // per global size would recompile for every new batch size.
  void run(const char* name, cl::Kernel& k, std::size_t global, std::size_t local = 64) {
    cl::Event e;
    global = (global + local - 1) / local * local;
    const auto t0 = trace::Clock::now();
    queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(global), cl::NDRange(local), nullptr, &e);
    record(name, e, trace::kDispatch, t0, {{"work_items", global}, {"local_size", local}});
  }

  cl::Kernel& kernel(const std::string& name) {
    auto it = kernels.find(name);
    if (it == kernels.end()) it = kernels.emplace(name, cl::Kernel(program, name.c_str())).first;
    return it->second;
  }

  // A buffer over the caller's memory (zero_copy devices only: CL_DEVICE_HOST_UNIFIED_MEMORY).
  template <class T>
  cl::Buffer host_buffer(cl_mem_flags flags, const T* data, std::size_t count) {
    return cl::Buffer(context, flags | CL_MEM_USE_HOST_PTR, std::max<std::size_t>(1, count) * sizeof(T),
                      const_cast<T*>(data));
  }
  // Makes a host-pointer buffer's device writes visible in the host memory (OpenCL 1.2 section
  // 5.4.3: the host may read a CL_MEM_USE_HOST_PTR buffer's memory only while it is mapped).
  void sync_to_host(const cl::Buffer& b, std::size_t bytes) {
    if (bytes == 0) return;
    cl::Event e;
    const auto t0 = trace::Clock::now();
    void* p = queue.enqueueMapBuffer(b, CL_TRUE, CL_MAP_READ, 0, bytes, nullptr, &e);
    record("map", e, trace::kDownload, t0, {{"bytes", bytes}});
    queue.enqueueUnmapMemObject(b, p);
  }

  template <class T>
  cl::Buffer constant_buffer(const std::vector<T>& v) {
    if (v.size() * sizeof(T) > max_alloc())
      throw ResourceError(
          fmt::format("opencl backend: a {:.0f} MiB buffer exceeds {}'s largest allocation ({:.0f} MiB)",
                      v.size() * sizeof(T) / 1048576.0, info.name, max_alloc() / 1048576.0));
    // An empty vector still needs a valid buffer object; the copy is made by the buffer's creation.
    trace::Span span("constant_buffer", trace::kUpload);
    span.arg("backend", "opencl");
    span.arg("bytes", v.size() * sizeof(T));
    return cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, std::max<std::size_t>(1, v.size()) * sizeof(T),
                      const_cast<T*>(v.empty() ? reinterpret_cast<const T*>(&scene_scale) : v.data()));
  }

  void upload_scene32(const TriangleSurface& s) {
    if (scene32.host && scene32.host->is_of(s)) return;
    scene32 = Scene32{};
    scene32.host = std::make_unique<Fp32Surface>(s);
    const Fp32DeviceArrays d = scene32.host->take_device_arrays();
    scene32.buffers.push_back(constant_buffer(d.nodes));
    scene32.buffers.push_back(constant_buffer(d.node_slack));
    scene32.buffers.push_back(constant_buffer(d.slot_corners));
    scene32.buffers.push_back(constant_buffer(d.slot_slack));
    scene32.scale = d.scale;
  }

  // The fp32 path of signed_distance for a surface (kernels/sdf_fp32.h; the values from the
  // candidates: host/backends/fp32_path.h).
  void surface_sdf32(const TriangleSurface& s, std::span<const Vec3> points, std::span<double> values) {
    upload_scene32(s);
    const std::size_t n = std::min(chunk(kFp32RecordWords * sizeof(std::uint32_t)), points.size());
    cl::Buffer in(context, CL_MEM_READ_ONLY, 3 * sizeof(float) * n);
    cl::Buffer out(context, CL_MEM_WRITE_ONLY, kFp32RecordWords * sizeof(std::uint32_t) * n);
    std::vector<float> p32(3 * n);
    std::vector<std::uint32_t> cand(kFp32RecordWords * n);
    const cl_uint per_item = info.type == "gpu" ? 1 : 16;
    cl::Kernel& k = kernel("sdf_surface32");
    for (std::size_t first = 0; first < points.size(); first += n) {
      const std::size_t count = std::min(n, points.size() - first);
      parallel_for(count, [&](std::size_t i) {
        for (int c = 0; c < 3; ++c) p32[3 * i + c] = float(points[first + i][c]);
      });
      write(in, p32.data(), 3 * count);
      cl_uint arg = 0;
      for (const cl::Buffer& b : scene32.buffers) k.setArg(arg++, b);
      k.setArg(arg++, in);
      k.setArg(arg++, out);
      k.setArg(arg++, cl_uint(count));
      k.setArg(arg++, per_item);
      k.setArg(arg++, scene32.scale);
      run("sdf_surface32", k, (count + per_item - 1) / per_item, 8);
      read(out, cand.data(), kFp32RecordWords * count);
      scene32.host->values_from_records(points, {}, first, std::span(cand).first(kFp32RecordWords * count), values,
                                        fp32_stats);
    }
  }

  void upload_scene(const TriangleSurface& s) {
    const SurfaceKey key = key_of(&s);
    if (key == scene_key && !scene.empty()) return;
    const DeviceScene d = DeviceScene::build(s);
    scene.clear();
    scene.push_back(constant_buffer(d.wide_boxes));
    scene.push_back(constant_buffer(d.wide_links));
    scene.push_back(constant_buffer(d.leaf_bounds));
    scene.push_back(constant_buffer(d.leaf_slot));
    scene.push_back(constant_buffer(d.slot_triangle));
    scene.push_back(constant_buffer(d.slot_corners));
    scene.push_back(constant_buffer(d.slot_features));
    scene.push_back(constant_buffer(d.face_normals));
    scene.push_back(constant_buffer(d.edge_normals));
    scene.push_back(constant_buffer(d.vertex_normals));
    scene_scale = d.scale;
    scene_key = key;
  }
};

OpenclBackend::OpenclBackend(const OpenclOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.options = options;
  try {
    m.pick_device();
    m.context = cl::Context(m.device);
    m.queue = cl::CommandQueue(m.context, m.device, CL_QUEUE_PROFILING_ENABLE);
    m.build_program();
    m.configs = m.constant_buffer(packed_mc33_configs());
  } catch (const cl::Error& e) {
    fail(e, "setting up the device");
  }
}

OpenclBackend::~OpenclBackend() = default;

const DeviceInfo& OpenclBackend::device() const { return impl_->info; }
bool OpenclBackend::program_from_cache() const { return impl_->from_cache; }
const std::string& OpenclBackend::cache_file() const { return impl_->cache_path; }
const OpenclProfile& OpenclBackend::profile() const { return impl_->profile; }
const Fp32Stats& OpenclBackend::fp32_stats() const { return impl_->fp32_stats; }
void OpenclBackend::reset_profile() {
  impl_->profile = {};
  impl_->fp32_stats = {};
}

bool OpenclBackend::fp32_path() const { return impl_->fp32; }
void OpenclBackend::forget_resident_values() { impl_->resident_data = nullptr; }

void OpenclBackend::device_surface_sdf32(const TriangleSurface& surface, std::span<const Vec3> points,
                                         std::span<double> values) {
  try {
    impl_->surface_sdf32(surface, points, values);
  } catch (const cl::Error& e) {
    fail(e, "signed distance");
  }
}

void OpenclBackend::device_surface_sdf(const TriangleSurface& surface, const MortonBatch& points,
                                       std::span<double> values) {
  Impl& m = *impl_;
  try {
    m.upload_scene(surface);
    // The values come back in search order and are scattered; they are not left resident (the
    // device copy is permuted).
    const std::size_t total = points.size();
    const std::size_t n = m.chunk(3 * sizeof(double));
    std::vector<double> staged(3 * std::min(n, total)), chunk_values(std::min(n, total));
    cl::Buffer in(m.context, CL_MEM_READ_ONLY, 3 * sizeof(double) * std::min(n, total));
    cl::Buffer out(m.context, CL_MEM_WRITE_ONLY, sizeof(double) * std::min(n, total));
    const cl_uint per_item = m.sdf_points_per_item();
    cl::Kernel& k = m.kernel("sdf_surface");
    for (std::size_t first = 0; first < total; first += n) {
      const std::size_t count = std::min(n, total - first);
      points.gather(first, count, staged.data());
      m.write(in, staged.data(), 3 * count);
      cl_uint arg = 0;
      for (const cl::Buffer& b : m.scene) k.setArg(arg++, b);
      k.setArg(arg++, in);
      k.setArg(arg++, out);
      k.setArg(arg++, cl_uint(count));
      k.setArg(arg++, per_item);
      k.setArg(arg++, m.scene_scale);
      m.run("sdf_surface", k, (count + per_item - 1) / per_item, 8);
      m.read(out, chunk_values.data(), count);
      points.scatter(first, std::span(chunk_values).first(count), values);
    }
  } catch (const cl::Error& e) {
    fail(e, "signed distance");
  }
}

void OpenclBackend::device_shape_sdf(ShapeKind shape, std::span<const Vec3> points, std::span<double> values) {
  Impl& m = *impl_;
  try {
    const std::size_t n = m.chunk(3 * sizeof(double));
    cl::Buffer in(m.context, CL_MEM_READ_ONLY, 3 * sizeof(double) * std::min(n, points.size()));
    cl::Buffer out(m.context, CL_MEM_WRITE_ONLY, sizeof(double) * std::min(n, points.size()));
    cl::Kernel& k = m.kernel("sdf_shape");
    for (std::size_t first = 0; first < points.size(); first += n) {
      const std::size_t count = std::min(n, points.size() - first);
      m.write(in, &points[first].x, 3 * count);
      k.setArg(0, cl_int(shape));
      k.setArg(1, in);
      k.setArg(2, out);
      k.setArg(3, cl_uint(count));
      m.run("sdf_shape", k, count);
      m.read(out, &values[first], count);
    }
    if (points.size() <= n && !m.host_unified) {
      m.resident = out;
      m.resident_data = values.data();
      m.resident_size = values.size();
    }
  } catch (const cl::Error& e) {
    fail(e, "signed distance");
  }
}

void OpenclBackend::device_refinement_error(std::span<const std::array<double, kChildLatticePoints>> lattice,
                                            std::span<const double> sizes, std::span<double> errors) {
  Impl& m = *impl_;
  try {
    const std::size_t n = std::min(m.chunk(sizeof(lattice[0])), lattice.size());
    cl::Buffer in(m.context, CL_MEM_READ_ONLY, sizeof(lattice[0]) * n);
    cl::Buffer sz(m.context, CL_MEM_READ_ONLY, sizeof(double) * n);
    cl::Buffer out(m.context, CL_MEM_WRITE_ONLY, sizeof(double) * n);
    cl::Kernel& k = m.kernel("refinement_error");
    for (std::size_t first = 0; first < lattice.size(); first += n) {
      const std::size_t count = std::min(n, lattice.size() - first);
      m.write(in, lattice[first].data(), kChildLatticePoints * count);
      m.write(sz, &sizes[first], count);
      k.setArg(0, in);
      k.setArg(1, sz);
      k.setArg(2, out);
      k.setArg(3, cl_uint(count));
      m.run("refinement_error", k, count);
      m.read(out, &errors[first], count);
    }
  } catch (const cl::Error& e) {
    fail(e, "refinement error");
  }
}

void OpenclBackend::device_classify_cells(const HexComplex& complex, std::span<const double> values,
                                          const CellClassification& out, const ClassifyOptions& options) {
  const std::size_t cells = complex.cells.size();
  Impl& m = *impl_;
  constexpr cl_uint kBlock = 256;  // cells per work item of the prefix sum
  const bool uniform = options.uniform_cells_per_axis > 0;
  const bool want_words = !out.words.empty();
  const bool want_crossings = !out.crossings.empty();
  try {
    // Per cell: 1 subcase byte, 8 offset bytes, 8 word bytes when asked for, 32 corner bytes
    // unless uniform; the chunk is limited by the largest of these buffers.
    const std::size_t n = std::min(m.chunk(want_crossings ? 12 * sizeof(double)
                                           : uniform      ? sizeof(cl_ulong)
                                                          : 8 * sizeof(std::uint32_t)),
                                   cells);
    const std::size_t max_blocks = (n + kBlock - 1) / kBlock;
    // The value window is limited by the allocation size only (max_chunk counts cells).
    const std::size_t window_limit = std::min<std::size_t>(m.max_alloc() / sizeof(double), std::size_t(1) << 31);
    // A device that shares the host's memory (PoCL on CPUs) reads the caller's arrays and writes
    // the results in place (CL_MEM_USE_HOST_PTR, synchronised by map/unmap): no copies. Others
    // get device buffers, and the values stay there when signed_distance left them (resident).
    const bool zero_copy = m.host_unified;
    const bool whole = values.size() <= window_limit;  // every chunk reads the one value buffer
    cl::Buffer cell_buf, subcase_buf, word_buf, crossing_buf, offset_buf;
    const cl::Buffer dummy(m.context, CL_MEM_READ_WRITE, 16);
    const cl::Buffer bad(m.context, CL_MEM_READ_WRITE, sizeof(cl_uint));
    const cl_uint zero = 0;
    m.queue.enqueueFillBuffer(bad, zero, 0, sizeof zero);
    if (!zero_copy) {
      if (!uniform) cell_buf = cl::Buffer(m.context, CL_MEM_READ_ONLY, 8 * sizeof(std::uint32_t) * n);
      subcase_buf = cl::Buffer(m.context, CL_MEM_READ_WRITE, n);
      if (want_words) word_buf = cl::Buffer(m.context, CL_MEM_WRITE_ONLY, 2 * sizeof(std::uint32_t) * n);
      if (want_crossings) crossing_buf = cl::Buffer(m.context, CL_MEM_WRITE_ONLY, 12 * sizeof(double) * n);
      offset_buf = cl::Buffer(m.context, CL_MEM_WRITE_ONLY, sizeof(cl_ulong) * n);
    }
    cl::Buffer sums(m.context, CL_MEM_READ_WRITE, sizeof(cl_ulong) * (max_blocks + 1));
    cl::Buffer value_buf;
    std::size_t value_capacity = 0;
    if (whole) {
      if (zero_copy) value_buf = m.host_buffer(CL_MEM_READ_ONLY, values.data(), values.size());
      else if (options.values_from_last_sdf && m.resident_matches(values)) value_buf = m.resident;
      else {
        value_buf = cl::Buffer(m.context, CL_MEM_READ_ONLY, sizeof(double) * values.size());
        m.write(value_buf, values.data(), values.size());
      }
    }
    cl::Kernel &classify = m.kernel(want_crossings ? "classify_crossings" : "classify"),
               &block_sums = m.kernel("hex_block_sums"), &scan = m.kernel("hex_scan_sums"),
               &block_offsets = m.kernel("hex_block_offsets");
    static_assert(sizeof(cl_ulong) == sizeof(std::uint64_t) && sizeof(CellCorners) == 8 * sizeof(std::uint32_t));
    std::uint64_t total = 0;
    for (std::size_t first = 0; first < cells;) {
      std::size_t count = std::min(n, cells - first);
      std::uint32_t lo = 0;
      if (!whole) {
        // The chunk's cells read the points [lo, hi]; shrink the chunk until that window fits.
        std::uint32_t hi;
        for (;;) {
          lo = UINT32_MAX, hi = 0;
          for (std::size_t i = first; i < first + count; ++i)
            for (std::uint32_t p : complex.cells[i]) lo = std::min(lo, p), hi = std::max(hi, p);
          if (hi >= values.size()) throw std::invalid_argument("classify_cells: a cell refers to a missing point");
          if (std::size_t(hi - lo) + 1 <= window_limit || count == 1) break;
          count = (count + 1) / 2;
        }
        const std::size_t window = std::size_t(hi - lo) + 1;
        if (zero_copy) {
          value_buf = m.host_buffer(CL_MEM_READ_ONLY, &values[lo], window);
        } else {
          if (window > value_capacity) {
            value_buf = cl::Buffer(m.context, CL_MEM_READ_ONLY, sizeof(double) * window);
            value_capacity = window;
          }
          m.write(value_buf, &values[lo], window);
        }
      }
      if (zero_copy) {
        if (!uniform) cell_buf = m.host_buffer(CL_MEM_READ_ONLY, complex.cells[first].data(), 8 * count);
        subcase_buf = m.host_buffer(CL_MEM_READ_WRITE, &out.subcases[first], count);
        if (want_words) word_buf = m.host_buffer(CL_MEM_WRITE_ONLY, &out.words[2 * first], 2 * count);
        if (want_crossings) crossing_buf = m.host_buffer(CL_MEM_WRITE_ONLY, &out.crossings[12 * first], 12 * count);
        offset_buf = m.host_buffer(CL_MEM_WRITE_ONLY, reinterpret_cast<cl_ulong*>(&out.offsets[first]), count);
      } else if (!uniform) {
        m.write(cell_buf, complex.cells[first].data(), 8 * count);
      }
      cl_uint arg = 0;
      classify.setArg(arg++, m.configs);
      classify.setArg(arg++, uniform ? dummy : cell_buf);
      classify.setArg(arg++, value_buf);
      classify.setArg(arg++, cl_uint(lo));
      classify.setArg(arg++, cl_uint(first));
      classify.setArg(arg++, cl_uint(options.uniform_cells_per_axis));
      classify.setArg(arg++, options.zero_tolerance);
      classify.setArg(arg++, subcase_buf);
      classify.setArg(arg++, want_words ? word_buf : dummy);
      classify.setArg(arg++, cl_uint(want_words));
      if (want_crossings) classify.setArg(arg++, crossing_buf);
      classify.setArg(arg++, bad);
      classify.setArg(arg++, cl_uint(count));
      const cl_uint cells_per_item = m.classify_cells_per_item();
      classify.setArg(arg++, cells_per_item);
      m.run(want_crossings ? "classify_crossings" : "classify", classify,
            (count + cells_per_item - 1) / cells_per_item);

      const cl_uint blocks = cl_uint((count + kBlock - 1) / kBlock);
      block_sums.setArg(0, subcase_buf);
      block_sums.setArg(1, cl_uint(count));
      block_sums.setArg(2, kBlock);
      block_sums.setArg(3, sums);
      m.run("hex_block_sums", block_sums, blocks, 8);
      scan.setArg(0, sums);
      scan.setArg(1, blocks);
      scan.setArg(2, cl_ulong(total));
      m.run("hex_scan_sums", scan, 1, 1);
      block_offsets.setArg(0, subcase_buf);
      block_offsets.setArg(1, cl_uint(count));
      block_offsets.setArg(2, kBlock);
      block_offsets.setArg(3, sums);
      block_offsets.setArg(4, offset_buf);
      m.run("hex_block_offsets", block_offsets, blocks, 8);

      if (zero_copy) {
        // The results are already in the caller's arrays; mapping makes them visible to the host.
        m.sync_to_host(subcase_buf, count);
        if (want_words) m.sync_to_host(word_buf, 2 * count * sizeof(std::uint32_t));
        if (want_crossings) m.sync_to_host(crossing_buf, 12 * count * sizeof(double));
        m.sync_to_host(offset_buf, count * sizeof(cl_ulong));
      } else {
        m.read(subcase_buf, &out.subcases[first], count);
        if (want_words) m.read(word_buf, &out.words[2 * first], 2 * count);
        if (want_crossings) m.read(crossing_buf, &out.crossings[12 * first], 12 * count);
        m.read(offset_buf, reinterpret_cast<cl_ulong*>(&out.offsets[first]), count);
      }
      cl_ulong chunk_total = 0;
      cl::Event e;
      const auto t0 = trace::Clock::now();
      m.queue.enqueueReadBuffer(sums, CL_TRUE, sizeof(cl_ulong) * blocks, sizeof(cl_ulong), &chunk_total, nullptr, &e);
      m.record("read", e, trace::kDownload, t0, {{"bytes", sizeof(cl_ulong)}});
      total = chunk_total;
      first += count;
    }
    cl_uint bad_value = 0;
    m.queue.enqueueReadBuffer(bad, CL_TRUE, 0, sizeof bad_value, &bad_value);
    m.queue.finish();  // the unmaps, before the host buffers are released
    // core's classify() refuses non-finite values; the kernel flagged them.
    if (bad_value) throw InputError("MC33 classify: a corner value is not finite");
    out.offsets[cells] = total;
  } catch (const cl::Error& e) {
    fail(e, "MC33 classification");
  }
}

std::vector<DeviceInfo> list_opencl_devices() {
  std::vector<DeviceInfo> out;
  try {
    for (const cl::Platform& p : platforms())
      for (const cl::Device& d : devices_of(p)) {
        out.push_back(describe(p, d));
        out.back().precision = out.back().fp64 && !fp32_forced_by_environment() ? "fp64" : "fp32";
      }
  } catch (const cl::Error& e) {
    fail(e, "listing devices");
  }
  return out;
}

}  // namespace mchex
