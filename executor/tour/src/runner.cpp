// `projtour run | validate | graph`: the commands over prepare_run (runner_prepare.cpp); the run
// itself is RunSession's (run_session.cpp).
#include "projtour/tour/runner.hpp"

#include <ostream>

#include "projtour/tour/run_session.hpp"
#include "run_session_parts.hpp"

namespace projtour {

int validate_command(const RunOptions& options, std::ostream& out, std::ostream& err) {
  host::Diagnostics diag;
  auto prepared = prepare_run(options, PrepareDepth::everything, diag);
  print_diagnostics(diag, err);
  if (!prepared) {
    err << "projtour: " << diag.error_count() << " problem(s) in " << options.mission.string()
        << "\n";
    return 2;
  }
  out << options.mission.string() << ": ok (" << prepared->mission.targets.size() << " targets, "
      << prepared->machine->leaves().size() << " behaviour states)\n";
  return 0;
}

int graph_command(const RunOptions& options, std::ostream& out, std::ostream& err) {
  host::Diagnostics diag;
  auto prepared = prepare_run(options, PrepareDepth::machine, diag);
  print_diagnostics(diag, err);
  if (!prepared) return 2;
  out << machine_to_dot(*prepared->machine, prepared->catalog.get());
  return 0;
}

int run_command(const RunOptions& options, std::ostream& out, std::ostream& err) {
  RunSession session(options, out, err);
  if (const auto status = session.open()) return *status;
  if (const auto status = session.wire()) return *status;
  if (const auto status = session.loop()) return *status;
  return session.close();
}

}  // namespace projtour
