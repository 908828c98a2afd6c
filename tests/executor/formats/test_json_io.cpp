// The JSON projtour writes and reads back: the writer's exact text (outputs stay byte-identical
// across versions), strict parsing of checkpoint.json and report.json with errors that name the
// file and the byte, and the target records through to_json/from_json.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "projtour/contract/mission.hpp"
#include "projtour/formats/json_io.hpp"
#include "projtour/record/target_record.hpp"
#include "projtour/run/atomic_file.hpp"
#include "projtour/run/report.hpp"
#include "projtour/views/summary_page.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

// The message of what `parse_json(text)` throws, or "" when it parses.
std::string parse_error(const std::string& text) {
  try {
    parse_json(text, "in.json");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(JsonParse, RejectsWhatTheHandWrittenParserAccepted) {
  for (const char* text : {"1-2-3",
                           "1.2.3",
                           "+5",
                           "01",
                           "-01",
                           "1.",
                           ".5",
                           "1e",
                           "[1,]",
                           "{\"a\":1,}",
                           "// c\n1",
                           "NaN",
                           "Infinity",
                           "[1] 2",
                           "\"\\uZZZZ\"",
                           "\"\\u12\"",
                           "\"\\ud800\"",
                           "\"\\udc00\"",
                           "\"\\ud800\\u0041\"",
                           "\"\\x\"",
                           "\"a\tb\"",
                           "\"\xff\"",
                           "\"\xc3\"",
                           "tru",
                           ""}) {
    const std::string error = parse_error(text);
    EXPECT_EQ(error.rfind("in.json: malformed JSON at byte ", 0), 0u) << text << " -> " << error;
  }
}

TEST(JsonParse, NamesTheByteOfTheError) {
  EXPECT_EQ(parse_error("1-2-3").rfind("in.json: malformed JSON at byte 3: ", 0), 0u)
      << parse_error("1-2-3");
  EXPECT_NE(parse_error("{\n  \"a\": 01\n}").find("line 2"), std::string::npos);
}

TEST(JsonParse, RejectsDuplicateKeysAtTheirByte) {
  // The second "a" closes at byte 12 (counting from 1).
  EXPECT_EQ(parse_error(R"({"a": 1, "a": 2})"),
            "in.json: malformed JSON at byte 12: duplicate key \"a\"");
  EXPECT_NE(parse_error(R"({"x": [{"id": 1, "b": {"c": 1, "c": 1}}]})").find("duplicate key \"c\""),
            std::string::npos);
  // The same key in different objects is fine.
  EXPECT_EQ(parse_error(R"({"a": {"a": 1}, "b": [{"a": 1}, {"a": 2}], "c": {}})"), "");
}

// Regression: a checkpoint of 50,000 nested '[' crashed --resume (the recursion of reading it).
TEST(JsonParse, NestingDeeperThanTheBoundIsRefusedAtItsByte) {
  const auto nested = [](int depth) {
    return std::string(static_cast<std::size_t>(depth), '[') +
           std::string(static_cast<std::size_t>(depth), ']');
  };
  EXPECT_EQ(parse_error(nested(kMaxJsonDepth)), "");
  EXPECT_EQ(parse_error(nested(kMaxJsonDepth + 1)),
            "in.json: malformed JSON at byte 65: nested deeper than 64 arrays and objects");
  EXPECT_EQ(parse_error(std::string(50000, '[')),
            "in.json: malformed JSON at byte 65: nested deeper than 64 arrays and objects");
  std::string objects;
  for (int i = 0; i < 50000; ++i) objects += "{\"a\": ";
  EXPECT_NE(parse_error(objects).find("nested deeper than 64"), std::string::npos);
}

// Regression (found by fuzz_checkpoint_reader): a number beyond a double escaped parse_json as
// nlohmann's out_of_range, which --resume did not name the file of.
TEST(JsonParse, NumberBeyondADoubleIsMalformed) {
  EXPECT_EQ(parse_error(R"({"mission_s": -1e+600})"),
            "in.json: malformed JSON at byte 22: number out of range");
}

TEST(JsonParse, AcceptsStrictJson) {
  const Json j = parse_json(
      R"({"u": 18446744073709551615, "i": -9223372036854775808, "d": 1e-07, "s": "\ud83d\ude00\u00e9\n",
          "n": null, "b": [true, false, 0, -0.0, 1E+2]})",
      "in.json");
  EXPECT_EQ(j.at("u").get<std::uint64_t>(), std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(j.at("i").get<std::int64_t>(), std::numeric_limits<std::int64_t>::min());
  EXPECT_EQ(j.at("d").get<double>(), 1e-7);
  EXPECT_EQ(j.at("s").get<std::string>(), "\xF0\x9F\x98\x80\xC3\xA9\n");  // valid UTF-8
  EXPECT_EQ(j.at("b").size(), 5u);
}

TEST(JsonDump, WritesTheTextProjtourAlwaysWrote) {
  EXPECT_EQ(dump_json(Json(std::numeric_limits<std::uint64_t>::max())), "18446744073709551615");
  EXPECT_EQ(dump_json(Json(std::numeric_limits<std::int64_t>::min())), "-9223372036854775808");
  // Shortest round-trip doubles, ".0" on whole ones, and no JSON for non-finite values.
  const std::pair<double, const char*> doubles[] = {
      {0.1, "0.1"},
      {1e-7, "1e-07"},
      {195.75, "195.75"},
      {3.0, "3.0"},
      {0.0001, "1e-04"},
      {1e14, "1e+14"},
      {123456.0, "123456.0"},
      {-0.0, "-0.0"},
      {0.30000000000000004, "0.30000000000000004"},
      {2.5e-5, "2.5e-05"},
      {std::nan(""), "null"},
      {std::numeric_limits<double>::infinity(), "null"}};
  for (const auto& [value, text] : doubles) EXPECT_EQ(dump_json(Json(value)), text) << text;
  EXPECT_EQ(json_number_text(1.5), "1.5");

  Json j = Json::object();
  j["t"] = 0.0;
  j["s"] = "q\"b\\s\n\t\r\x01\b/é";
  j["a"] = Json::array({1, 2});
  j["o"] = Json::object();
  j["e"] = Json::array();
  j["n"] = nullptr;
  EXPECT_EQ(
      dump_json(j),
      R"({"t": 0.0, "s": "q\"b\\s\n\t\r\u0001\u0008/é", "a": [1, 2], "o": {}, "e": [], "n": null})");
  EXPECT_EQ(
      dump_json(j, 2),
      "{\n  \"t\": 0.0,\n  \"s\": \"q\\\"b\\\\s\\n\\t\\r\\u0001\\u0008/é\",\n  \"a\": [\n    1,\n"
      "    2\n  ],\n  \"o\": {},\n  \"e\": [],\n  \"n\": null\n}");
}

TEST(JsonDump, ParseThenDumpGivesTheSameText) {
  const std::string text = R"({
  "mission": "demo-tour",
  "dry_run": true,
  "seed": 18446744073709551615,
  "timing": {
    "wall_s": 3.587429007,
    "mission_s": 195.75
  },
  "targets": [
    {
      "id": "rabbit",
      "outcome": "projected",
      "retries": 0,
      "projected_s": 8.0,
      "align": {
        "method": "projective_icp",
        "time_ms": 1.2207,
        "iterations": 19,
        "inlier_fraction": 0.755750273822563,
        "rmse_mm": 1.2825235013211473
      }
    }
  ]
})";
  EXPECT_EQ(dump_json(parse_json(text, "report.json"), 2), text);
}

TargetRecord full_record() {
  TargetRecord r;
  r.id = "rabbit";
  r.outcome = "projected";
  r.retries = 2;
  r.measurements.projected_s = 8.0;
  r.measurements.align = AlignFigures{"projective_icp", 1.25, 19, 0.75, 1.5};
  r.measurements.localization_error = LocalizationError{0.01, 0.02, 0.03, 0.04};
  r.measurements.target_pose_error = TargetPoseError{0.5, 0.25};
  r.measurements.projection_error_mm = BeforeAfter{7.0, 2.0};
  r.measurements.projection_error_px = BeforeAfter{std::nullopt, 3.0};
  return r;
}

TEST(TargetRecordJson, WritesDesignOrderAndReadsBack) {
  const TargetRecord r = full_record();
  const std::string text = dump_json(Json(r));
  EXPECT_EQ(
      text,
      R"({"id": "rabbit", "outcome": "projected", "retries": 2, "projected_s": 8.0, )"
      R"("align": {"method": "projective_icp", "time_ms": 1.25, "iterations": 19, )"
      R"("inlier_fraction": 0.75, "rmse_mm": 1.5}, "localization_error": {"trans_m": 0.01, )"
      R"("rot_deg": 0.02, "building_trans_m": 0.03, "building_rot_deg": 0.04}, "target_pose_error": {"trans_mm": 0.5, "rot_deg": 0.25}, )"
      R"("projection_error_mm": {"before_align": 7.0, "after_align": 2.0}, )"
      R"("projection_error_px": {"after_align": 3.0}})");
  const TargetRecord back = parse_json(text, "record").get<TargetRecord>();
  EXPECT_EQ(dump_json(Json(back)), text);
  ASSERT_TRUE(back.measurements.align.has_value());
  EXPECT_EQ(back.measurements.align->iterations, 19);
  EXPECT_FALSE(back.measurements.projection_error_px->before_align.has_value());
}

// A figure that came out NaN is written as null and must not stop a resume.
TEST(TargetRecordJson, NonFiniteFiguresRoundTripAsNull) {
  TargetRecord r = full_record();
  r.measurements.align->rmse_mm = std::nan("");
  r.measurements.projection_error_mm->after_align = std::numeric_limits<double>::infinity();
  const std::string text = dump_json(Json(r));
  EXPECT_NE(text.find("\"rmse_mm\": null"), std::string::npos) << text;
  const TargetRecord back = parse_json(text, "record").get<TargetRecord>();
  EXPECT_TRUE(std::isnan(back.measurements.align->rmse_mm));
  EXPECT_TRUE(std::isnan(*back.measurements.projection_error_mm->after_align));
  EXPECT_EQ(dump_json(Json(back)), text);
}

TEST(TargetRecordJson, RejectsFieldsOfTheWrongTypeOrUnknown) {
  const auto error = [](const std::string& text) -> std::string {
    try {
      parse_json(text, "record").get<TargetRecord>();
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  };
  const std::string head = R"({"id": "a", "outcome": "projected", )";
  EXPECT_EQ(error(head + R"("retries": 0})"), "");
  EXPECT_EQ(error(head + R"("retries": 1.5})"), "\"retries\" is not an integer");
  EXPECT_EQ(error(head + R"("retries": "1"})"), "\"retries\" is not an integer");
  EXPECT_EQ(error(head + R"("retries": 99999999999})"), "\"retries\" is out of range");
  EXPECT_EQ(error(R"({"outcome": "projected", "retries": 0})"), "\"id\" is missing");
  EXPECT_EQ(error(head + R"("retries": 0, "colour": 1})"), "unknown field \"colour\"");
  EXPECT_EQ(error(head + R"("retries": 0, "projected_s": "8"})"),
            "\"projected_s\" is not a number but string");
  EXPECT_EQ(error(head + R"("retries": 0, "align": {"method": "x", "time_ms": 1, )"
                         R"("iterations": 2.5, "inlier_fraction": 1, "rmse_mm": 1}})"),
            "align: \"iterations\" is not an integer");
  EXPECT_EQ(error(head + R"("retries": 0, "projection_error_mm": {"after": 1}})"),
            "projection_error_mm: unknown field \"after\"");
  // Regression: a calibration without "adopted" escaped as nlohmann's out_of_range.
  EXPECT_EQ(error(head + R"("retries": 0, "calibration": {}})"),
            "calibration: \"adopted\" is missing");
  EXPECT_EQ(error(head + R"("retries": 0, "localization_error": [1, 2]})"),
            "localization_error: the value is not an object but array");
}

class CheckpointFile : public ::testing::Test {
 protected:
  void SetUp() override {
    mission_.name = "m";
    mission_.targets.resize(2);
    mission_.targets[0].id = "rabbit";
    mission_.targets[1].id = "sign";
  }
  fs::path write(const std::string& text) {
    const fs::path file = dir_ / "checkpoint.json";
    std::ofstream(file, std::ios::binary) << text;
    return file;
  }
  // The message read_checkpoint throws for `text`, or "" when it reads.
  std::string error(const std::string& text) {
    try {
      read_checkpoint(write(text), mission_);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  }

  test::TempDir scratch_;
  const fs::path dir_ = scratch_.path();
  MissionSpec mission_;
};

// What a done entry of the tests below was done against.
const char* const kAgainst =
    R"("done_against": {"pose": {"translation_m": [1.0, 2.0, 0.5], )"
    R"("rotation_wxyz": [1.0, 0.0, 0.0, 0.0]}, )"
    R"("model": {"file": "models/rabbit.ply", "bytes": 1234, "fnv1a64": "0123456789abcdef"}})";

// A checkpoint of mission "m" at `mission_s` with these done entries.
std::string checkpoint_text(const std::string& mission_s, const std::string& done) {
  return R"({"mission": "m", "seed": 1, "mission_s": )" + mission_s + R"(, "done": [)" + done +
         R"(], "current_target": null})";
}

// A done entry: `fields` after the id, then kAgainst.
std::string done_entry(const std::string& id, const std::string& fields) {
  return R"({"id": ")" + id + R"(", )" + fields + ", " + kAgainst + "}";
}

const char* const kProjected = R"("outcome": "projected", "retries": 0)";

TEST_F(CheckpointFile, RoundTripsThroughTheRecords) {
  Checkpoint c;
  c.mission = "m";
  c.seed = std::numeric_limits<std::uint64_t>::max();
  c.mission_s = 42.5;
  TargetRecord r = full_record();
  r.index = 0;
  c.done.push_back(r);
  TargetIdentity against;
  against.t_map_model_m = {1.0, -2.5, 0.125};
  against.q_map_model = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  against.model = "models/rabbit.ply";
  against.model_bytes = 1234;
  against.model_fnv1a64 = 0xfedcba9876543210ull;
  c.done_against.push_back(against);
  c.current_target = "sign";
  const std::string text = dump_json(checkpoint_to_json(c), 2);
  EXPECT_NE(text.find("\"seed\": 18446744073709551615,"), std::string::npos) << text;
  EXPECT_NE(text.find("\"fnv1a64\": \"fedcba9876543210\""), std::string::npos) << text;
  const Checkpoint back = read_checkpoint(write(text), mission_);
  EXPECT_EQ(back.seed, c.seed);
  EXPECT_EQ(back.mission_s, 42.5);
  ASSERT_EQ(back.done.size(), 1u);
  EXPECT_EQ(back.done[0].index, 0u);
  EXPECT_EQ(dump_json(Json(back.done[0])), dump_json(Json(r)));
  ASSERT_EQ(back.done_against.size(), 1u);
  EXPECT_EQ(identity_change(back.done_against[0], against), "");
  EXPECT_EQ(back.done_against[0].model, "models/rabbit.ply");
  EXPECT_EQ(back.current_target, std::optional<std::string>("sign"));
  EXPECT_EQ(dump_json(checkpoint_to_json(back), 2), text);
}

TEST_F(CheckpointFile, MalformedTextNamesTheFileAndByte) {
  const std::string file = (dir_ / "checkpoint.json").string();
  EXPECT_EQ(
      error(R"({"mission": "m", "seed": 01})").rfind(file + ": malformed JSON at byte 27: ", 0), 0u)
      << error(R"({"mission": "m", "seed": 01})");
  EXPECT_EQ(error(R"({"mission": "m", "mission": "m"})"),
            file + ": malformed JSON at byte 26: duplicate key \"mission\"");
  EXPECT_EQ(
      error(R"({"mission": "m", "seed": 1, "mission_s": 0.0, "done": [{"id": "rabbit", )"
            R"("outcome": "projected", "retries": 0, "retries": 1}], "current_target": null})")
          .rfind(file + ": malformed JSON at byte ", 0),
      0u);
}

TEST_F(CheckpointFile, FieldsMustHaveTheirTypes) {
  const std::string file = (dir_ / "checkpoint.json").string();
  const auto checkpoint = [](const std::string& seed, const std::string& done) {
    return R"({"mission": "m", "seed": )" + seed + R"(, "mission_s": 1.0, "done": [)" + done +
           R"(], "current_target": null})";
  };
  EXPECT_EQ(error(checkpoint("1", done_entry("rabbit", kProjected))), "");
  EXPECT_EQ(error(checkpoint("7", "")), "");
  EXPECT_EQ(error(checkpoint("-1", "")), file + ": \"seed\" is not an unsigned integer");
  EXPECT_EQ(error(checkpoint("1.5", "")), file + ": \"seed\" is not an unsigned integer");
  EXPECT_EQ(error(checkpoint("\"1\"", "")), file + ": \"seed\" is not an unsigned integer");
  EXPECT_EQ(
      error(checkpoint("1", done_entry("rabbit", R"("outcome": "projected", "retries": -0.5)"))),
      file + ": done[0]: \"retries\" is not an integer");
  EXPECT_EQ(error(checkpoint("1", R"({"id": "rabbit", "outcome": "projected", "retries": 0})")),
            file +
                ": done[0].done_against: missing: each done target records what it was done "
                "against");
  EXPECT_EQ(error(checkpoint("1", R"({"id": "rabbit", "outcome": "projected", "retries": 0, )"
                                  R"("done_against": {"pose": {"translation_m": [1, 2], )"
                                  R"("rotation_wxyz": [1, 0, 0, 0]}, "model": {}}})")),
            file + ": done[0].done_against.pose.translation_m: expected an array of 3 numbers");
  EXPECT_EQ(error(checkpoint("1", R"({"id": "rabbit", "outcome": "projected", "retries": 0, )"
                                  R"("done_against": {"pose": {"translation_m": [1, 2, 3], )"
                                  R"("rotation_wxyz": [2, 0, 0, 0]}, "model": {}}})")),
            file +
                ": done[0].done_against.pose.rotation_wxyz: expected a unit quaternion, got "
                "norm 2.0");
  EXPECT_EQ(error(checkpoint("1", R"({"id": "rabbit", "outcome": "projected", "retries": 0, )"
                                  R"("done_against": {"pose": {"translation_m": [1, 2, 3], )"
                                  R"("rotation_wxyz": [1, 0, 0, 0]}, "model": {"file": "a", )"
                                  R"("bytes": 1, "fnv1a64": "XYZ"}}})")),
            file +
                ": done[0].done_against.model.fnv1a64: expected 16 lowercase hex digits, got "
                "\"XYZ\"");
  EXPECT_EQ(error(checkpoint("1", R"({"id": "rabbit", "outcome": "projected", "retries": 0, )"
                                  R"("done_against": {"pose": {"translation_m": [1, 2, 3], )"
                                  R"("rotation_wxyz": [1, 0, 0, 0]}, "model": {"file": "a"}}})")),
            file + ": done[0].done_against: \"bytes\" is missing");
  EXPECT_EQ(error(R"({"mission": "m", "seed": 1, "mission_s": 1.0, "done": [], )"
                  R"("current_target": null, "extra": 1})"),
            file + ": unknown field \"extra\"");
  EXPECT_EQ(error("[]"), file + ": the checkpoint is not an object but array");
}

// Regression: a checkpoint of 50,000 nested '[' crashed --resume.
TEST_F(CheckpointFile, DeeplyNestedCheckpointIsRefused) {
  const std::string file = (dir_ / "checkpoint.json").string();
  EXPECT_EQ(error(std::string(50000, '[')),
            file + ": malformed JSON at byte 65: nested deeper than 64 arrays and objects");
  EXPECT_EQ(error(checkpoint_text("1.0", "") + std::string(50000, '[')).rfind(file, 0), 0u);
}

TEST_F(CheckpointFile, CheckpointLargerThanTheBoundIsRefusedUnread) {
  const std::string file = (dir_ / "checkpoint.json").string();
  std::string text = checkpoint_text("1.0", "");
  text.resize(kMaxCheckpointBytes + 1, ' ');
  EXPECT_EQ(error(text), file + ": larger than 64 MiB, the bound of a checkpoint");
  text.resize(kMaxCheckpointBytes);  // trailing spaces are JSON whitespace
  EXPECT_EQ(error(text), "");
}

// Regression: `mission_s: -1e300` hung --resume (the clock stood still at the tick's size).
TEST_F(CheckpointFile, NegativeHugeOrNonFiniteMissionTimeIsRefused) {
  const std::string file = (dir_ / "checkpoint.json").string();
  const std::string expected = file + ": mission_s: expected a finite time from 0 to 1e+09, got ";
  EXPECT_EQ(error(checkpoint_text("-1e300", "")), expected + "-1e+300");
  EXPECT_EQ(error(checkpoint_text("1e300", "")), expected + "1e+300");
  EXPECT_EQ(error(checkpoint_text("-0.5", "")), expected + "-0.5");
  EXPECT_EQ(error(checkpoint_text("1000000000.5", "")), expected + "1000000000.5");
  EXPECT_EQ(error(checkpoint_text("null", "")), expected + "null");
  EXPECT_EQ(error(checkpoint_text("\"1\"", "")), file + ": mission_s: is not a number but string");
  EXPECT_EQ(error(checkpoint_text("0", "")), "");
  EXPECT_EQ(error(checkpoint_text("1e9", "")), "");
  // The time fields of the records too.
  EXPECT_EQ(
      error(checkpoint_text("1.0", done_entry("rabbit", R"("outcome": "projected", )"
                                                        R"("retries": 0, "projected_s": -1.0)"))),
      file + ": done[0].projected_s: expected a finite time from 0 to 1e+09, got -1.0");
  EXPECT_EQ(error(checkpoint_text(
                "1.0", done_entry("rabbit", R"("outcome": "projected", "retries": 0, )"
                                            R"("align": {"method": "x", "time_ms": null, )"
                                            R"("iterations": 2, "inlier_fraction": 1, )"
                                            R"("rmse_mm": null})"))),
            file + ": done[0].align.time_ms: expected a finite time from 0 to 1e+12, got null");
  EXPECT_EQ(error(checkpoint_text("1.0", done_entry("rabbit", R"("outcome": "skipped", )"
                                                              R"("retries": -3)"))),
            file + ": done[0].retries: expected a count >= 0, got -3");
}

// Regression: duplicated `done` entries gave a report of 8 targets for a 6-target mission.
TEST_F(CheckpointFile, DuplicateDoneTargetIsRefused) {
  const std::string file = (dir_ / "checkpoint.json").string();
  const std::string rabbit = done_entry("rabbit", kProjected);
  EXPECT_EQ(
      error(checkpoint_text("1.0", rabbit + ", " + done_entry("sign", kProjected) + ", " + rabbit)),
      file + ": done[2].id: \"rabbit\" is done already (done[0])");
}

// Regression: an unknown outcome was copied through to the report.
TEST_F(CheckpointFile, UnknownOutcomeIsRefused) {
  const std::string file = (dir_ / "checkpoint.json").string();
  EXPECT_EQ(
      error(checkpoint_text("1.0", done_entry("sign", kProjected) + ", " +
                                       done_entry("rabbit", R"("outcome": "x", "retries": 0)"))),
      file +
          ": done[1].outcome: expected one of \"projected\", \"skipped\", \"failed\", "
          "\"outside_hours\", "
          "got \"x\"");
  // Control characters are escaped, not echoed raw to the terminal.
  EXPECT_EQ(error(checkpoint_text("1.0", done_entry("rabbit", R"("outcome": "\u001b[2J", )"
                                                              R"("retries": 0)"))),
            file +
                ": done[0].outcome: expected one of \"projected\", \"skipped\", \"failed\", "
                "\"outside_hours\", "
                "got \"\\u001b[2J\"");
}

TEST_F(CheckpointFile, UnknownTargetIdIsRefused) {
  const std::string file = (dir_ / "checkpoint.json").string();
  EXPECT_EQ(error(checkpoint_text("1.0", done_entry("fox", kProjected))),
            file + ": done[0].id: target \"fox\" is not in the mission");
  EXPECT_EQ(error(R"({"mission": "m", "seed": 1, "mission_s": 0.0, "done": [], )"
                  R"("current_target": "fox"})"),
            file + ": current_target: target \"fox\" is not in the mission");
}

// The report's shape, pinned: the notes (a target visited again on resume) come after the
// reasons, and only when there are any.
TEST(ReportJson, NotesAreWrittenAfterTheReasonsWhenAny) {
  RunSummary summary;
  summary.mission = "m";
  summary.seed = 3;
  summary.outcome = TourOutcome::completed;
  summary.wall_s = 1.5;
  summary.mission_s = 20.0;
  TargetRecord r;
  r.id = "rabbit";
  r.outcome = "projected";
  summary.targets.push_back(r);
  EXPECT_EQ(dump_json(build_report(summary)),
            R"({"mission": "m", "dry_run": false, "seed": 3, "outcome": "completed", )"
            R"("timing": {"wall_s": 1.5, "mission_s": 20.0}, "targets": [{"id": "rabbit", )"
            R"("outcome": "projected", "retries": 0}]})");
  summary.ignored_cancel.push_back("tour/visit/work (scripted)");
  summary.notes.push_back(
      "target \"rabbit\" visited again: its pose on the map moved 24.000 m since the checkpoint");
  EXPECT_EQ(dump_json(build_report(summary)),
            R"({"mission": "m", "dry_run": false, "seed": 3, "outcome": "completed", )"
            R"j("ignored_cancel": ["tour/visit/work (scripted)"], "notes": ["target \"rabbit\" )j"
            R"(visited again: its pose on the map moved 24.000 m since the checkpoint"], )"
            R"("timing": {"wall_s": 1.5, "mission_s": 20.0}, "targets": [{"id": "rabbit", )"
            R"("outcome": "projected", "retries": 0}]})");
}

// A schedule's records: round by round, each round in mission order, with the round and the
// content item written; the table gains a round column.
TEST(ReportJson, RoundsInOrderWithTheirContent) {
  RunSummary summary;
  summary.mission = "m";
  auto record = [](std::size_t index, const std::string& id, int round) {
    TargetRecord r;
    r.index = index;
    r.id = id;
    r.outcome = "projected";
    r.round = round;
    return r;
  };
  // Visited out of mission order (nearest first), and a retried one recorded late.
  summary.targets = {record(1, "pillar", 1), record(0, "rabbit", 1), record(0, "rabbit", 2),
                     record(1, "pillar", 2)};
  summary.targets[2].content = "lunch.avi";
  summary.targets[2].content_index = 1;
  const Json targets = build_report(summary)["targets"];
  EXPECT_EQ(dump_json(targets),
            R"([{"id": "rabbit", "outcome": "projected", "retries": 0, "round": 1}, )"
            R"({"id": "pillar", "outcome": "projected", "retries": 0, "round": 1}, )"
            R"({"id": "rabbit", "outcome": "projected", "retries": 0, "round": 2, )"
            R"("content": "lunch.avi", "content_index": 1}, )"
            R"({"id": "pillar", "outcome": "projected", "retries": 0, "round": 2}])");
  TargetRecord back = targets[2].get<TargetRecord>();
  EXPECT_EQ(back.round, 2);
  EXPECT_EQ(back.content, "lunch.avi");
  EXPECT_EQ(back.content_index, 1);
  std::ostringstream table;
  print_target_table(summary, table);
  EXPECT_EQ(table.str().rfind("round  target  outcome", 0), 0u) << table.str();
  EXPECT_NE(table.str().find("\n2      rabbit  projected"), std::string::npos) << table.str();
}

TEST(SummaryInput, MalformedReportNamesTheFileAndByte) {
  const test::TempDir scratch;
  const fs::path dir = scratch.path();
  write_file_atomically(dir / "report.json", "{\"mission\": \"m\", \"seed\": 1-2-3}\n");
  try {
    read_summary_input(dir);
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(
                  (dir / "report.json").string() + ": malformed JSON at byte 28: ", 0),
              0u)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "report.json.tmp"));
}

TEST(AtomicFile, ReplacesTheFileAndNamesItOnFailure) {
  const test::TempDir scratch;
  const fs::path file = scratch / "atomic.txt";
  write_file_atomically(file, "one");
  write_file_atomically(file, "two");
  std::ifstream in(file);
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()),
            "two");
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));
  fs::remove(file);
  try {
    write_file_atomically("/nonexistent/dir/x.json", "x");
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.json"), std::string::npos);
  }
}

}  // namespace
}  // namespace projtour
