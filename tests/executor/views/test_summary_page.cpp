#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "projtour/run/atomic_file.hpp"
#include "projtour/views/summary_page.hpp"
#include "projtour_test/chromium.hpp"
#include "projtour_test/process.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

namespace fs = std::filesystem;

void write_png(const fs::path& file, const cv::Scalar& colour) {
  fs::create_directories(file.parent_path());
  ASSERT_TRUE(cv::imwrite(file.string(), cv::Mat(60, 80, CV_8UC3, colour)));
}

Json make_report() {
  Json align = Json::object();
  align["method"] = "icp_point_to_plane";
  align["time_ms"] = 45.23;
  align["iterations"] = 31;
  align["inlier_fraction"] = 0.9531;
  align["rmse_mm"] = 1.214;
  Json loc = Json::object();
  loc["trans_m"] = 0.0312;
  loc["rot_deg"] = 0.81;
  Json pose_err = Json::object();
  pose_err["trans_mm"] = 4.12;
  pose_err["rot_deg"] = 0.33;
  Json mm = Json::object();
  mm["before_align"] = 25.34;
  mm["after_align"] = 1.26;
  Json px = Json::object();
  px["before_align"] = 31.02;
  px["after_align"] = 1.54;

  Json rabbit = Json::object();
  rabbit["id"] = "rabbit";
  rabbit["outcome"] = "projected";
  rabbit["retries"] = 1;
  rabbit["projected_s"] = 10.0;
  rabbit["align"] = align;
  rabbit["localization_error"] = loc;
  rabbit["target_pose_error"] = pose_err;
  rabbit["projection_error_mm"] = mm;
  rabbit["projection_error_px"] = px;

  Json pillar = Json::object();
  pillar["id"] = "pillar #2";  // needs URL encoding in the picture paths
  pillar["outcome"] = "skipped";
  pillar["reason"] = "align: poor_fit after 3 retries <inlier fraction 0.21>";
  pillar["retries"] = 3;

  Json report = Json::object();
  report["mission"] = "visuals-test";
  report["dry_run"] = true;
  report["seed"] = 42;
  report["outcome"] = "completed_with_skips";
  Json timing = Json::object();
  timing["wall_s"] = 12.5;
  timing["mission_s"] = 187.25;
  report["timing"] = timing;
  Json targets = Json::array();
  targets.push_back(rabbit);
  targets.push_back(pillar);
  report["targets"] = targets;
  return report;
}

// A run directory as the executor leaves it: report.json, tour.png, all four pictures for the
// projected target and only the alignment picture for the skipped one.
class SummaryPageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    write_file_atomically(run_dir_ / "report.json", dump_json(make_report(), 2));
    write_png(run_dir_ / "tour.png", {255, 255, 255});
    for (const char* name : {"alignment.png", "projector.png", "before.png", "after.png"}) {
      write_png(run_dir_ / "targets" / "rabbit" / name, {0, 128, 255});
    }
    write_png(run_dir_ / "targets" / "pillar #2" / "alignment.png", {255, 0, 0});
  }

  std::string write_page() {
    write_summary_page(read_summary_input(run_dir_), run_dir_);
    std::ifstream in(run_dir_ / "summary.html");
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

  test::TempDir scratch_;
  const fs::path run_dir_ = scratch_.path();
};

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

TEST_F(SummaryPageTest, ShowsTheRunAndEveryTargetsFigures) {
  const std::string html = write_page();
  for (const char* expected :
       {"<h1>visuals-test</h1>", "completed_with_skips", "<td>42</td>", "3 min 07 s", "12.5 s",
        "1 of 2", "median 1.3 mm, worst 1.3 mm over 1 target", "icp_point_to_plane", "45.2 ms",
        "31 iterations", "inlier fraction 0.953", "1.21 mm RMSE", "0.031 m", "0.81&deg;", "4.1 mm",
        "25.3 mm &middot; 31.0 px", "1.3 mm &middot; 1.5 px", "projected for", "10.0 s",
        // Report text is escaped, never markup.
        "align: poor_fit after 3 retries &lt;inlier fraction 0.21&gt;", "pillar #2"}) {
    EXPECT_TRUE(contains(html, expected)) << "missing: " << expected;
  }
  EXPECT_FALSE(contains(html, "<inlier")) << "unescaped report text";
}

TEST_F(SummaryPageTest, LinksOnlyThePicturesOnDiskByRelativePath) {
  const std::string html = write_page();
  EXPECT_TRUE(contains(html, "src=\"tour.png\""));
  for (const char* name : {"alignment.png", "projector.png", "before.png", "after.png"}) {
    EXPECT_TRUE(contains(html, std::string("src=\"targets/rabbit/") + name + "\"")) << name;
  }
  EXPECT_TRUE(contains(html, "src=\"targets/pillar%20%232/alignment.png\""));
  EXPECT_FALSE(contains(html, "pillar%20%232/projector.png"));
  EXPECT_FALSE(contains(html, run_dir_.string())) << "the page must move with its directory";
  EXPECT_FALSE(contains(html, "http")) << "no network";
}

TEST_F(SummaryPageTest, UnreadableReportNamesTheFile) {
  std::ofstream(run_dir_ / "report.json") << "{\"mission\": ";
  try {
    read_summary_input(run_dir_);
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& e) {
    EXPECT_TRUE(contains(e.what(), (run_dir_ / "report.json").string())) << e.what();
  }
  EXPECT_THROW(read_summary_input(run_dir_ / "nowhere"), std::runtime_error);
}

TEST_F(SummaryPageTest, SparseReportStillRenders) {
  // An aborted run may have no targets and no timing: the page says what it knows.
  Json report = Json::object();
  report["mission"] = "aborted-run";
  report["outcome"] = "aborted";
  fs::remove(run_dir_ / "tour.png");
  const std::string html = render_summary_page(SummaryInput{report}, run_dir_);
  EXPECT_TRUE(contains(html, "aborted-run"));
  EXPECT_TRUE(contains(html, "0 of 0"));
  EXPECT_FALSE(contains(html, "<img"));
}

// A schedule's report: a table per round in the report's order, one section per visit with
// its own anchor, the content item shown and the targets passed over with their reason.
TEST_F(SummaryPageTest, GroupsAScheduledRunByRound) {
  Json report = Json::object();
  report["mission"] = "all-day";
  report["outcome"] = "completed";
  Json targets = Json::array();
  auto visit = [&](int round, const std::string& id, const std::string& outcome,
                   const std::string& content) {
    Json t = Json::object();
    t["id"] = id;
    t["outcome"] = outcome;
    t["retries"] = 0;
    t["round"] = round;
    if (outcome != "projected") t["reason"] = "outside its hours (11:30-14:00) at 09:01:10";
    if (!content.empty()) {
      t["content"] = content;
      t["content_index"] = 0;
    }
    targets.push_back(t);
  };
  visit(1, "sign", "projected", "");
  visit(1, "cafe", "outside_hours", "");
  visit(2, "sign", "projected", "");
  visit(2, "cafe", "projected", "lunch.avi");
  report["targets"] = targets;
  const std::string html = render_summary_page(SummaryInput{report}, run_dir_);
  const auto round1 = html.find("<h3 id=\"round-1\">Round 1: 1 of 2 projected</h3>");
  const auto round2 = html.find("<h3 id=\"round-2\">Round 2: 2 of 2 projected</h3>");
  ASSERT_NE(round1, std::string::npos) << html;
  ASSERT_NE(round2, std::string::npos);
  EXPECT_LT(round1, round2);
  EXPECT_TRUE(contains(html, "3 of 4 in 2 rounds"));
  EXPECT_TRUE(contains(html, "outside its hours (11:30-14:00) at 09:01:10"));
  EXPECT_TRUE(contains(html, "href=\"#target-cafe-round-2\">cafe (lunch.avi)</a>"));
  for (const char* section : {"target-sign-round-1", "target-cafe-round-1", "target-sign-round-2",
                              "target-cafe-round-2"}) {
    EXPECT_TRUE(contains(html, std::string("<section id=\"") + section + "\">")) << section;
  }
}

// --- in a real browser -----------------------------------------------------------------------

using test::chromium_command;

// Opens the page in headless Chromium and reads each <img>'s data-loaded from the final DOM.
std::vector<test::LoadedImage> load_in_chromium(const fs::path& html, const fs::path& scratch) {
  return test::images_of(test::dom_in_chromium(html, scratch));
}

TEST_F(SummaryPageTest, EveryImageLoadsInHeadlessChromium) {
  if (chromium_command().empty())
    GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  write_page();
  const auto images = load_in_chromium(run_dir_ / "summary.html", run_dir_);
  ASSERT_EQ(images.size(), 6u) << "tour.png, four rabbit pictures, one pillar picture";
  for (const auto& image : images) EXPECT_EQ(image.loaded, "1") << image.src;
}

TEST_F(SummaryPageTest, HeadlessChromiumCheckDetectsBrokenImages) {
  if (chromium_command().empty())
    GTEST_SKIP() << "chromium is not installed (apt-get install chromium)";
  write_page();
  // After the page was written: one picture disappears, another is not a PNG any more.
  fs::remove(run_dir_ / "targets" / "rabbit" / "before.png");
  std::ofstream(run_dir_ / "targets" / "rabbit" / "after.png", std::ios::trunc) << "not a png";
  const auto images = load_in_chromium(run_dir_ / "summary.html", run_dir_);
  ASSERT_EQ(images.size(), 6u);
  std::vector<std::string> broken;
  for (const auto& image : images) {
    if (image.loaded != "1") broken.push_back(image.src);
  }
  EXPECT_EQ(broken,
            (std::vector<std::string>{"targets/rabbit/before.png", "targets/rabbit/after.png"}));
}

}  // namespace
}  // namespace projtour
