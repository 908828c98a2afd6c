#pragma once
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/plugin_author.hpp"

namespace projtour::mrpt_sensor {

// Replays a rawlog's depth frames, read whole at construction (a site's rehearsal is a few
// hundred frames): the next one at most every period_s of mission time, from the start again
// after the last with `loop`, else nothing more.
class RawlogDepth : public DepthCameraDriver {
 public:
  RawlogDepth(const Params& params, const RunContext& run);
  void update(double t_s) override;
  void safe_stop() override {}
  std::optional<DepthFrame> grab() override;

  std::size_t frame_count() const { return frames_.size(); }

 private:
  double period_s_;
  bool loop_;
  std::string file_;
  std::vector<DepthFrame> frames_;
  std::size_t next_ = 0;
  std::uint64_t sequence_ = 0;
  double now_s_ = 0.0;
  std::optional<double> last_s_;
};

}  // namespace projtour::mrpt_sensor
