// The mission's all-day fields: schedule (rounds, until, start, pause_s), and each target's
// hours windows and content list with its rotation; every bad value at its line and column.
#include "projtour/host/mission_loader.hpp"
#include "projtour_test/loader_fixture.hpp"

namespace projtour::test {
namespace {

using ::testing::ElementsAre;

class MissionSchedule : public LoaderTest {
 protected:
  // kMission with a schedule line before `machine:` (line 18) and the rabbit's content line
  // (line 10) replaced by `content`.
  std::string with(const std::string& schedule, const std::string& content = "content: sale.png") {
    std::string text = replace(kMission, "machine: default", schedule + "\nmachine: default");
    return replace(text, "content: sale.png\n    standoff_m", content + "\n    standoff_m");
  }
};

TEST_F(MissionSchedule, WithoutScheduleOnePassUnnumbered) {
  host::Diagnostics diag;
  const auto mission = host::load_mission(write("m.yaml", kMission), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_FALSE(mission->schedule.written);
  EXPECT_FALSE(mission->schedule.rounds);
  EXPECT_FALSE(mission->schedule.until_s);
  ASSERT_EQ(mission->target_times.size(), 2u);
  for (const auto& t : mission->target_times) {
    EXPECT_EQ(t.content, std::vector<std::filesystem::path>{dir_path / "sale.png"});
    EXPECT_TRUE(t.hours.empty());
    EXPECT_FALSE(t.per_round);
  }
}

TEST_F(MissionSchedule, AllFieldsLoad) {
  write("menu.mp4", "not decoded by the loader");
  host::Diagnostics diag;
  const auto mission = host::load_mission(
      write("m.yaml",
            with("schedule: {rounds: 3, start: \"09:30\", until: \"17:00:30\", pause_s: 600}",
                 "content: [sale.png, menu.mp4]\n    rotate: per_round\n"
                 "    hours: [\"11:30-14:00\", \"18:00-24:00\"]")),
      diag);
  ASSERT_TRUE(mission) << diag.format();
  const auto& s = mission->schedule;
  EXPECT_TRUE(s.written);
  EXPECT_EQ(s.rounds, 3);
  EXPECT_EQ(s.start_s, 9 * 3600 + 30 * 60);
  EXPECT_EQ(s.until_s, 17 * 3600 + 30);
  EXPECT_DOUBLE_EQ(s.pause_s, 600.0);
  const host::TargetTimes& rabbit = mission->target_times[0];
  EXPECT_EQ(rabbit.content,
            (std::vector<std::filesystem::path>{dir_path / "sale.png", dir_path / "menu.mp4"}));
  EXPECT_EQ(mission->targets[0].content, dir_path / "sale.png");  // the first item
  EXPECT_TRUE(rabbit.per_round);
  ASSERT_EQ(rabbit.hours.size(), 2u);
  EXPECT_EQ(rabbit.hours[0].begin_s, 11 * 3600 + 30 * 60);
  EXPECT_EQ(rabbit.hours[0].end_s, 14 * 3600);
  EXPECT_EQ(rabbit.hours[1].end_s, 24 * 3600);
  EXPECT_EQ(mission->marks.at("targets[0].content[1]").line, 10);
}

TEST_F(MissionSchedule, UntilAloneDefaultsStartToNine) {
  host::Diagnostics diag;
  const auto mission =
      host::load_mission(write("m.yaml", with("schedule: {until: \"18:00\"}")), diag);
  ASSERT_TRUE(mission) << diag.format();
  EXPECT_FALSE(mission->schedule.rounds);
  EXPECT_EQ(mission->schedule.start_s, 9 * 3600);
  EXPECT_DOUBLE_EQ(mission->schedule.pause_s, 0.0);
}

TEST_F(MissionSchedule, ScheduleErrorsAtTheirValues) {
  const std::string m = dir + "/m.yaml:";
  EXPECT_THAT(mission_errors(with("schedule: {rounds: 0}")),
              ElementsAre(m + "18:20: schedule.rounds: expected an integer > 0, got 0"));
  EXPECT_THAT(
      mission_errors(with("schedule: {rounds: 10001}")),
      ElementsAre(m + "18:20: schedule.rounds: expected an integer > 0 and at most 10000, got "
                      "10001"));
  EXPECT_THAT(mission_errors(with("schedule: {until: \"25:00\"}")),
              ElementsAre(m + "18:19: schedule.until: expected a time of day \"HH:MM\" or "
                              "\"HH:MM:SS\" from 00:00 to 24:00, got \"25:00\""));
  EXPECT_THAT(mission_errors(with("schedule: {rounds: 2, start: 9am}")),
              ElementsAre(m + "18:30: schedule.start: expected a time of day \"HH:MM\" or "
                              "\"HH:MM:SS\" from 00:00 to 24:00, got \"9am\""));
  EXPECT_THAT(mission_errors(with("schedule: {rounds: 2, pause_s: -1}")),
              ElementsAre(m + "18:32: schedule.pause_s: expected a number >= 0, got -1"));
  EXPECT_THAT(mission_errors(with("schedule: {rounds: 2, pause_s: 90000}")),
              ElementsAre(m + "18:32: schedule.pause_s: expected a number >= 0 and at most "
                              "86400, got 90000"));
  EXPECT_THAT(mission_errors(with("schedule: {pause_s: 60}")),
              ElementsAre(m + "18:11: schedule: expected rounds (how many passes) or until (a "
                              "time of day), or both"));
  EXPECT_THAT(mission_errors(with("schedule: {start: \"18:00\", until: \"17:00\"}")),
              ElementsAre(m + "18:35: schedule.until: expected a time after start (18:00): a "
                              "schedule does not cross midnight"));
  EXPECT_THAT(mission_errors(with("schedule: 3")),
              ElementsAre(m + "18:11: schedule: expected a mapping, got \"3\""));
}

TEST_F(MissionSchedule, MisspeltScheduleKey) {
  const auto errors = mission_errors(with("schedule: {round: 2, until: \"18:00\"}"));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].rfind(dir + "/m.yaml:18:12: schedule.round: unknown key", 0), 0u)
      << errors[0];
}

TEST_F(MissionSchedule, HoursErrorsAtTheWindow) {
  const std::string m = dir + "/m.yaml:";
  EXPECT_THAT(mission_errors(with("",
                                  "content: sale.png\n    hours: [\"11:30-14:00\", "
                                  "\"14:00-11:30\"]")),
              ElementsAre(m + "11:28: targets[0].hours[1]: expected a window that ends after it "
                              "begins (one day, not across midnight), got \"14:00-11:30\""));
  EXPECT_THAT(mission_errors(with("", "content: sale.png\n    hours: [\"noon\"]")),
              ElementsAre(m + "11:13: targets[0].hours[0]: expected a window \"HH:MM-HH:MM\" of "
                              "times from 00:00 to 24:00, got \"noon\""));
  EXPECT_THAT(mission_errors(with("", "content: sale.png\n    hours: []")),
              ElementsAre(m + "11:12: targets[0].hours: expected 1 to 24 windows "
                              "\"HH:MM-HH:MM\", got 0"));
  EXPECT_THAT(mission_errors(with("", "content: sale.png\n    hours: \"11:30-14:00\"")),
              ElementsAre(m + "11:12: targets[0].hours: expected a list, got \"11:30-14:00\""));
}

TEST_F(MissionSchedule, ContentListErrorsAtTheItem) {
  const std::string m = dir + "/m.yaml:";
  EXPECT_THAT(mission_errors(with("", "content: []")),
              ElementsAre(m + "10:14: targets[0].content: expected 1 to 64 images or videos, "
                              "got 0"));
  EXPECT_THAT(mission_errors(with("", "content: [sale.png, menu.txt]")),
              ElementsAre(m + "10:25: targets[0].content[1]: expected an image or a video (.png, "
                              ".jpg, .jpeg, .bmp, .mp4, .avi, .mkv or .webm), got \"menu.txt\""));
  EXPECT_THAT(mission_errors(with("", "content: sale.png\n    rotate: hourly")),
              ElementsAre(m + "11:13: targets[0].rotate: expected one of per_visit, per_round, "
                              "got \"hourly\""));
}

}  // namespace
}  // namespace projtour::test
