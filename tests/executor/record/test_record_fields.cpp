// The target record's one definition of its fields (record_fields.hpp): the JSON text of a record
// with every field set, read back strictly, and the summary page's rows, which come from the
// same list and so show every field the record writes.
#include <gtest/gtest.h>

#include <string>

#include "projtour/formats/json_io.hpp"
#include "projtour/record/record_fields.hpp"
#include "projtour/record/target_record.hpp"
#include "projtour/views/summary_page.hpp"

namespace projtour {
namespace {

TargetRecord every_field() {
  TargetRecord r;
  r.id = "rabbit";
  r.outcome = "projected";
  r.reason = "shown twice";
  r.retries = 1;
  r.round = 2;
  r.content = "lunch.avi";
  r.content_index = 1;
  TargetMeasurements& m = r.measurements;
  m.projected_s = 8.0;
  m.beam_interruptions = 2;
  m.blanked_s = 1.5;
  m.align = AlignFigures{"icp", 1.25, 19, 0.75, 1.5};
  m.localization_error = LocalizationError{0.01, 0.02, std::nullopt, std::nullopt};
  m.target_pose_error = TargetPoseError{0.5, 0.25};
  m.projection_error_mm = BeforeAfter{7.0, 2.0};
  m.projection_error_px = BeforeAfter{9.0, 3.0};
  CalibrateResult c;
  c.adopted = true;
  c.decoded_blocks = 40;
  c.inliers = 38;
  c.rms_px = 0.5;
  c.change_mm = 3.0;
  c.change_deg = 0.125;
  c.sequence_s = 2.5;
  c.compute_ms = 12.0;
  m.calibration = c;
  m.observed_error_mm = 2.5;
  m.observed_light_on_target = 0.875;
  m.projection_error_area_mm = AreaError{2.25, 4.5};
  m.light_off_target_fraction = 0.0625;
  m.planned_path_m = 12.25;
  return r;
}

// The order and text report.json and checkpoint.json have always had, every field present.
const char* const kEveryFieldText =
    R"({"id": "rabbit", "outcome": "projected", "reason": "shown twice", "retries": 1, )"
    R"("round": 2, "content": "lunch.avi", "content_index": 1, "projected_s": 8.0, )"
    R"("beam_interruptions": 2, "blanked_s": 1.5, "align": {"method": "icp", "time_ms": 1.25, )"
    R"("iterations": 19, "inlier_fraction": 0.75, "rmse_mm": 1.5}, )"
    R"("localization_error": {"trans_m": 0.01, "rot_deg": 0.02}, )"
    R"("target_pose_error": {"trans_mm": 0.5, "rot_deg": 0.25}, )"
    R"("projection_error_mm": {"before_align": 7.0, "after_align": 2.0}, )"
    R"("projection_error_px": {"before_align": 9.0, "after_align": 3.0}, )"
    R"("observed_error_mm": 2.5, "observed_light_on_target": 0.875, )"
    R"("projection_error_area_mm": {"mean": 2.25, "max": 4.5}, )"
    R"("light_off_target_fraction": 0.0625, "calibration": {"adopted": true, )"
    R"("decoded_blocks": 40, "inliers": 38, "rms_px": 0.5, "change_mm": 3.0, )"
    R"("change_deg": 0.125, "sequence_s": 2.5, "time_ms": 12.0}, "planned_path_m": 12.25})";

TEST(RecordFields, EveryFieldWrittenInItsOrderAndReadBack) {
  const std::string text = dump_json(Json(every_field()));
  EXPECT_EQ(text, kEveryFieldText);
  const TargetRecord back = parse_json(text, "record").get<TargetRecord>();
  EXPECT_EQ(dump_json(Json(back)), text);
  EXPECT_EQ(back.content_index, 1);
  ASSERT_TRUE(back.measurements.calibration.has_value());
  EXPECT_EQ(back.measurements.calibration->compute_ms, 12.0);
  EXPECT_EQ(back.measurements.beam_interruptions, 2);
  EXPECT_EQ(back.measurements.planned_path_m, 12.25);
}

// Reading a record into one that held another leaves nothing of the first.
TEST(RecordFields, ReadingReplacesEveryField) {
  TargetRecord r = every_field();
  from_json(parse_json(R"({"id": "a", "outcome": "skipped", "retries": 0})", "record"), r);
  EXPECT_EQ(dump_json(Json(r)), R"({"id": "a", "outcome": "skipped", "retries": 0})");
  EXPECT_EQ(r.round, 0);
  EXPECT_EQ(r.content_index, 0);
  EXPECT_FALSE(r.measurements.calibration.has_value());
}

TEST(RecordFields, ContentIndexComesWithItsContent) {
  const auto error = [](const std::string& text) -> std::string {
    try {
      parse_json(text, "record").get<TargetRecord>();
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  };
  const std::string head = R"({"id": "a", "outcome": "projected", "retries": 0, )";
  EXPECT_EQ(error(head + R"("content": "x.avi"})"), "\"content_index\" is missing");
  EXPECT_EQ(error(head + R"("content": "x.avi", "content_index": 0.5})"),
            "\"content_index\" is not an integer");
  EXPECT_EQ(error(head + R"("content": "x.avi", "content_index": 3})"), "");
  EXPECT_EQ(error(head + R"("reason": 3})"), "\"reason\" is not a string but number");
  EXPECT_EQ(error(head + R"("calibration": {"adopted": 1}})"),
            "calibration: adopted: expected true or false");
  EXPECT_EQ(error(head + R"("projection_error_area_mm": {"mean": 1, "max": 2, "min": 0}})"),
            "projection_error_area_mm: unknown field \"min\"");
}

// The rows of a target on the summary page, "label|value" in order.
std::vector<std::string> figure_rows(const Json& target) {
  Json report = Json::object();
  report["targets"] = Json::array({target});
  const std::string html = render_summary_page(SummaryInput{report}, "/nonexistent");
  const std::string open = "<table class=\"figures\">\n";
  std::size_t at = html.find(open);
  EXPECT_NE(at, std::string::npos) << html;
  at += open.size();
  std::vector<std::string> rows;
  for (std::size_t end; (end = html.find("</td></tr>\n", at)) != std::string::npos; at = end + 11) {
    const std::string row = html.substr(at, end - at);
    if (row.rfind("<tr><th>", 0) != 0) break;
    const std::size_t th_end = row.find("</th><td>");
    rows.push_back(row.substr(8, th_end - 8) + "|" + row.substr(th_end + 9));
  }
  return rows;
}

TEST(RecordFields, SummaryPageShowsEveryFieldTheRecordWrites) {
  Json target = Json(every_field());
  target["colour"] = Json{{"r", 1}};  // a field this version does not know: shown as it is
  const std::vector<std::string> rows = figure_rows(target);
  const std::vector<std::string> expected = {
      "outcome|<span class=\"badge\" style=\"background:#00aa00\">projected</span>",
      "reason|shown twice",
      "retries|1",
      "round|2",
      "content|lunch.avi",
      "content index|1",
      "projected for|8.0 s",
      "beam guard|2 interruptions, blanked 1.5 s",
      "alignment|icp &middot; 1.2 ms &middot; 19 iterations &middot; inlier fraction 0.750 "
      "&middot; 1.50 mm RMSE",
      "localization error|0.010 m &middot; 0.02&deg;",
      "target pose error|0.5 mm &middot; 0.25&deg;",
      "projection error before alignment|7.0 mm &middot; 9.0 px",
      "projection error after alignment|2.0 mm &middot; 3.0 px",
      "observed error (colour camera)|2.5 mm &middot; 2.0 mm true (referee)",
      "light on the target (observed)|87.5 %",
      "projection error over the content area|2.2 mm mean &middot; 4.5 mm worst",
      "light off the target (referee)|6.2 %",
      "projector calibration|adopted: yes &middot; 40 blocks decoded &middot; 38 inliers "
      "&middot; 0.50 px RMS &middot; change 3.0 mm &middot; change 0.12&deg; &middot; "
      "sequence 2.5 s &middot; 12.0 ms",
      "planned path|12.2 m",
      "colour.r|1"};
  EXPECT_EQ(rows, expected);
}

// The terminal's table and the page's overview show the same figures, from one list.
TEST(RecordFields, OverviewColumnsNameFieldsOfTheRecord) {
  const Json j = Json(every_field());
  for (const OverviewColumn& c : kOverviewColumns) {
    ASSERT_TRUE(j.contains(c.key)) << c.key;
    const Json& v = c.sub_key != nullptr ? j.at(c.key).at(c.sub_key) : j.at(c.key);
    EXPECT_TRUE(v.is_number()) << c.key;
  }
}

}  // namespace
}  // namespace projtour
