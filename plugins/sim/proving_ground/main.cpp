// projtour-proving-ground: draws random buildings (generate), runs their dry runs (run) and
// tabulates what "projected" was worth in them (table). See plugins/sim/proving_ground/README.md.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fstream>
#include <iostream>

#include "batch.hpp"
#include "ground.hpp"
#include "projtour/cli/options.hpp"

namespace {

namespace fs = std::filesystem;

// The projtour beside this program (both are built into the build directory's root).
fs::path projtour_beside_me() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path("projtour") : self.parent_path() / "projtour";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"projtour-proving-ground: random buildings for the closed loop's verdict"};
  app.require_subcommand(1);
  projtour::ground::GroundOptions options;
  options.source_dir = PROJTOUR_SOURCE_DIR;
  std::string out;
  CLI::App* generate = app.add_subcommand("generate", "draw missions and worlds into OUT");
  projtour::cli::add_uint64(
      *generate, "--seed", [&](std::uint64_t v) { options.seed = v; }, "N");
  projtour::cli::add_int(
      *generate, "--missions", [&](int v) { options.missions = v; }, "N")
      ->check(CLI::Range(1, 100000));
  projtour::cli::add_int(
      *generate, "--targets", [&](int v) { options.targets_per_mission = v; }, "N")
      ->check(CLI::Range(1, 10));
  std::string scanned = PROJTOUR_SCANNED_MESH_DIR;
  generate->add_option("--scanned-meshes", scanned,
                       "CGAL's data/meshes (default: the build's copy; \"\" for the shipped only)");
  generate->add_option("out", out, "a new directory")->required();

  std::string ground;
  int jobs = 2;
  std::string projtour;
  CLI::App* run = app.add_subcommand("run", "run every case of GROUND that has no report yet");
  run->add_option("ground", ground)->required();
  projtour::cli::add_int(
      *run, "--jobs", [&](int v) { jobs = v; }, "N")
      ->check(CLI::Range(1, 64));
  run->add_option("--projtour", projtour, "the projtour program (default: beside this one)");

  CLI::App* table = app.add_subcommand("table", "the table of GROUND's visits (Markdown)");
  table->add_option("ground", ground)->required();
  std::string table_out;
  table->add_option("--out", table_out, "write here instead of standard output");

  CLI11_PARSE(app, argc, argv);
  try {
    if (generate->parsed()) {
      options.scanned_mesh_dir = scanned;
      if (!scanned.empty() && !fs::exists(fs::path(scanned) / "cow.off")) {
        std::cerr << "projtour-proving-ground: " << scanned
                  << " holds no scanned meshes (install libcgal-demo and configure again)\n";
        return 2;
      }
      projtour::ground::write_ground(options, out);
      std::cout << "projtour-proving-ground: " << options.missions << " missions in " << out
                << "\n";
      return 0;
    }
    if (run->parsed()) {
      const fs::path program = projtour.empty() ? projtour_beside_me() : fs::path(projtour);
      const int failed = projtour::ground::run_cases(ground, program, jobs, std::cout);
      if (failed > 0) std::cerr << "projtour-proving-ground: " << failed << " runs failed\n";
      return failed > 0 ? 1 : 0;
    }
    const auto results = projtour::ground::read_results(ground);
    if (table_out.empty()) {
      projtour::ground::write_table(results, std::cout);
    } else {
      std::ofstream file(table_out);
      projtour::ground::write_table(results, file);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "projtour-proving-ground: " << e.what() << "\n";
    return 2;
  }
}
