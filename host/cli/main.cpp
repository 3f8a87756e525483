// mchex-gpu: the command line. Subcommands:
//   mesh     surface or analytic shape -> inside and outside all-hex meshes (+ JSON report)
//   check    validate hex meshes: structure, quality (Bernstein certificate), conformity, fidelity
//   certify  re-check the positivity proof (core/cutting/certify.h)
//   optimize move vertices to raise the scaled Jacobian, every hex still certified
//   convert  a hex mesh from one file format to another
//   devices  the compute backends and devices found (core/device/backend.h)
// This file parses the command line and maps errors to exit codes; each subcommand is in its own
// file (host/cli/commands.h). Every failure is one line on stderr and a non-zero exit: 1 bad input
// or usage, 2 resource limit, 3 an internal failure (a mesh that fails its own check, a failed
// certificate). SIGINT and SIGTERM leave no file behind (core/io/atomic_file.h): `mesh` writes
// all of its outputs or none.
#include <cstdio>
#include <map>
#include <new>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/certify.h"
#include "core/io/atomic_file.h"
#include "core/io/mesh_io.h"
#include "host/cli/commands.h"
#include "host/cli/huge_pages.h"
#include "host/cli/options.h"

using namespace mchex;
using namespace mchex::cli;

int main(int argc, char** argv) {
  restart_with_heap_tunables(argv);
  install_signal_cleanup();
  CLI::App app{"mchex-gpu: all-hex meshes of a solid and of the box around it (MCHex, Tong & Zhang 2025)"};
  app.require_subcommand(1);
  app.fallthrough();  // --quiet and --threads also after the subcommand name
  bool quiet = false;
  int threads = 0;
  app.add_flag("--quiet,-q", quiet, "no summary and no progress lines");
  app.add_option("--threads", threads, "worker threads (default: all cores)")->check(CLI::Range(1, 1024));

  auto* mesh = app.add_subcommand("mesh", "mesh a surface (STL, OBJ, OFF, PLY) or a built-in shape");
  MeshCli mesh_cli(*mesh);
  const std::map<std::string, SignRule>& sign_rules = cli::sign_rules();
  OptimizeCommand oo;
  auto* optimize_cmd = app.add_subcommand(
      "optimize", "move the vertices of a hex mesh (and its outside mesh) to raise the scaled Jacobian, keeping "
                  "boundary vertices on the input surface and every hex Bernstein-certified");
  optimize_cmd->add_option("mesh", oo.mesh, "inside hex mesh (.mesh, .vtu or .msh)")->required();
  optimize_cmd->add_option("--outside", oo.outside, "its outside mesh: the interface moves in both");
  optimize_cmd->add_option("--input", oo.input, "the input surface the boundary stays on");
  optimize_cmd->add_option("--shape", oo.shape, "the built-in shape the mesh was made from, as --input");
  optimize_cmd->add_option("-o,--output", oo.output, "optimised inside mesh")->required();
  optimize_cmd->add_option("--outside-output", oo.outside_output,
                           "optimised outside mesh (default: outside.EXT beside the output)");
  optimize_cmd->add_option("--sweeps", oo.options.max_sweeps, "as mesh --optimize-sweeps")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  optimize_cmd->add_option("--ratio-sweeps", oo.options.ratio_sweeps, "as mesh --optimize-ratio-sweeps")
      ->check(CLI::Range(0, 10000))
      ->capture_default_str();
  optimize_cmd->add_option("--max-edge-ratio", oo.options.max_edge_ratio, "as mesh --optimize-max-edge-ratio")
      ->check(CLI::Range(1.0, 1e6))
      ->capture_default_str();
  optimize_cmd->add_option("--report", oo.report, "write the optimiser's figures as JSON to this file");
  optimize_cmd->add_option("--sign", oo.solid.sign, "--input: the sign rule the mesh was made with, as mesh --sign")
      ->transform(CLI::CheckedTransformer(sign_rules, CLI::ignore_case))
      ->default_str("winding");
  optimize_cmd->add_flag("--no-repair{false}", oo.solid.repair, "--input: as mesh --no-repair");

  CheckCommand co;
  auto* check = app.add_subcommand("check", "validate a hex mesh (and its outside mesh) and measure its quality");
  add_check_options(*check, co);

  CertifyOptions certify_options;
  auto* certify_cmd = app.add_subcommand(
      "certify", "re-check the positivity proof: every cell type x 24 rotations x MC33 subcase, crossings from random "
                 "and extreme corner values; every Bernstein coefficient of det J must be > 0 (exit 3 when not)");
  certify_cmd->add_option("--eps", certify_options.eps, "crossings clamped to [eps, 1 - eps], as mesh --eps")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  certify_cmd
      ->add_option("--type", certify_options.types,
                   "certify only this cell type (repeatable; the single type is always certified)")
      ->type_name("NAME");

  std::string convert_in, convert_out;
  MeshWriteOptions convert_write;
  auto* convert = app.add_subcommand(
      "convert", "convert a hex mesh between .mesh, .meshb, .vtu, .msh, .exo and .inp (regions kept)");
  convert->add_option("input", convert_in, "hex mesh to read")->required();
  convert->add_option("output", convert_out, "hex mesh to write; the format follows the extension")->required();
  convert->add_flag("--binary", convert_write.binary, kBinaryHelp);

  bool devices_json = false;
  auto* devices = app.add_subcommand("devices", "list the compute backends, platforms and devices found");
  devices->add_flag("--json", devices_json, "print the list as JSON");
  bool devices_auto_choice = false;
  // Hidden (no group): what `mesh --backend auto` asks a child process (host/cli/mesh_command.cpp).
  devices->add_flag("--auto-choice", devices_auto_choice, "print the backend --backend auto would use here")->group("");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "mchex-gpu: %s (see --help)\n", e.what());
    return 1;
  }
  try {
    std::optional<ThreadLimit> limit;
    if (threads > 0) limit.emplace(threads);
    if (mesh->parsed()) {
      const OutputGroup outputs;
      mesh_cli.finish();
      return run_mesh(mesh_cli.command, quiet);
    }
    if (devices->parsed()) return devices_auto_choice ? run_auto_choice() : run_devices(devices_json);
    if (optimize_cmd->parsed()) {
      const OutputGroup outputs;
      return run_optimize(oo, quiet);
    }
    if (certify_cmd->parsed()) {
      const CertifyResult r = certify(certify_options);
      if (!quiet) fmt::print("{}", certify_report(r));
      return r.passed() ? 0 : 3;
    }
    if (convert->parsed()) {
      mesh_format(convert_out);
      write_hex_mesh(read_hex_mesh(convert_in), convert_out, convert_write);
      return 0;
    }
    return run_check(co, quiet);
  } catch (const InputError& e) {
    std::fprintf(stderr, "mchex-gpu: %s\n", e.what());
    return 1;
  } catch (const ResourceError& e) {
    std::fprintf(stderr, "mchex-gpu: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "mchex-gpu: out of memory\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mchex-gpu: %s\n", e.what());
    return 3;
  }
}
