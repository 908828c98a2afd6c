// Behaviour `capture`: takes depth frames from the depth camera driver, averages them, and puts
// the result on the blackboard for align.
#include <memory>
#include <sstream>
#include <vector>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/plugin_author.hpp"
#include "projtour/perception/registration.hpp"

namespace projtour::capture {
namespace {
// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kNoFrame = "no_frame";
}  // namespace outcome
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kAverageFrames = "average_frames";
inline constexpr const char* kMaxWaitS = "max_wait_s";
}  // namespace param

struct Settings {
  long long average_frames = 1;
  double max_wait_s = 2.0;
};

Settings read_settings(const Params& p) {
  Settings s;
  s.average_frames = p.integer(param::kAverageFrames);
  s.max_wait_s = p.number(param::kMaxWaitS);
  if (s.average_frames < 1 || s.average_frames > 100) {
    throw std::invalid_argument("average_frames: must lie in [1, 100]");
  }
  if (!(s.max_wait_s > 0.0)) throw std::invalid_argument("max_wait_s: must be > 0");
  return s;
}

class Capture : public Behaviour {
 public:
  Capture(const Params& params, const RunContext&) : settings_(read_settings(params)) {}

  void start(Context& ctx) override {
    frames_.clear();
    dropped_ = 0;
    started_s_ = ctx.state_elapsed_s();  // a pause is not time the camera failed to deliver
  }

  std::optional<Outcome> tick(Context& ctx) override {
    if (ctx.cancel_requested()) return Outcome{kOutcomeCancelled, "cancelled"};
    DepthCameraDriver* camera = ctx.drivers().depth_camera.get();
    if (camera == nullptr) return Outcome{kOutcomeFailed, "no depth camera driver"};
    // Where the camera was when the frames came: align must use these, not where it is later.
    if (!ctx.drivers().pan_tilt) return Outcome{kOutcomeFailed, "no pan-tilt driver"};
    const PoseEstimate2D* base = ctx.blackboard().find(keys::kLocalization);
    if (base == nullptr) {
      return Outcome{kOutcomeFailed, std::string("no localization estimate on the blackboard (") +
                                         keys::kLocalization.name + ")"};
    }
    try {
      while (auto frame = camera->grab()) {
        // A dropped frame arrives with no readings: it would only thin the average.
        if (frame->valid_count() == 0) {
          ++dropped_;
          continue;
        }
        frames_.push_back(std::move(*frame));
        if (frames_.size() >= static_cast<std::size_t>(settings_.average_frames)) break;
      }
    } catch (const DriverError& e) {
      return Outcome{kOutcomeFailed, std::string("depth camera: ") + e.what()};
    }
    if (frames_.size() >= static_cast<std::size_t>(settings_.average_frames)) {
      CapturedFrame captured;
      captured.frame = frames_.size() == 1 ? std::move(frames_.front())
                                           : perception::average_depth_frames(frames_);
      try {
        captured.joints = ctx.drivers().pan_tilt->measured();
      } catch (const DriverError& e) {
        return Outcome{kOutcomeFailed, std::string("pan-tilt: ") + e.what()};
      }
      captured.base_estimate = *base;
      std::ostringstream what;
      what << frames_.size() << " frame(s), " << captured.frame.valid_count() << " readings";
      ctx.blackboard().set(keys::kCapture, std::move(captured));
      frames_.clear();
      return Outcome{outcome::kSucceeded, what.str()};
    }
    if (ctx.state_elapsed_s() - started_s_ > settings_.max_wait_s) {
      std::ostringstream why;
      why << "got " << frames_.size() << " of " << settings_.average_frames << " frame(s) in "
          << settings_.max_wait_s << " s (" << dropped_ << " dropped)";
      return Outcome{outcome::kNoFrame, why.str()};
    }
    return std::nullopt;
  }

 private:
  Settings settings_;
  std::vector<DepthFrame> frames_;
  int dropped_ = 0;
  double started_s_ = 0.0;
};

const projtour_param_desc kParams[] = {
    {param::kAverageFrames, "integer", "1", "frames averaged pixel by pixel into one"},
    {param::kMaxWaitS, "number", "2.0", "no_frame when the frames have not arrived by then"},
};
const char* const kOutcomes[] = {outcome::kSucceeded, outcome::kNoFrame};
const projtour_key_desc kKeys[] = {reads(keys::kLocalization), writes(keys::kCapture)};
const projtour_kind_desc kKinds[] = {with_keys(
    behaviour_kind<Capture>("capture",
                            "a depth frame from the depth camera, stamped with the joint angles "
                            "and the base estimate at capture",
                            kParams, kOutcomes, validator<read_settings>()),
    kKeys)};

}  // namespace
}  // namespace projtour::capture

PROJTOUR_PLUGIN("capture", "1.0.0", projtour::capture::kKinds)
