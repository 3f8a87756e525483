// _mchex: the Python extension under the mchex package (host/python/mchex/__init__.py is its
// front; docs/python.md the API). It is a second front end over the CLI's own code, not a second
// copy of it: keyword arguments become the CLI's option words, parsed by the same CLI11 options
// (host/cli/options.h), so a value is accepted, defaulted and refused exactly as on the command
// line; the run is core/pipeline/pipeline.h run_pipeline, the report core/pipeline/report.h
// report_json, the check and devices JSON host/cli/commands.h's. So mchex.mesh gives the CLI's
// meshes and report for the same options (tests/test_python.py).
//
// Guarantees: the GIL is released while the pipeline, the check or the certificate run (the
// arrays are copied in before and out after); every error is a Python exception whose message is
// the CLI's one line: InputError (a ValueError) for bad input, ResourceError for the memory
// refusal, MemoryError for an allocation failure, RuntimeError for any other failure.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/certify.h"
#include "core/grid/cell_types.h"
#include "core/io/mesh_io.h"
#include "core/mesh/surface.h"
#include "core/pipeline/report.h"
#include "host/backends/registry.h"
#include "host/cli/commands.h"
#include "host/cli/options.h"
#include "host/cli/summary.h"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace mchex::python {
namespace {

using Points = py::array_t<double, py::array::c_style | py::array::forcecast>;

// The option words of `kwargs` for `app`: key k is the option --k with '_' read as '-'; True for a
// flag gives the flag, False the flag's --no- form where there is one (fidelity=False:
// --no-fidelity; repair=False: --no-repair); None leaves the option out. `reserved` are the
// options the Python call takes as its own parameters, so not as keywords.
std::vector<std::string> option_words(const CLI::App& app, const py::dict& kwargs,
                                      const std::vector<std::string>& reserved, const std::string& function) {
  auto usable = [&](const std::string& name) -> const CLI::Option* {
    if (std::find(reserved.begin(), reserved.end(), name) != reserved.end()) return nullptr;
    return app.get_option_no_throw(name);
  };
  auto is_flag = [](const CLI::Option* o) { return o->get_expected_max() == 0; };
  std::vector<std::string> words;
  for (const auto& [k, v] : kwargs) {
    const std::string key = py::str(k);
    std::string word = key;
    std::replace(word.begin(), word.end(), '_', '-');
    const CLI::Option* option = usable("--" + word);
    const CLI::Option* negated = usable("--no-" + word);
    if (negated && !is_flag(negated)) negated = nullptr;
    if (!option && !negated) {
      std::vector<std::string> names;
      for (const CLI::Option* o : app.get_options()) {
        const std::string& n = o->get_single_name();
        if (o->get_lnames().empty() || std::find(reserved.begin(), reserved.end(), "--" + n) != reserved.end())
          continue;
        std::string name = n.rfind("no-", 0) == 0 ? n.substr(3) : n;
        std::replace(name.begin(), name.end(), '-', '_');
        if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
      }
      throw InputError(fmt::format("{}: unknown option {} (the options: {})", function, key, fmt::join(names, ", ")));
    }
    if (v.is_none()) continue;
    if (py::isinstance<py::bool_>(v)) {
      const bool on = v.cast<bool>();
      if (option && is_flag(option)) {
        if (on) words.push_back("--" + word);
        else if (negated) words.push_back("--no-" + word);
      } else if (!option) {
        if (!on) words.push_back("--no-" + word);
      } else {
        throw InputError(fmt::format("--{}: expected a value, got {}", word, on ? "True" : "False"));
      }
      continue;
    }
    if (!option || is_flag(option))
      throw InputError(fmt::format("--{}: a flag, give True or False", option ? word : "no-" + word));
    words.push_back("--" + word);
    words.push_back(py::str(v));
  }
  return words;
}

// CLI11 parses its words last first; its errors are the CLI's lines less "(see --help)".
void parse(CLI::App& app, std::vector<std::string> words) {
  std::reverse(words.begin(), words.end());
  try {
    app.parse(words);
  } catch (const CLI::ParseError& e) {
    throw InputError(e.what());
  }
}

// (points, hexes, region) as numpy arrays: float64 N x 3, int64 M x 8 (VTK_HEXAHEDRON order,
// core/mesh/hex_mesh.h), int32 M.
py::tuple to_arrays(const HexMesh& mesh) {
  py::array_t<double> points({static_cast<py::ssize_t>(mesh.points.size()), py::ssize_t{3}});
  auto p = points.mutable_unchecked<2>();
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    for (int a = 0; a < 3; ++a) p(i, a) = mesh.points[i][a];
  py::array_t<std::int64_t> hexes({static_cast<py::ssize_t>(mesh.hexes.size()), py::ssize_t{8}});
  auto h = hexes.mutable_unchecked<2>();
  for (std::size_t i = 0; i < mesh.hexes.size(); ++i)
    for (int c = 0; c < 8; ++c) h(i, c) = mesh.hexes[i][c];
  py::array_t<std::int32_t> region(static_cast<py::ssize_t>(mesh.region.size()));
  std::copy(mesh.region.begin(), mesh.region.end(), region.mutable_data());
  return py::make_tuple(points, hexes, region);
}

// What an argument that is not the array asked for is, for the one-line error.
std::string describe(const py::handle& object) {
  const py::array any = py::array::ensure(object);
  if (!any) return std::string(py::str(py::type::of(object).attr("__name__")));
  std::vector<py::ssize_t> shape(any.shape(), any.shape() + any.ndim());
  return fmt::format("shape ({}) of {}", fmt::join(shape, ", "), std::string(py::str(any.dtype())));
}

// Whether the array's element kind is one of `kinds` (numpy's kind letters).
bool numeric(const py::array& a, std::string_view kinds) {
  return kinds.find(a.dtype().kind()) != std::string_view::npos;
}

// An N x 3 float array's rows as points; what names it in the one-line errors.
std::vector<Vec3> read_points(const py::handle& object, const std::string& what) {
  const py::array any = py::array::ensure(object);
  if (!any || any.ndim() != 2 || any.shape(1) != 3 || !numeric(any, "fiu"))
    throw InputError(fmt::format("{}: expected an N x 3 array of floats, got {}", what, describe(object)));
  const Points a = Points::ensure(any);
  auto r = a.unchecked<2>();
  std::vector<Vec3> points(static_cast<std::size_t>(a.shape(0)));
  for (std::size_t i = 0; i < points.size(); ++i) {
    points[i] = {r(i, 0), r(i, 1), r(i, 2)};
    if (!std::isfinite(r(i, 0)) || !std::isfinite(r(i, 1)) || !std::isfinite(r(i, 2)))
      throw InputError(fmt::format("{}: row {} is not finite", what, i));
  }
  return points;
}

// An M x K integer array's rows, every entry naming one of `n` points.
template <std::size_t K>
std::vector<std::array<std::uint32_t, K>> read_indices(const py::handle& object, std::size_t n,
                                                       const std::string& what) {
  const py::array any = py::array::ensure(object);
  if (!any || any.ndim() != 2 || any.shape(1) != static_cast<py::ssize_t>(K) || !numeric(any, "iu"))
    throw InputError(fmt::format("{}: expected an M x {} array of integers, got {}", what, K, describe(object)));
  const auto a = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(any);
  auto r = a.unchecked<2>();
  std::vector<std::array<std::uint32_t, K>> rows(static_cast<std::size_t>(a.shape(0)));
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t c = 0; c < K; ++c) {
      const std::int64_t v = r(i, c);
      if (v < 0 || static_cast<std::uint64_t>(v) >= n)
        throw InputError(fmt::format("{}: row {} names point {}, which is not one of the {} points", what, i, v, n));
      rows[i][c] = static_cast<std::uint32_t>(v);
    }
  return rows;
}

// A hex mesh from (points, hexes[, region]); region defaults to `region` for every hex.
HexMesh to_mesh(const py::tuple& arrays, const std::string& what, std::int32_t default_region) {
  if (arrays.size() < 2 || arrays.size() > 3)
    throw InputError(what + ": expected (points, hexes) or (points, hexes, region)");
  HexMesh mesh;
  mesh.points = read_points(arrays[0], what + " points");
  mesh.hexes = read_indices<8>(arrays[1], mesh.points.size(), what + " hexes");
  if (arrays.size() == 3 && !arrays[2].is_none()) {
    const auto region = py::array_t<std::int32_t, py::array::forcecast>::ensure(arrays[2]);
    if (!region || region.ndim() != 1 || static_cast<std::size_t>(region.shape(0)) != mesh.hexes.size())
      throw InputError(fmt::format("{} region: expected one integer per hex ({})", what, mesh.hexes.size()));
    mesh.region.assign(region.data(), region.data() + region.shape(0));
  } else {
    mesh.region.assign(mesh.hexes.size(), default_region);
  }
  return mesh;
}

// `sources`: one surface (a path, or a (vertices, triangles) pair), or several: the regions of one
// mesh, as several INPUT files are on the command line.
py::dict mesh(const py::list& sources, const std::string& shape, const std::string& name, const py::dict& kwargs,
              int threads, bool quiet) {
  CLI::App app{"mchex.mesh"};
  app.set_help_flag();
  cli::MeshCli options(app);
  // Inputs, outputs and the trace are mchex.mesh's own parameters or Result.write's.
  parse(app, option_words(app, kwargs,
                          {"--shape", "--output", "--outside", "--binary", "--report", "--trace", "--region-files"},
                          "mesh"));
  options.finish();
  cli::MeshCommand& command = options.command;
  command.shape = shape;
  // Arrays become surfaces of their own (a deque: the request points at them), named `name`, or
  // "NAME I" for the I-th of several sources; files go by their paths.
  std::deque<TriangleSurface> surfaces;
  std::vector<const TriangleSurface*> arrays(sources.size(), nullptr);
  for (std::size_t i = 0; i < sources.size(); ++i) {
    const py::handle source = sources[i];
    if (py::isinstance<py::str>(source)) {
      command.inputs.push_back(source.cast<std::string>());
      continue;
    }
    const py::tuple pair = source.cast<py::tuple>();
    TriangleSurface& surface = surfaces.emplace_back();
    surface.vertices = read_points(pair[0], "vertices");
    surface.triangles = read_indices<3>(pair[1], surface.vertices.size(), "triangles");
    if (surface.triangles.empty()) throw InputError("triangles: the surface has no triangles");
    // As a file's are: a triangle soup's repeated corners become shared vertices.
    weld_vertices(surface);
    arrays[i] = &surface;
    command.inputs.push_back(sources.size() == 1 ? name : fmt::format("{} {}", name, i + 1));
  }
  if (!surfaces.empty() && !command.shape.empty()) throw InputError("give either a surface or a shape, not both");
  MeshRequest request = cli::mesh_request(command, quiet);
  // The request names array sources as files; it meshes the arrays themselves.
  for (std::size_t i = 0; i < arrays.size(); ++i) {
    if (!arrays[i]) continue;
    const SolidSource source = SolidSource::in_memory(*arrays[i], command.inputs[i]);
    if (arrays.size() == 1) request.solid = source;
    else request.regions[i] = source;
  }
  std::optional<MeshRun> run;
  {
    py::gil_scoped_release release;
    std::optional<ThreadLimit> limit;
    if (threads > 0) limit.emplace(threads);
    run.emplace(run_pipeline(request));
  }
  py::dict out;
  out["inside"] = to_arrays(run->meshes.inside);
  out["outside"] = to_arrays(run->meshes.outside);
  out["report"] = report_json(*run).dump();
  out["ok"] = run->check.ok;
  out["error"] = run->check.ok ? std::string() : cli::first_error(run->check);
  return out;
}

// `inside` and `outside`: a path, or (points, hexes[, region]).
HexMesh load(const py::object& source, const std::string& what, std::int32_t region, std::string& name) {
  if (py::isinstance<py::str>(source)) {
    name = source.cast<std::string>();
    py::gil_scoped_release release;
    return read_hex_mesh(name);
  }
  name = what;
  return to_mesh(source.cast<py::tuple>(), what, region);
}

std::string check(const py::object& inside, const py::object& outside, const std::string& input, const py::dict& kwargs,
                  bool quiet) {
  CLI::App app{"mchex.check"};
  app.set_help_flag();
  cli::CheckCommand command;
  cli::add_check_options(app, command);
  std::vector<std::string> words = option_words(app, kwargs, {"--outside", "--input", "--json"}, "check");
  words.push_back("--");
  words.push_back("inside");
  parse(app, words);
  command.input = input;
  const HexMesh in = load(inside, "inside", kInside, command.mesh);
  std::optional<HexMesh> out;
  if (!outside.is_none()) out = load(outside, "outside", kOutside, command.outside);
  py::gil_scoped_release release;
  return cli::check_meshes(in, out ? &*out : nullptr, command, quiet).json.dump();
}

void write_meshes(const py::tuple& inside, const py::object& outside, const std::string& inside_path,
                  const std::string& outside_path, bool binary) {
  const HexMesh in = to_mesh(inside, "inside", kInside);
  std::optional<HexMesh> out;
  if (!outside.is_none()) out = to_mesh(outside.cast<py::tuple>(), "outside", kOutside);
  const bool both = out.has_value();
  // As the CLI: every name is checked before anything is written.
  for (const fs::path& p :
       both ? std::vector<fs::path>{inside_path, outside_path} : std::vector<fs::path>{inside_path}) {
    mesh_format(p);
    if (!p.parent_path().empty() && !fs::is_directory(p.parent_path()))
      throw InputError(p.string() + ": the folder " + p.parent_path().string() + " does not exist");
  }
  if (both && fs::weakly_canonical(inside_path) == fs::weakly_canonical(outside_path))
    throw InputError("the inside and outside meshes need different file names");
  py::gil_scoped_release release;
  const MeshWriteOptions options{binary};
  write_hex_mesh(in, inside_path, options);
  if (both) write_hex_mesh(*out, outside_path, options);
}

// The certificate's summary per cell type, as `mchex-gpu certify` prints it (certify_report).
py::dict certify_summary(double eps, std::vector<std::string> type_names) {
  CertifyOptions options;
  options.eps = eps;
  options.types = std::move(type_names);
  std::optional<CertifyResult> r;
  {
    py::gil_scoped_release release;
    r.emplace(certify(options));
  }
  const auto types = cell_types();
  py::list per_type;
  for (std::size_t t = 0; t < types.size(); ++t) {
    if (!r->selected[t]) continue;
    std::size_t hexes = 0, moved = 0, checked = 0;
    py::list proven, left;
    double least = std::numeric_limits<double>::infinity();
    for (int s = 0; s < kNumSubcases; ++s) {
      const CertifyEntry& e = r->table[t][s];
      if (!e.checked) continue;
      ++checked;
      hexes += e.hexes;
      moved += e.moved_centres;
      const std::string name(subcase_name(static_cast<Subcase>(s)));
      if (r->proven(static_cast<int>(t), s)) {
        proven.append(name);
        least = std::min(least, e.min_coefficient);
      } else {
        left.append(name);
      }
    }
    py::dict d;
    d["type"] = types[t].name;
    d["hexes"] = hexes;
    d["checked_subcases"] = checked;
    d["proven_subcases"] = proven;
    d["left_to_remedy"] = left;
    d["min_coefficient"] = std::isfinite(least) ? py::object(py::float_(least)) : py::object(py::none());
    d["moved_centres"] = moved;
    per_type.append(d);
  }
  py::dict out;
  out["passed"] = r->passed();
  out["eps"] = r->options.eps;
  out["hexes"] = r->hexes;
  out["not_landed_subcases"] = r->not_landed_subcases;
  out["run_time_pairs"] = r->run_time_pairs();
  out["seconds"] = r->seconds;
  out["types"] = per_type;
  if (r->first_failure) {
    const CertifyFailure& f = *r->first_failure;
    py::dict d;
    d["type"] = types[f.type].name;
    d["rotation"] = f.rotation;
    d["subcase"] = std::string(subcase_name(f.subcase));
    d["coefficient"] = f.coefficient;
    out["first_failure"] = d;
  } else {
    out["first_failure"] = py::none();
  }
  out["text"] = certify_report(*r);
  return out;
}

}  // namespace
}  // namespace mchex::python

PYBIND11_MODULE(_mchex, m) {
  using namespace mchex::python;
  m.doc() = "mchex-gpu's pipeline (the extension under the mchex package; use mchex, docs/python.md)";
  py::register_exception<mchex::InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<mchex::ResourceError>(m, "ResourceError", PyExc_RuntimeError);
  m.def("mesh", &mesh, py::arg("sources"), py::arg("shape"), py::arg("name"), py::arg("options"), py::arg("threads"),
        py::arg("quiet"));
  m.def("check", &check, py::arg("inside"), py::arg("outside"), py::arg("input"), py::arg("options"), py::arg("quiet"));
  m.def("write", &write_meshes, py::arg("inside"), py::arg("outside"), py::arg("inside_path"), py::arg("outside_path"),
        py::arg("binary"));
  m.def("certify", &certify_summary, py::arg("eps"), py::arg("types"));
  m.def("devices", [] {
    std::string text;
    {
      py::gil_scoped_release release;
      text = mchex::cli::devices_json(mchex::list_devices()).dump();
    }
    return text;
  });
  m.def("backends", &mchex::built_backend_names);
}
