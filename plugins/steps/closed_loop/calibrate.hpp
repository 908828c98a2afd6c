#pragma once
#include <memory>
#include <opencv2/core.hpp>
#include <optional>

#include "lit_capture.hpp"
#include "projtour/contract/blackboard_keys.hpp"

namespace projtour::light {
class GrayCodeSequence;
}

namespace projtour::closed_loop {

struct CalibrateSettings;
void check_calibrate_params(const Params& params);

class Calibrate : public LitStep {
 public:
  Calibrate(const Params& params, const RunContext& run);
  ~Calibrate() override;
  void start(Context& ctx) override;
  std::optional<Outcome> tick(Context& ctx) override;

 private:
  Outcome measure(Context& ctx);
  void publish(Context& ctx) const;

  std::unique_ptr<CalibrateSettings> settings_;
  std::unique_ptr<light::GrayCodeSequence> sequence_;
  cv::Mat mask_;
  CalibrateResult result_;
};

}  // namespace projtour::closed_loop
