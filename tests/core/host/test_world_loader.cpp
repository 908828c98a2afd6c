// World files of a dry run: values, defaults, the checks against the mission, and diagnostics.
#include <sstream>
#include <stdexcept>
#include "projtour_test/loader_fixture.hpp"

#include "projtour/host/mission_loader.hpp"
#include "projtour/host/world_faults.hpp"

namespace projtour::test {
namespace {

using ::testing::ElementsAre;

const char* const kWorld = R"(seed: 7
targets:
  rabbit:
    pose: {x: 6.03, y: 2.02, z: 0.9, yaw_deg: 177}
target_offset: {max_m: 0.05, max_deg: 5}
noise: {odometry_trans_frac: 0.02, odometry_rot_frac: 0.04, laser_range_m: 0.02, encoder_deg: 0.05, depth: none}
model_error: {enabled: false, noise_mm: 2}
calibration_error: {trans_mm: 3, rot_deg: 0.3}
faults:
  - {target: rabbit, type: frame_dropout, fraction: 0.5}
  - {target: hare, type: kidnap, distance_m: 1.0}
)";

class WorldLoader : public LoaderTest {
 protected:
  void SetUp() override {
    LoaderTest::SetUp();
    host::Diagnostics diag;
    auto loaded = host::load_mission(write("m.yaml", kMission), diag);
    ASSERT_TRUE(loaded) << diag.format();
    mission = std::move(*loaded);
  }

  std::vector<std::string> world_errors(const std::string& text) const {
    host::Diagnostics diag;
    EXPECT_FALSE(host::load_world(write("w.yaml", text), mission, diag));
    EXPECT_TRUE(diag.has_errors());
    return formatted(diag);
  }

  MissionSpec mission;
};

TEST_F(WorldLoader, AllValues) {
  host::Diagnostics diag;
  const auto world = host::load_world(write("w.yaml", kWorld), mission, diag);
  ASSERT_TRUE(world) << diag.format();
  EXPECT_EQ(world->file, dir_path / "w.yaml");
  EXPECT_EQ(world->seed, 7u);
  ASSERT_EQ(world->T_map_model_true.count("rabbit"), 1u);
  EXPECT_TRUE(world->T_map_model_true.at("rabbit").translation().isApprox(
      Eigen::Vector3d(6.03, 2.02, 0.9)));
  EXPECT_EQ(world->T_map_model_true.count("hare"), 0u);
  EXPECT_DOUBLE_EQ(world->target_offset_max_m, 0.05);
  EXPECT_DOUBLE_EQ(world->target_offset_max_deg, 5.0);
  EXPECT_DOUBLE_EQ(world->odometry_trans_noise_frac, 0.02);
  EXPECT_DOUBLE_EQ(world->odometry_rot_noise_frac, 0.04);
  EXPECT_DOUBLE_EQ(world->laser_range_noise_m, 0.02);
  EXPECT_DOUBLE_EQ(world->encoder_noise_deg, 0.05);
  EXPECT_FALSE(world->depth_noise);
  EXPECT_FALSE(world->model_error);
  EXPECT_DOUBLE_EQ(world->model_error_noise_mm, 2.0);
  EXPECT_DOUBLE_EQ(world->calibration_error_mm, 3.0);
  EXPECT_DOUBLE_EQ(world->calibration_error_deg, 0.3);
  ASSERT_EQ(world->faults.size(), 2u);
  EXPECT_EQ(world->faults[0].target, "rabbit");
  EXPECT_EQ(world->faults[0].type, "frame_dropout");
  EXPECT_EQ(world->faults[0].values, (std::map<std::string, double>{{"fraction", 0.5}}));
  EXPECT_EQ(world->faults[1].type, "kidnap");
  EXPECT_EQ(world->faults[1].values, (std::map<std::string, double>{{"distance_m", 1.0}}));
  EXPECT_EQ(world->faults[1].mark.line, 11);
}

TEST_F(WorldLoader, EmptyFileIsTheDefaultWorld) {
  host::Diagnostics diag;
  const auto world = host::load_world(write("w.yaml", "# defaults\n"), mission, diag);
  ASSERT_TRUE(world) << diag.format();
  const host::WorldSpec defaults;
  EXPECT_FALSE(world->seed);
  EXPECT_TRUE(world->T_map_model_true.empty());
  EXPECT_DOUBLE_EQ(world->odometry_trans_noise_frac, defaults.odometry_trans_noise_frac);
  EXPECT_TRUE(world->depth_noise);
  EXPECT_TRUE(world->faults.empty());
}

TEST_F(WorldLoader, ShippedExampleLoadsAgainstAMissionWithItsTarget) {
  host::Diagnostics diag;
  const auto world =
      host::load_world(PROJTOUR_SOURCE_DIR "/examples/worlds/atrium_faults.yaml", mission, diag);
  ASSERT_TRUE(world) << diag.format();
  EXPECT_EQ(world->seed, 7u);
  EXPECT_EQ(world->faults.size(), 3u);
}

TEST_F(WorldLoader, TheBuildingSections) {
  host::Diagnostics diag;
  const auto world =
      host::load_world(PROJTOUR_SOURCE_DIR "/examples/worlds/busy_building.yaml", mission, diag);
  ASSERT_TRUE(world) << diag.format();
  EXPECT_DOUBLE_EQ(world->encoder_bias_pan_deg, 0.2);
  EXPECT_DOUBLE_EQ(world->encoder_bias_tilt_deg, -0.1);
  EXPECT_TRUE(world->depth_artefacts);
  ASSERT_EQ(world->objects.size(), 2u);
  EXPECT_EQ(world->objects[0].shape, host::WorldObjectSpec::Shape::box);
  EXPECT_DOUBLE_EQ(world->objects[0].size_y_m, 0.4);
  EXPECT_NEAR(world->objects[0].pose.yaw_rad, deg_to_rad(20.0), 1e-12);
  EXPECT_EQ(world->objects[1].shape, host::WorldObjectSpec::Shape::cylinder);
  EXPECT_DOUBLE_EQ(world->objects[1].size_x_m, 0.4);
  EXPECT_DOUBLE_EQ(world->clutter.per_m, 0.05);
  EXPECT_DOUBLE_EQ(world->clutter.max_height_m, 1.2);
  EXPECT_TRUE(world->supports);
  EXPECT_DOUBLE_EQ(world->map_error.wall_thinning_m, 0.05);
  EXPECT_DOUBLE_EQ(world->map_error.shift_y_m, -0.02);
  ASSERT_EQ(world->map_error.missing_walls.size(), 1u);
  EXPECT_DOUBLE_EQ(world->map_error.missing_walls[0].thickness_m, 0.3);
  EXPECT_EQ(world->map_error.extra_walls.size(), 1u);
  ASSERT_EQ(world->glass.size(), 1u);
  EXPECT_EQ(world->glass[0].b_m, Eigen::Vector2d(-0.5, -44.0));
  EXPECT_EQ(world->people.walkers, 4);
  ASSERT_EQ(world->people.list.size(), 2u);
  EXPECT_EQ(world->people.list[0].route_m.size(), 2u);
  EXPECT_TRUE(world->people.list[0].loop);
  EXPECT_EQ(world->people.list[1].start_m, Eigen::Vector2d(-4.0, -45.0));
  EXPECT_DOUBLE_EQ(world->people.list[1].start_s, 30.0);
}

TEST_F(WorldLoader, BuildingMistakesPointAtTheirField) {
  EXPECT_THAT(
      world_errors("objects:\n  - {type: box, x: 1, y: 2, size_m: [0.5], height_m: 1}\n"),
      ElementsAre(dir + "/w.yaml:2:37: objects[0].size_m: expected 2 numbers [x, y], got 1"));
  EXPECT_THAT(world_errors("objects:\n  - {type: cylinder, x: 1, y: 2, diameter_m: 0.3}\n"),
              ElementsAre(dir + "/w.yaml:2:5: objects[0].height_m: missing required field"));
  EXPECT_THAT(world_errors("people: {speed_mps: [1.5, 0.5]}\n"),
              ElementsAre(dir + "/w.yaml:1:21: people.speed_mps: expected [min, max] with 0 < min "
                                "<= max, got [1.5, 0.5]"));
  EXPECT_THAT(world_errors("people:\n  list:\n    - {route: [[0, 0]]}\n"),
              ElementsAre(dir + "/w.yaml:3:15: people.list[0].route: expected a route of at least "
                                "2 waypoints [[x, y], ...], got 1"));
  EXPECT_THAT(world_errors("glass:\n  - {from: [0, 0], to: [0, 0]}\n"),
              ElementsAre(dir + "/w.yaml:2:24: glass[0].to: expected a wall of some length: `to` "
                                "is `from`"));
  EXPECT_THAT(world_errors("map_error: {wall_thining_m: 0.1}\n"),
              ElementsAre(dir + "/w.yaml:1:13: map_error.wall_thining_m: unknown key "
                                "\"wall_thining_m\"; did you mean \"wall_thinning_m\"?"));
  EXPECT_THAT(world_errors("faults:\n  - {target: rabbit, type: person_standing, for_s: 0}\n"),
              ElementsAre(dir + "/w.yaml:2:52: faults[0].for_s: expected a number > 0, got 0"));
}

TEST_F(WorldLoader, UnknownTargetIdSuggests) {
  EXPECT_THAT(world_errors(replace(kWorld, "rabbit:", "rabit:")),
              ElementsAre(dir +
                          "/w.yaml:3:3: targets.rabit: unknown target \"rabit\" (not in "
                          "mission " +
                          dir + "/m.yaml); did you mean \"rabbit\"?"));
}

TEST_F(WorldLoader, FaultOnUnknownTarget) {
  EXPECT_THAT(world_errors(replace(kWorld, "target: hare", "target: fox")),
              ElementsAre(dir +
                          "/w.yaml:11:14: faults[1].target: unknown target \"fox\" (not "
                          "in mission " +
                          dir + "/m.yaml)"));
}

TEST_F(WorldLoader, UnknownFaultType) {
  EXPECT_THAT(world_errors(replace(kWorld, "frame_dropout", "dropout")),
              ElementsAre(dir + "/w.yaml:10:28: faults[0].type: expected one of frame_dropout, "
                                "target_missing, occluder, blocked_path, kidnap, "
                                "camera_disconnect, projector_failure, target_nudge, pole, "
                                "daylight, person_crossing, person_standing, got "
                                "\"dropout\""));
}

TEST_F(WorldLoader, FaultValueNotANumber) {
  EXPECT_THAT(world_errors(replace(kWorld, "fraction: 0.5", "fraction: half")),
              ElementsAre(dir + "/w.yaml:10:53: faults[0].fraction: expected a number, got "
                                "\"half\""));
}

// A pole fault as the third fault, on line 12.
std::string with_pole(const std::string& numbers) {
  return replace(kWorld, "distance_m: 1.0}\n",
                 "distance_m: 1.0}\n  - {target: rabbit, type: pole, " + numbers + "}\n");
}

TEST_F(WorldLoader, PoleFault) {
  host::Diagnostics diag;
  const auto world = host::load_world(
      write("w.yaml", with_pole("distance_m: 0.6, diameter_m: 0.05, offset_m: -0.2")), mission,
      diag);
  ASSERT_TRUE(world) << diag.format();
  ASSERT_EQ(world->faults.size(), 3u);
  EXPECT_EQ(world->faults[2].type, "pole");
  EXPECT_EQ(world->faults[2].values,
            (std::map<std::string, double>{
                {"distance_m", 0.6}, {"diameter_m", 0.05}, {"offset_m", -0.2}}));
  // Every number is optional.
  EXPECT_TRUE(host::load_world(
      write("w.yaml", replace(with_pole("offset_m: 0"), ", offset_m: 0", "")), mission, diag))
      << diag.format();
}

TEST_F(WorldLoader, PoleDiameterMustBePositive) {
  EXPECT_THAT(world_errors(with_pole("distance_m: 0.6, diameter_m: -0.05")),
              ElementsAre(dir + "/w.yaml:12:63: faults[2].diameter_m: expected a number > 0, got "
                                "-0.05"));
}

TEST_F(WorldLoader, PoleDistanceMustBePositive) {
  EXPECT_THAT(world_errors(with_pole("distance_m: 0, offset_m: -0.2")),
              ElementsAre(dir + "/w.yaml:12:46: faults[2].distance_m: expected a number > 0, got "
                                "0"));
}

TEST_F(WorldLoader, PoleUnknownKeySuggests) {
  EXPECT_THAT(world_errors(with_pole("distance_m: 0.6, diamter_m: 0.05")),
              ElementsAre(dir + "/w.yaml:12:51: faults[2].diamter_m: unknown key \"diamter_m\"; "
                                "did you mean \"diameter_m\"?"));
}

// Every fault type's keys are the simulator's: a misspelt one used to leave the fault at its
// default without a word.
TEST_F(WorldLoader, MisspeltFaultKeyIsAnError) {
  EXPECT_THAT(world_errors(replace(kWorld, "kidnap, distance_m: 1.0", "kidnap, distanse_m: 1.0")),
              ElementsAre(dir + "/w.yaml:11:34: faults[1].distanse_m: unknown key \"distanse_m\"; "
                                "did you mean \"distance_m\"?"));
}

TEST_F(WorldLoader, PoleValueNotANumber) {
  EXPECT_THAT(world_errors(with_pole("distance_m: 0.6, diameter_m: thin")),
              ElementsAre(dir + "/w.yaml:12:63: faults[2].diameter_m: expected a number, got "
                                "\"thin\""));
}

TEST_F(WorldLoader, UnknownTopKeySuggests) {
  EXPECT_THAT(world_errors(replace(kWorld, "noise:", "noize:")),
              ElementsAre(dir + "/w.yaml:6:1: noize: unknown key \"noize\"; did you mean "
                                "\"noise\"?"));
}

TEST_F(WorldLoader, NegativeNoise) {
  EXPECT_THAT(world_errors(replace(kWorld, "laser_range_m: 0.02", "laser_range_m: -0.02")),
              ElementsAre(dir + "/w.yaml:6:76: noise.laser_range_m: expected a number >= 0, got "
                                "-0.02"));
}

TEST_F(WorldLoader, DepthNoiseModelUnknown) {
  EXPECT_THAT(world_errors(replace(kWorld, "depth: none", "depth: nonee")),
              ElementsAre(dir + "/w.yaml:6:108: noise.depth: expected one of kinect_v1, none, "
                                "got \"nonee\"; did you mean \"none\"?"));
}

TEST_F(WorldLoader, SeedNotAnInteger) {
  EXPECT_THAT(world_errors(replace(kWorld, "seed: 7", "seed: lucky")),
              ElementsAre(dir + "/w.yaml:1:7: seed: expected an integer, got \"lucky\""));
}

TEST_F(WorldLoader, ModelErrorEnabledNotABool) {
  EXPECT_THAT(world_errors(replace(kWorld, "enabled: false", "enabled: 0.5")),
              ElementsAre(dir + "/w.yaml:7:24: model_error.enabled: expected true or false, got "
                                "\"0.5\""));
}

TEST_F(WorldLoader, TargetListedTwice) {
  EXPECT_THAT(
      world_errors(replace(kWorld, "target_offset:",
                           "  rabbit: {pose: {x: 6, y: 2, z: 0.9, yaw_deg: 0}}\ntarget_offset:")),
      ElementsAre(dir + "/w.yaml:5:3: targets.rabbit: duplicate key \"rabbit\" (first at line "
                        "3)"));
}

TEST_F(WorldLoader, TruePoseUnknownKeySuggests) {
  EXPECT_THAT(world_errors(replace(kWorld, "yaw_deg: 177", "yaw_deg: 177, pich_deg: 2")),
              ElementsAre(dir + "/w.yaml:4:52: targets.rabbit.pose.pich_deg: unknown key "
                                "\"pich_deg\"; did you mean \"pitch_deg\"?"));
}

// The one table of faults (world_faults.hpp): each type written with every number at the table's
// default loads as written (the defaults are within the loader's bounds), and fault_number gives
// the same default when the number is left out, as the simulator reads it.
TEST_F(WorldLoader, FaultTableDefaultsLoadAsWrittenAndAsLeftOut) {
  ASSERT_EQ(host::fault_kinds().size(), 12u);
  for (const host::FaultKindSpec& kind : host::fault_kinds()) {
    std::ostringstream text;
    text.precision(17);
    text << "faults:\n  - {target: rabbit, type: " << kind.type;
    for (const host::FaultNumberSpec& n : kind.numbers)
      text << ", " << n.key << ": " << n.default_value;
    text << "}\n";
    host::Diagnostics diag;
    const auto world = host::load_world(write("w.yaml", text.str()), mission, diag);
    ASSERT_TRUE(world) << kind.type << ": " << diag.format();
    ASSERT_EQ(world->faults.size(), 1u);
    const host::FaultSpec& written = world->faults[0];
    EXPECT_EQ(written.type, kind.type);
    EXPECT_EQ(written.values.size(), kind.numbers.size()) << kind.type;
    host::FaultSpec left_out;
    left_out.type = kind.type;
    for (const host::FaultNumberSpec& n : kind.numbers) {
      EXPECT_EQ(written.values.at(n.key), n.default_value) << kind.type << "." << n.key;
      EXPECT_EQ(host::fault_number(left_out, n.key), n.default_value) << kind.type << "." << n.key;
      EXPECT_EQ(host::fault_default(kind.type, n.key), n.default_value)
          << kind.type << "." << n.key;
    }
  }
}

// A number the table does not have is the simulator's mistake, never silently a default.
TEST_F(WorldLoader, FaultTableRefusesANumberItDoesNotHave) {
  EXPECT_THROW(host::fault_default("person_standing", "speed_mps"), std::logic_error);
  EXPECT_THROW(host::fault_default("no_such_fault", "after_s"), std::logic_error);
  EXPECT_EQ(host::find_fault_kind("no_such_fault"), nullptr);
  ASSERT_NE(host::find_fault_kind("pole"), nullptr);
  EXPECT_EQ(host::find_fault_kind("pole")->numbers.size(), 3u);
}

}  // namespace
}  // namespace projtour::test
