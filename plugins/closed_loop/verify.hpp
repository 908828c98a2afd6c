#pragma once
#include <memory>
#include <opencv2/core.hpp>
#include <optional>

#include "lit_capture.hpp"
#include "projtour/behaviour.hpp"
#include "projtour/blackboard_keys.hpp"
#include "target_view.hpp"

namespace projtour::closed_loop {

struct VerifySettings;
void check_verify_params(const Params& params);

class Verify : public Behaviour {
 public:
  Verify(const Params& params, const RunContext& run);
  ~Verify() override;
  void start(Context& ctx) override;
  std::optional<Outcome> tick(Context& ctx) override;
  void stop(Context& ctx) override;
  void pause(Context& ctx) override;
  void resume(Context& ctx) override;

 private:
  Outcome measure(Context& ctx);
  void write_view(const Context& ctx) const;

  std::unique_ptr<VerifySettings> settings_;
  std::unique_ptr<ContentWarper> warper_;
  std::optional<TargetView> view_;
  std::vector<cv::Mat> frames_;  // dark, dots, the content area lit white
  LitCapture capture_;
  VerifyResult result_;
  std::optional<Outcome> early_;
};

}  // namespace projtour::closed_loop
