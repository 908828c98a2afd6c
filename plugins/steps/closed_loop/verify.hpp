#pragma once
#include <memory>
#include <opencv2/core.hpp>
#include <optional>

#include "lit_capture.hpp"
#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/light/registered_depth.hpp"
#include "verify_judgement.hpp"

namespace projtour::closed_loop {

struct VerifySettings;
void check_verify_params(const Params& params);

class Verify : public LitStep {
 public:
  Verify(const Params& params, const RunContext& run);
  ~Verify() override;
  void start(Context& ctx) override;
  std::optional<Outcome> tick(Context& ctx) override;

 private:
  // Measures what the three frames show; the judgement (verify_judgement.hpp) decides.
  VerifyMeasured measure(Context& ctx);
  // The outline's slide of the Model Points (slide_at_) and what it says of the aligned pose.
  void see_outline(const PinholeModel& colour, const ColourFrame& dark,
                   const std::vector<float>& model_z, VerifyMeasured& m);
  // The dots' errors against the Model Points where the outline puts them (result_ too).
  void measure_dots(const Context& ctx, const light::RegisteredDepth& depth, VerifyMeasured& m);
  // misaligned: slides the aligned pose on the blackboard by slide_at_.
  void correct_pose(Context& ctx) const;
  void write_view(const Context& ctx) const;

  std::unique_ptr<VerifySettings> settings_;
  std::unique_ptr<head::ContentWarper> warper_;
  std::vector<cv::Mat> frames_;  // dark, dots, the content area lit white
  VerifyResult result_;
  std::array<Eigen::Vector3d, 4> slide_at_{};  // each Model Point's slide the outline sees
};

}  // namespace projtour::closed_loop
