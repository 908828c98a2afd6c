#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "projtour_executor/json.hpp"
#include "projtour_executor/report.hpp"

namespace projtour {
namespace {

TEST(Json, RoundTripKeepsOrderTypesAndEscapes) {
  Json j = Json::object();
  j.set("z", 1);
  j.set("a", 0.1);
  j.set("s", "quote \" backslash \\ newline \n tab \t bell \x07");
  j.set("n", nullptr);
  j.set("b", false);
  Json arr = Json::array();
  arr.push_back(2.0);
  arr.push_back("x");
  j.set("arr", arr);
  const std::string text = j.dump(2);
  const Json back = Json::parse(text);
  EXPECT_EQ(back.dump(), j.dump());
  EXPECT_EQ(back.as_object().front().first, "z");
  EXPECT_TRUE(back.at("z").as_int() == 1);
  EXPECT_DOUBLE_EQ(back.at("a").as_double(), 0.1);
  EXPECT_TRUE(back.at("arr").as_array()[0].is_number());
  EXPECT_EQ(
      j.dump(),
      R"({"z": 1, "a": 0.1, "s": "quote \" backslash \\ newline \n tab \t bell \u0007", "n": null, "b": false, "arr": [2.0, "x"]})");
}

TEST(Json, MalformedTextNamesTheOffset) {
  EXPECT_THROW(Json::parse("{\"a\": }"), std::runtime_error);
  try {
    Json::parse("[1, 2");
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("offset 5"), std::string::npos) << e.what();
  }
}

TEST(Json, AtomicWriteReplacesTheWholeFile) {
  const auto file = std::filesystem::temp_directory_path() /
                    ("projtour_atomic_" + std::to_string(::getpid()) + ".json");
  write_file_atomically(file, "first version, longer than the second\n");
  write_file_atomically(file, "second\n");
  std::ifstream in(file);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "second\n");
  EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp"));
  std::filesystem::remove(file);
}

TEST(Report, HoldsExactlyTheDesignFields) {
  RunSummary s;
  s.mission = "m";
  s.dry_run = true;
  s.seed = 4;
  s.outcome = TourOutcome::completed_with_skips;
  s.wall_s = 1.5;
  s.mission_s = 30.0;
  TargetRecord b;
  b.index = 1;
  b.id = "b";
  b.outcome = "skipped";
  b.reason = "unreachable";
  TargetRecord a;
  a.index = 0;
  a.id = "a";
  a.outcome = "projected";
  a.measurements.set("localization_error", Json(Json::Object{{"trans_m", 0.1}, {"rot_deg", 1.0}}));
  a.measurements.set("projected_s", 10.0);
  s.targets = {b, a};
  const Json r = build_report(s);
  std::vector<std::string> keys;
  for (const auto& kv : r.as_object()) keys.push_back(kv.first);
  EXPECT_EQ(keys, (std::vector<std::string>{"mission", "dry_run", "seed", "outcome", "timing",
                                            "targets"}));
  EXPECT_EQ(r.at("outcome").as_string(), "completed_with_skips");
  const auto& targets = r.at("targets").as_array();
  ASSERT_EQ(targets.size(), 2u);
  EXPECT_EQ(targets[0].at("id").as_string(), "a");  // mission order
  std::vector<std::string> a_keys;
  for (const auto& kv : targets[0].as_object()) a_keys.push_back(kv.first);
  EXPECT_EQ(a_keys, (std::vector<std::string>{"id", "outcome", "retries", "projected_s",
                                              "localization_error"}));
  EXPECT_EQ(targets[1].at("reason").as_string(), "unreachable");
  EXPECT_EQ(targets[1].find("projected_s"), nullptr);
}

}  // namespace
}  // namespace projtour
