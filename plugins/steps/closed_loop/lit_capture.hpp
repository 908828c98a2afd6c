#pragma once
// Shows projector frames one at a time and takes, for each, the first colour frame exposed after
// it had been lit for `hold_s` (the camera's time stamps, not the tick, decide). Calibrate's
// Gray-code sequence and verify's three frames both go through it. While anything is lit, the
// beam guard reads every depth frame: something in the beam ends the sequence dark, with
// `blocked_beam` (a half-taken sequence is no use, and the person may stay a while). Something
// already in the beam in the depth frame the target was captured in (a pole before a sign) is
// never lit: a fresh depth frame looks first, and where it still stands the sequence ends
// `occluded` with nothing shown.
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/context.hpp"
#include "projtour/light/beam_guard.hpp"
#include "step_names.hpp"
#include "target_view.hpp"

namespace projtour::closed_loop {

class LitCapture {
 public:
  using FrameSource = std::function<cv::Mat(int)>;

  // Frames 0..count-1 from `source`; the colour camera's exposure is fixed at exposure_ms for
  // the sequence (dark and lit frames are compared pixel by pixel). The beam guard watches what
  // of `view`'s target the projector lights (the model's bounding box in the projector).
  void start(Context& ctx, const TargetView& view, int count, FrameSource source, double hold_s,
             double exposure_ms);
  // One tick of the sequence: the outcome that ends it early -- cancelled, or "no_frame" when
  // no usable colour frame came within timeout_s of state time after a show (`showing` names
  // what was up), or no depth frame with readings within timeout_s to look whether what stood
  // in the beam at capture still does, "blocked_beam" when something comes into the beam,
  // "occluded" when something stood in it at capture and still does -- else nullopt; done() once
  // every frame has its colour frame. Throws DriverError from the devices.
  std::optional<Outcome> step(Context& ctx, double timeout_s, const std::string& showing);
  bool done() const { return static_cast<int>(frames_.size()) == count_ && !active_; }
  // A pause blanks the projector and forgets what was taken: the sequence starts again on
  // resume, since the scene may have changed meanwhile.
  void pause(Context& ctx);
  void resume(Context& ctx);
  // Blanks the projector and gives the camera its automatic exposure back.
  void finish(Context& ctx);

  const std::vector<ColourFrame>& frames() const { return frames_; }
  // Mission time from the first show to the last frame taken.
  double duration_s() const { return last_frame_s_ - first_shown_s_; }
  // The newest depth frame the beam guard found clear: one read while lit, or the look's that
  // saw gone what stood in the beam at capture. For judging what stands before the target now:
  // the captured frame is older, and what stood in it may have gone. Null when the guard kept
  // none (unguarded, none came, or each read under half the captured frame's readings).
  const DepthFrame* lit_depth() const { return lit_depth_ ? &*lit_depth_ : nullptr; }
  // The depth to lift what the camera saw onto: `captured` (the frames align registered on,
  // merged), unless something stood in the beam in it; then lit_depth(), a single frame.
  const DepthFrame& lift_depth(const DepthFrame& captured) const {
    return at_capture_ && lit_depth_ ? *lit_depth_ : captured;
  }

 private:
  bool take(Context& ctx);
  void show_next(Context& ctx);
  std::optional<Outcome> guard_beam(Context& ctx, const std::string& showing);
  void light_first(Context& ctx);
  bool usable(const DepthFrame& frame) const;
  void keep_depth(DepthFrame&& frame);
  // While something seen in the beam at capture may still stand there: a depth frame newer than
  // the capture, and "occluded" when it is, else the first show.
  std::optional<Outcome> look_before_lighting(Context& ctx, double timeout_s,
                                              const std::string& showing);

  FrameSource source_;
  int count_ = 0;
  double hold_s_ = 0.0;
  double exposure_ms_ = 0.0;
  std::vector<ColourFrame> frames_;
  double shown_at_s_ = 0.0;        // mission time of the current show
  double shown_at_state_s_ = 0.0;  // ... and its state time (for stalled())
  double first_shown_s_ = 0.0;
  double last_frame_s_ = 0.0;
  bool active_ = false;
  light::BeamGuard guard_;
  std::optional<light::BeamIntrusion> at_capture_;  // in the beam in the captured frame
  std::optional<light::BeamIntrusion> standing_;    // ... and not yet seen gone: nothing is lit
  std::vector<std::size_t> at_capture_px_;          // its pixels in the captured frame
  std::optional<std::size_t> unsure_;  // a look read some of them clear, too few to light
  double captured_t_s_ = 0.0;
  double look_after_s_ = 0.0;  // a look takes only depth frames newer than this
  double last_read_s_ = 0.0;   // the newest depth frame with readings while lit
  std::size_t captured_valid_ = 0;
  std::optional<DepthFrame> lit_depth_;
};

// A step that lights the target and records what the colour camera sees (calibrate, verify):
// the target as align left it, the sequence's capture, and an outcome decided in start(). A stop,
// a pause and a resume are the capture's.
class LitStep : public Behaviour {
 public:
  void stop(Context& ctx) override { capture_.finish(ctx); }
  void pause(Context& ctx) override { capture_.pause(ctx); }
  void resume(Context& ctx) override { capture_.resume(ctx); }

 protected:
  std::optional<TargetView> view_;
  LitCapture capture_;
  std::optional<Outcome> early_;
};

}  // namespace projtour::closed_loop
