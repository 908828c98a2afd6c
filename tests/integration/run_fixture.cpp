#include "run_fixture.hpp"

#include <unistd.h>

namespace projtour::integration {

void DryRunTest::SetUp() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  dir_ = fs::temp_directory_path() / ("projtour_it_" + std::to_string(::getpid()) + "_" +
                                      info->test_suite_name() + "_" + info->name());
  fs::remove_all(dir_);
  fs::create_directories(dir_);
}

void DryRunTest::TearDown() {
  if (!HasFailure()) fs::remove_all(dir_);
}

DryRunResult DryRunTest::dry_run(const std::string& world, const std::string& name,
                                 const std::vector<std::string>& extra) {
  DryRunResult r;
  r.dir = dir_ / name;
  r.exit_code = run_projtour(dry_run_args(data_dir() / mission_, data_dir() / world, r.dir, extra),
                             dir_ / name);
  r.err = read_text(dir_ / (name + ".stderr"));
  try {
    r.report = read_json(r.dir / "report.json");
    read_json(r.dir / "checkpoint.json");
    r.events = read_jsonl(r.dir / "events.jsonl");
    for (const auto& problem : projector_safety_problems(r.dir, r.events)) {
      ADD_FAILURE() << name << ": " << problem;
    }
  } catch (const std::exception& e) {
    ADD_FAILURE() << name << ": " << e.what() << "\nstderr:\n" << r.err;
  }
  return r;
}

}  // namespace projtour::integration
