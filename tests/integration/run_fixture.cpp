#include "run_fixture.hpp"

namespace projtour::integration {

void DryRunTest::SetUp() {
  scratch_.emplace();
  dir_ = scratch_->path();
}

// Here rather than in the destructor: the verdict of the test is known, and the directory goes
// (or is kept) before the next test of the binary starts.
void DryRunTest::TearDown() {
  scratch_.reset();
}

DryRunResult DryRunTest::dry_run(const std::string& world, const std::string& name,
                                 const std::vector<std::string>& extra) {
  DryRunResult r;
  r.dir = dir_ / name;
  r.exit_code =
      test::run_projtour(dry_run_args(data_dir() / mission_, data_dir() / world, r.dir, extra),
                         dir_ / name)
          .status;
  r.err = read_text(dir_ / (name + ".stderr"));
  try {
    const test::RunFiles files = test::read_run_files(r.dir);
    r.report = files.report;
    r.events = files.events;
    for (const auto& problem : projector_safety_problems(r.dir, r.events)) {
      ADD_FAILURE() << name << ": " << problem;
    }
  } catch (const std::exception& e) {
    ADD_FAILURE() << name << ": " << e.what() << "\nstderr:\n" << r.err;
  }
  return r;
}

}  // namespace projtour::integration
