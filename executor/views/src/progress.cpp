#include "projtour/views/progress.hpp"

#include <cstdio>

namespace projtour {

ProgressDisplay::ProgressDisplay(std::ostream& out, bool terminal, std::size_t target_count,
                                 std::size_t already_done)
    : out_(out), terminal_(terminal), target_count_(target_count), done_(already_done) {}

void ProgressDisplay::on_event(const ExecutorEvent& event) {
  if (event.type == EventType::round) {
    // Counts are per round: "target i/N" stays within the tour's N.
    if (event.outcome == "end") done_ = 0;
    if (terminal_ && line_open_) out_ << "\r\033[K";
    line_open_ = false;
    out_ << "round " << event.round << " " << event.outcome << "s " << event.message << "\n";
    out_.flush();
    return;
  }
  if (event.type != EventType::enter) return;
  const std::string target = event.target.value_or("");
  if (!terminal_ && !target.empty() && target != target_) {
    out_ << "target " << done_ + 1 << "/" << target_count_ << " " << target << ": visiting\n";
  }
  target_ = target;
  state_ = event.state;
  if (terminal_) redraw(event.t_s);
}

void ProgressDisplay::on_target_done(const TargetRecord& record) {
  ++done_;
  if (terminal_) {
    out_ << "\r\033[K";
    line_open_ = false;
  }
  out_ << "target " << done_ << "/" << target_count_ << " " << record.id << ": " << record.outcome
       << (record.reason.empty() ? "" : " (" + record.reason + ")") << "\n";
  out_.flush();
}

void ProgressDisplay::redraw(double t_s) {
  char time_text[32];
  std::snprintf(time_text, sizeof time_text, "%8.1f s", t_s);
  out_ << "\r\033[K[" << time_text << "] target " << std::min(done_ + 1, target_count_) << "/"
       << target_count_ << (target_.empty() ? "" : " " + target_) << "  " << state_;
  out_.flush();
  line_open_ = true;
  last_drawn_s_ = t_s;
}

void ProgressDisplay::finish() {
  if (line_open_) out_ << "\n";
  line_open_ = false;
}

}  // namespace projtour
