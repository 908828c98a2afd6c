#pragma once
// The Command fixture of the projtour command's end-to-end tests (test_command.cpp,
// test_command_run_dir.cpp): a scratch directory, a scripted mission written into it, and the
// command as a child with the build's plugins.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "projtour_test/process.hpp"
#include "projtour_test/run_files.hpp"
#include "projtour_test/temp_dir.hpp"

// A named namespace, not an anonymous one: both files' TEST_F(Command, ...) must derive from
// one fixture class, which GoogleTest checks.
namespace projtour::command_test {

namespace fs = std::filesystem;

inline const std::string kSource = PROJTOUR_SOURCE_DIR;
inline const std::string kPluginPath = test::plugin_build_dir().string();

// "" for a file not written (yet): a missing file shows in the assertion on its contents.
inline std::string read_text(const fs::path& file) {
  return test::read_text_if_exists(file);
}
using test::read_jsonl;

class Command : public ::testing::Test {
 protected:
  // A three-target mission in the test hall with `machine` (YAML under "machine:").
  fs::path write_mission(const std::string& machine, const std::string& name = "mission.yaml") {
    const std::string data = kSource + "/tests/executor/data/";
    std::ostringstream m;
    m << "mission: cmd-test\n"
      << "map: " << data << "hall.yaml\n"
      << "robot: " << data << "robot_null.yaml\n"
      << "start: {x: 1.0, y: 1.0, yaw_deg: 0}\n"
      << "targets:\n";
    const char* ids[] = {"rabbit", "pillar", "sign"};
    for (int i = 0; i < 3; ++i) {
      m << "  - id: " << ids[i] << "\n"
        << "    model: " << kSource << "/examples/models/bunny.ply\n"
        << "    pose: {x: " << 3 + 3 * i << ".0, y: 7.0, z: 0.9, yaw_deg: -90}\n"
        << "    model_points: [[0.1165, -0.0044, 0.0911], [0.1230, 0.0374, 0.0884], "
           "[0.1250, 0.0410, 0.0476], [0.1259, -0.0009, 0.0539]]\n"
        << "    content: " << data << "content.png\n";
    }
    m << "machine:\n" << machine;
    const fs::path file = dir_ / name;
    std::ofstream(file) << m.str();
    return file;
  }

  // projtour with `args` (words as a shell splits them) and the build's plugins; stdout and
  // stderr go to files in the test directory.
  test::ChildOptions command(const std::string& args, const std::string& log = "") const {
    test::ChildOptions options =
        test::projtour_command(test::shell_words(args + " --plugin-path " + kPluginPath));
    options.stdout_file = dir_ / ("stdout" + log + ".txt");
    options.stderr_file = dir_ / ("stderr" + log + ".txt");
    return options;
  }
  int projtour(const std::string& args) { return test::run(command(args)).status; }
  // projtour with `args`, stopped right after it writes `marker` and sent SIGINT there: its exit
  // status (-1 when it never reached the marker; its stderr is in stderr1.txt).
  // The command as a child that stops itself right after it writes the first events.jsonl line
  // holding `marker` (its output in stderr1.txt).
  std::unique_ptr<test::Child> stopping_after(const std::string& args, const std::string& marker) {
    test::ChildOptions options = command(args, "1");
    options.stop_after_write = marker;
    return std::make_unique<test::Child>(options);
  }
  int interrupt_after(const std::string& args, const std::string& marker) {
    const auto child = stopping_after(args, marker);
    if (!child->wait_stopped(std::chrono::seconds(60))) return -1;
    child->signal(SIGINT);
    child->resume();
    return child->wait(std::chrono::seconds(60));
  }
  std::string err() const { return read_text(dir_ / "stderr.txt"); }
  std::string out() const { return read_text(dir_ / "stdout.txt"); }

  test::TempDir scratch_;
  const fs::path dir_ = scratch_.path();
};

}  // namespace projtour::command_test
