#pragma once
// The run's progress on stdout: one updating line on a terminal (target i/N, state, mission
// time), plain lines per target otherwise; a line per round of a schedule, and counts per round.
#include <ostream>
#include <string>

#include "projtour/record/events.hpp"

namespace projtour {

class ProgressDisplay : public ExecutorObserver {
 public:
  ProgressDisplay(std::ostream& out, bool terminal, std::size_t target_count,
                  std::size_t already_done);
  void on_event(const ExecutorEvent& event) override;
  void on_target_done(const TargetRecord& record) override;
  // Ends the updating line.
  void finish();

 private:
  void redraw(double t_s);

  std::ostream& out_;
  bool terminal_;
  std::size_t target_count_;
  std::size_t done_;
  std::string target_;
  std::string state_;
  double last_drawn_s_ = -1.0;
  bool line_open_ = false;
};

}  // namespace projtour
