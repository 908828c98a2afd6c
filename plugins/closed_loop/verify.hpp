#pragma once
#include <memory>
#include <opencv2/core.hpp>
#include <optional>

#include "lit_capture.hpp"
#include "projtour/blackboard_keys.hpp"

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
  Outcome measure(Context& ctx);
  void write_view(const Context& ctx) const;

  std::unique_ptr<VerifySettings> settings_;
  std::unique_ptr<ContentWarper> warper_;
  std::vector<cv::Mat> frames_;  // dark, dots, the content area lit white
  VerifyResult result_;
};

}  // namespace projtour::closed_loop
