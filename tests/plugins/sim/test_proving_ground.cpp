// The proving ground's generator and table (plugins/sim/proving_ground): a seed gives the same
// files byte for byte; every mission it draws loads, fits its map and names its world's targets;
// held-out meshes stay in the held-back half; the false-success bound is Clopper-Pearson's.
#include <gtest/gtest.h>
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "batch.hpp"
#include "ground.hpp"
#include "projtour/host/mission_loader.hpp"
#include "projtour/host/world.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour::ground {
namespace {

namespace fs = std::filesystem;

GroundOptions options(std::uint64_t seed, int missions) {
  GroundOptions o;
  o.seed = seed;
  o.missions = missions;
  o.source_dir = PROJTOUR_SOURCE_DIR;
  o.scanned_mesh_dir = PROJTOUR_SCANNED_MESH_DIR;
  return o;
}

std::string read(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Every file under `dir`, by its path relative to it.
std::map<std::string, std::string> files_under(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) out[fs::relative(e.path(), dir).string()] = read(e.path());
  }
  return out;
}

TEST(ProvingGround, SameSeedSameFilesByteForByte) {
  ASSERT_TRUE(fs::exists(fs::path(PROJTOUR_SCANNED_MESH_DIR) / "cow.off"))
      << "libcgal-demo's meshes are extracted at configure time";
  test::TempDir a, b;
  write_ground(options(7, 6), a.path() / "g");
  write_ground(options(7, 6), b.path() / "g");
  const auto first = files_under(a.path() / "g"), second = files_under(b.path() / "g");
  // A mission and a world per case, visits.csv, and four turns of each of the ten scans.
  EXPECT_EQ(first.size(), 6u * 2u + 1u + 40u);
  EXPECT_EQ(first, second);
  test::TempDir c;
  write_ground(options(8, 6), c.path() / "g");
  EXPECT_NE(read(a.path() / "g" / "visits.csv"), read(c.path() / "g" / "visits.csv"));
}

TEST(ProvingGround, EveryMissionLoadsFitsItsMapAndItsWorldNamesItsTargets) {
  test::TempDir dir;
  const fs::path g = dir.path() / "g";
  write_ground(options(3, 12), g);
  std::set<std::string> maps, meshes;
  for (int c = 0; c < 12; ++c) {
    char name[16];
    std::snprintf(name, sizeof name, "case-%04d", c);
    host::Diagnostics diag;
    const auto mission = host::load_mission(g / name / "mission.yaml", diag);
    ASSERT_TRUE(mission) << name << "\n" << diag.format();
    const auto world = host::load_world(g / name / "world.yaml", *mission, diag);
    ASSERT_TRUE(world) << name << "\n" << diag.format();
    EXPECT_EQ(world->T_map_model_true.size(), mission->targets.size()) << name;
    const auto grid = navigation::load_occupancy_grid(mission->map);
    EXPECT_TRUE(navigation::check_mission_on_map(*mission, *grid).empty()) << name;
    maps.insert(mission->map.stem().string());
    for (const auto& t : mission->targets) {
      meshes.insert(t.model.stem().string());
      EXPECT_GE(t.standoff_m, 0.8);
      EXPECT_LE(t.standoff_m, 1.6);
      // The true pose is within the offsets the ground promises: 20 cm, 20 degrees.
      const Eigen::Isometry3d d = t.T_map_model.inverse() * world->T_map_model_true.at(t.id);
      EXPECT_LE(d.translation().norm(), 0.2 + 1e-3) << t.id;
      EXPECT_LE(Eigen::AngleAxisd(d.rotation()).angle(), 20.0 * M_PI / 180.0 + 1e-3) << t.id;
    }
  }
  EXPECT_EQ(maps.size(), 4u);
  EXPECT_GE(meshes.size(), 6u);
}

TEST(ProvingGround, HeldOutMeshesAppearOnlyInTheHeldBackHalf) {
  const auto cases = generate_ground(options(5, 24), test::TempDir().path() / "meshes");
  std::set<std::string> held_out;
  for (const auto& m : default_meshes(options(5, 24))) {
    if (m.held_out) held_out.insert(m.name);
  }
  ASSERT_EQ(held_out.size(), 4u);
  int held_out_visits = 0;
  for (const auto& c : cases) {
    for (const auto& v : c.visits) {
      if (held_out.count(v.mesh)) {
        EXPECT_EQ(v.half, "held_back") << c.name << " " << v.target;
        ++held_out_visits;
      }
    }
  }
  EXPECT_GT(held_out_visits, 0);
}

// Clopper-Pearson's one-sided 95 % bound: for 0 in n it is 1 - 0.05^(1/n) in closed form; for k
// in n the 95th percentile of Beta(k + 1, n - k), computed apart (Simpson's rule over the beta
// density): 0.39416 for 1 in 10, 0.17873 for 2 in 33 (issue 44's false successes).
TEST(ProvingGround, FalseSuccessBoundIsClopperPearson) {
  EXPECT_NEAR(upper_bound_95(0, 600), 1.0 - std::pow(0.05, 1.0 / 600.0), 1e-9);
  EXPECT_LT(upper_bound_95(0, 600), 0.005);
  EXPECT_NEAR(upper_bound_95(1, 10), 0.39416, 1e-5);
  EXPECT_NEAR(upper_bound_95(2, 33), 0.17873, 1e-5);
  EXPECT_EQ(upper_bound_95(0, 0), 1.0);
}

// A visit is a false success when projected with the referee's error over its tolerance; a visit
// whose navigate never succeeded (the run's events) is not reachable: it counts against no yield.
TEST(ProvingGround, ResultsReadFromTheReports) {
  test::TempDir dir;
  const fs::path g = dir.path();
  std::ofstream(g / "visits.csv") << "mission,target,tolerance_mm,seed\n"
                                     "case-0000,a,3.0,1\ncase-0000,b,3.0,1\ncase-0000,c,3.0,1\n";
  fs::create_directories(g / "case-0000" / "run");
  std::ofstream(g / "case-0000" / "run" / "report.json") << R"({"targets": [
      {"id": "a", "outcome": "projected", "observed_error_mm": 0.8,
       "projection_error_mm": {"before_align": 30.0, "after_align": 3.3}},
      {"id": "b", "outcome": "projected", "observed_error_mm": 1.0,
       "projection_error_mm": {"before_align": 30.0, "after_align": 1.2}},
      {"id": "c", "outcome": "skipped", "reason": "blocked: someone in the way"}]})";
  std::ofstream(g / "case-0000" / "run" / "events.jsonl")
      << R"({"t": 1, "event": "outcome", "state": "tour/visit/navigate", "target": "a", )"
         R"("outcome": "succeeded"})"
         "\n"
      << R"({"t": 2, "event": "outcome", "state": "tour/visit/navigate", "target": "b", )"
         R"("outcome": "succeeded"})"
         "\n"
      << R"({"t": 3, "event": "outcome", "state": "tour/visit/navigate", "target": "c", )"
         R"("outcome": "blocked"})"
         "\n";
  const GroundResults r = read_results(g);
  ASSERT_EQ(r.visits.size(), 3u);
  EXPECT_TRUE(r.visits[0].false_success());
  EXPECT_FALSE(r.visits[1].false_success());
  EXPECT_TRUE(r.visits[0].reachable);
  EXPECT_FALSE(r.visits[2].reachable);
  EXPECT_NEAR(*r.visits[0].observed_mm - *r.visits[0].true_mm, -2.5, 1e-12);
}

}  // namespace
}  // namespace projtour::ground
