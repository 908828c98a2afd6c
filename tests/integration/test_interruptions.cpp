// Interruptions (issue 8, item 2): dry runs of the integration tour are sent SIGINT at moments
// spread over every step, then resumed with --resume on the same --out. Over the two runs every
// target is projected exactly once, the exit statuses are 130 then 0 (or 3 with a reason), and no
// file of the run directory is ever truncated or unparsable.
//
// The moments do not depend on how fast the machine is: the child stops itself (SIGSTOP, from a
// preloaded shim of the support library, the program unchanged) right after it writes a chosen
// events.jsonl line, or right after it installs its SIGINT handler. The test then sends the real
// SIGINT and continues the child, so the handler runs before the child does anything more: a
// stop right after "enter tour/visit/capture" cancels capture, on any machine.
#include <signal.h>

#include <atomic>
#include <cstdio>
#include <map>
#include <random>
#include <thread>

#include "run_fixture.hpp"

namespace projtour::integration {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// Moments interrupted at once: CI's two cores. A child is mostly busy computing, so more would
// only share the same cores.
constexpr int kWorkers = 2;

const std::vector<std::string> kTargets = {"rabbit", "open-day-sign"};
const std::vector<std::string> kSteps = {"navigate",  "aim",    "capture", "align",
                                         "calibrate", "verify", "project", "next"};

// When to send SIGINT: right after the child writes the first line containing `marker` (a piece
// of one events.jsonl line), or, without a marker, right after it installs its SIGINT handler.
struct KillMoment {
  std::string what;
  std::optional<std::string> marker;

  static KillMoment entering(const std::string& step, std::size_t target_index) {
    return {"entering " + step + " of " + kTargets[target_index],
            R"("event": "enter", "state": "tour/visit/)" + step + R"(", "target": ")" +
                kTargets[target_index] + "\""};
  }
  // Between a step's outcome and the transition that follows it.
  static KillMoment after_outcome(const std::string& step, std::size_t target_index) {
    return {"after the outcome of " + step + " of " + kTargets[target_index],
            R"("event": "outcome", "state": "tour/visit/)" + step + R"(", "target": ")" +
                kTargets[target_index] + "\""};
  }
  // Right after one event of the uninterrupted run (the same seed gives the same lines; the
  // marker is the line as events.jsonl has it, so dump_json, not nlohmann's dump()).
  static KillMoment at_event(const Json& event) {
    return {"after event " + dump_json(event), dump_json(event)};
  }
};

// The step a cancel ended ("" when the SIGINT came between steps or the run was over).
std::string cancelled_step(const std::vector<Json>& events) {
  for (auto it = events.rbegin(); it != events.rend(); ++it) {
    if (it->at("event").get<std::string>() == "outcome" &&
        it->at("outcome").get<std::string>() == "cancelled") {
      const std::string& state = it->at("state").get<std::string>();
      return state.substr(state.rfind('/') + 1);
    }
  }
  return "";
}

class Interruptions : public DryRunTest {
 protected:
  // Every file a reader may open mid-run must parse whenever it is there; events.jsonl up to
  // its last newline (the writer may be in the middle of the next line).
  void expect_files_whole(const fs::path& run, const std::string& when) {
    try {
      if (fs::exists(run / "checkpoint.json")) read_json(run / "checkpoint.json");
      if (fs::exists(run / "report.json")) read_json(run / "report.json");
      if (fs::exists(run / "events.jsonl")) test::read_jsonl_complete_lines(run / "events.jsonl");
    } catch (const std::exception& e) {
      ADD_FAILURE() << when << ": " << e.what();
    }
  }

  // Interrupts one run at `k`, then resumes it; returns the step the cancel ended.
  std::string interrupt_and_resume(const KillMoment& k, int index) {
    const std::string name = "kill" + std::to_string(index);
    const fs::path run = dir_ / name;
    const fs::path mission = data_dir() / "short_tour.yaml";
    const fs::path world = data_dir() / "nominal_world.yaml";
    const std::string when = name + " (" + k.what + ")";
    // The history database of this moment's two runs alone: moments run side by side.
    const fs::path history_home = dir_ / (name + "-xdg-data");

    std::optional<int> first_exit;
    {
      test::ChildOptions options =
          test::projtour_command(dry_run_args(mission, world, run), dir_ / (name + "a"));
      options.env["XDG_DATA_HOME"] = history_home.string();
      if (k.marker) {
        options.stop_after_write = *k.marker;
      } else {
        options.stop_after_handler_for = SIGINT;
      }
      Child child(options);
      const bool stopped =
          child.wait_stopped(60s, [&] { expect_files_whole(run, when + " while running"); });
      if (stopped) {
        expect_files_whole(run, when + " while stopped");
        child.signal(SIGINT);
        child.resume();
      } else if (!child.poll()) {
        ADD_FAILURE() << when << ": never reached the moment";
      }
      first_exit = child.wait(60s);
    }
    const std::string err1 = read_text(dir_ / (name + "a.stderr"));
    if (*first_exit < 0) {
      ADD_FAILURE() << when << ": the process was killed by signal " << -*first_exit
                    << " instead of stopping safely with exit status 130; run directory holds "
                    << (fs::exists(run / "checkpoint.json") ? "a" : "no") << " checkpoint\n"
                    << err1;
      return "(killed)";
    }
    // A moment after the end of the tour is not an interruption: the run must have completed.
    if (*first_exit != 130) {
      EXPECT_EQ(*first_exit, 0) << when << "\n" << err1;
      return "(finished)";
    }

    // After the kill: every file whole, the report says interrupted, the projector safe.
    std::vector<Json> events1;
    std::size_t log_lines1 = 0;
    try {
      const Json report = read_json(run / "report.json");
      EXPECT_EQ(report.at("outcome").get<std::string>(), "interrupted") << when;
      const Json checkpoint = read_json(run / "checkpoint.json");
      EXPECT_LE(checkpoint.at("done").size(), kTargets.size()) << when;
      events1 = read_jsonl(run / "events.jsonl");
      log_lines1 = read_jsonl(run / "sim_projector_log.jsonl").size();
      for (const auto& p : projector_safety_problems(run, events1)) {
        ADD_FAILURE() << when << ": " << p;
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << when << ": " << e.what() << "\n" << err1;
      return "";
    }
    const std::string step = cancelled_step(events1);

    test::ChildOptions resume = test::projtour_command(
        dry_run_args(mission, world, run, {"--resume"}), dir_ / (name + "b"));
    resume.env["XDG_DATA_HOME"] = history_home.string();
    const int second_exit = test::run(resume, 120s).status;
    const std::string err2 = read_text(dir_ / (name + "b.stderr"));
    EXPECT_TRUE(second_exit == 0 || second_exit == 3)
        << when << ": resume exit " << second_exit << "\n"
        << err2;
    try {
      const std::vector<Json> events = read_jsonl(run / "events.jsonl");
      EXPECT_GT(events.size(), events1.size()) << when;
      const std::vector<Json> events2(events.begin() + events1.size(), events.end());
      for (const auto& p : projector_safety_problems(run, events2, log_lines1)) {
        ADD_FAILURE() << when << " (resumed): " << p;
      }
      const Json report = read_json(run / "report.json");
      read_json(run / "checkpoint.json");
      const auto& records = report.at("targets");
      EXPECT_EQ(records.size(), kTargets.size()) << when << ": " << dump_json(report, 2);
      for (const std::string& id : kTargets) {
        int projected = 0;
        for (const StepOutcome& s : step_outcomes(events, id)) {
          projected += s.step == "project" && s.outcome == "succeeded";
        }
        const Json& record = report_target(report, id);
        if (record.at("outcome").get<std::string>() == "projected") {
          EXPECT_EQ(projected, 1) << when << ": " << id << " projected " << projected
                                  << " times over the two runs";
        } else {
          EXPECT_EQ(second_exit, 3) << when;
          EXPECT_EQ(record.at("outcome").get<std::string>(), "skipped") << when;
          EXPECT_FALSE(record.at("reason").get<std::string>().empty()) << when;
          EXPECT_LE(projected, 1) << when << ": " << id;
        }
      }
      EXPECT_EQ(report.at("outcome").get<std::string>(),
                second_exit == 0 ? "completed" : "completed_with_skips")
          << when;
    } catch (const std::exception& e) {
      ADD_FAILURE() << when << " (resumed): " << e.what() << "\n" << err2;
    }
    return step;
  }
};

TEST_F(Interruptions, SigintAnywhereThenResumeProjectsEveryTargetOnce) {
  const auto started = Clock::now();
  // An uninterrupted run first: it completes, and its events are the random moments' menu.
  const DryRunResult whole = dry_run("nominal_world.yaml", "whole");
  ASSERT_EQ(whole.exit_code, 0) << whole.err;

  std::vector<KillMoment> moments;
  for (const std::string& step : kSteps) {
    moments.push_back(KillMoment::entering(step, 0));
    moments.push_back(KillMoment::entering(step, 1));
    moments.push_back(KillMoment::after_outcome(step, 0));
  }
  // Any event before the last visit ends (a SIGINT after the tour is its own test below).
  std::size_t last_visit_exit = 0;
  for (std::size_t i = 0; i < whole.events.size(); ++i) {
    if (whole.events[i].at("state").get<std::string>() == "tour/visit") last_visit_exit = i;
  }
  ASSERT_GT(last_visit_exit, 10u);
  std::mt19937 rng(20240611);
  std::uniform_int_distribution<std::size_t> random_event(1, last_visit_exit - 1);
  for (int i = 0; i < 8; ++i) {
    moments.push_back(KillMoment::at_event(whole.events[random_event(rng)]));
  }

  // Each moment is a run of its own in a directory of its own, so the moments run side by side:
  // kWorkers at a time, each worker taking the next moment not yet taken. GoogleTest's
  // assertions may fail in any thread; the children are waited for by pid.
  std::vector<std::string> steps(moments.size());
  std::atomic<std::size_t> next_moment{0};
  const auto work = [&] {
    for (std::size_t i = next_moment++; i < moments.size(); i = next_moment++) {
      steps[i] = interrupt_and_resume(moments[i], static_cast<int>(i));
    }
  };
  std::vector<std::thread> workers;
  for (int w = 0; w < kWorkers; ++w) workers.emplace_back(work);
  for (std::thread& worker : workers) worker.join();

  std::map<std::string, int> cancelled_in;
  int interrupted = 0;
  for (const std::string& step : steps) {
    if (step != "(finished)" && step != "(killed)") ++interrupted;
    ++cancelled_in[step.empty() ? "(between steps)" : step];
  }
  std::string spread;
  for (const auto& [step, n] : cancelled_in) spread += step + "=" + std::to_string(n) + " ";
  const double wall_s = std::chrono::duration<double>(Clock::now() - started).count();
  RecordProperty("cancelled_in", spread);
  RecordProperty("wall_s", std::to_string(wall_s));
  std::printf("%d interruptions in %.1f s; the cancel ended: %s\n", interrupted, wall_s,
              spread.c_str());
  EXPECT_GE(interrupted, 20) << spread;
  for (const std::string& step : kSteps) {
    EXPECT_GE(cancelled_in[step], 1) << "no SIGINT landed in " << step << ": " << spread;
  }
}

// Before the tour starts (plugins, map and models still loading) nothing has moved: a SIGINT
// then must still end the run as an interruption that --resume can continue.
TEST_F(Interruptions, SigintWhileLoadingExits130AndResumes) {
  const KillMoment loading{"as soon as the run catches SIGINT", {}};
  const std::string step = interrupt_and_resume(loading, 0);
  EXPECT_EQ(step, "") << "no step can have run before the tour started";
}

// After the tour's last event the run is writing its report and pictures: a SIGINT then must
// not turn a finished tour into a process killed by a signal.
TEST_F(Interruptions, SigintAfterTheTourEndedStillExitsCleanly) {
  const std::string step =
      interrupt_and_resume({"right after the tour's last event",
                            std::string(R"("state": "tour", "target": null, "outcome": "done")")},
                           0);
  EXPECT_TRUE(step == "(finished)" || step == "") << step;
}

}  // namespace
}  // namespace projtour::integration
