#include "lit_capture.hpp"

#include <algorithm>
#include <limits>
#include <sstream>

namespace projtour::closed_loop {

void LitCapture::start(Context& ctx, const TargetView& view, int count, FrameSource source,
                       double hold_s, double exposure_ms) {
  // The lit region: the model's bounding box in the projector (the patterns stay on it).
  const PinholeModel& projector = ctx.robot().projector.intrinsics;
  guard_ = light::BeamGuard();
  if (view.model && ctx.drivers().depth_camera) {
    const Eigen::Isometry3d T_projector_model = view.T_projector_camera * view.T_camera_model;
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi = -lo;
    for (const Eigen::Vector3f& p : view.model->points) {
      const Eigen::Vector3d q = T_projector_model * p.cast<double>();
      if (q.z() <= 0.0) continue;
      const Eigen::Vector2d px(projector.fx * q.x() / q.z() + projector.cx,
                               projector.fy * q.y() / q.z() + projector.cy);
      lo = lo.cwiseMin(px);
      hi = hi.cwiseMax(px);
    }
    if (lo.x() <= hi.x()) {
      guard_.arm(view.T_projector_camera, projector,
                 {lo, Eigen::Vector2d(hi.x(), lo.y()), hi, Eigen::Vector2d(lo.x(), hi.y())},
                 *view.model, view.T_camera_model);
    }
  }
  if (!guard_.armed()) {
    ctx.log().warning(target_prefix(ctx) + "the beam is not guarded (" +
                      (ctx.drivers().depth_camera ? "no model in view" : "no depth camera") + ")");
  }
  source_ = std::move(source);
  count_ = count;
  hold_s_ = hold_s;
  exposure_ms_ = exposure_ms;
  frames_.clear();
  active_ = true;
  ctx.drivers().colour_camera->set_exposure_ms(exposure_ms_);
  // Something that stood in the beam when the target was captured (a pole, a stand, a person)
  // is not lit to find out whether it is still there: a fresh depth frame decides first.
  at_capture_.reset();
  lit_depth_.reset();
  at_capture_px_.clear();
  captured_t_s_ = view.capture ? view.capture->frame.t_s : -std::numeric_limits<double>::infinity();
  look_after_s_ = captured_t_s_;
  captured_valid_ = view.capture ? view.capture->frame.valid_count() : 0;
  if (guard_.armed() && view.capture) {
    const light::BeamIntrusion seen =
        guard_.check(view.capture->frame, ctx.robot().camera.depth_to_color_m, &at_capture_px_);
    if (seen.blocked) {
      at_capture_ = seen;
      // Its own readings go when it does: the bar for a frame that saw the scene is the rest.
      const std::size_t stride = static_cast<std::size_t>(std::max(1, guard_.settings().stride_px));
      captured_valid_ -= std::min(captured_valid_, at_capture_px_.size() * stride * stride);
    }
  }
  standing_ = at_capture_;
  unsure_.reset();
  shown_at_state_s_ = ctx.state_elapsed_s();
  if (!standing_) light_first(ctx);
}

void LitCapture::light_first(Context& ctx) {
  // Frames exposed before the first show must not count: drop what is queued.
  while (ctx.drivers().colour_camera->grab()) {
  }
  show_next(ctx);
  first_shown_s_ = shown_at_s_;
  last_read_s_ = shown_at_s_;
}

std::optional<Outcome> LitCapture::look_before_lighting(Context& ctx, double timeout_s,
                                                        const std::string& showing) {
  // The newest frame that read anything: a dropped one (no readings) is clear of everything.
  std::optional<DepthFrame> frame;
  while (auto f = ctx.drivers().depth_camera->grab()) {
    if (f->t_s > look_after_s_ && f->valid_count() > 0 && (!frame || f->t_s > frame->t_s)) {
      frame = std::move(f);
    }
  }
  const Eigen::Vector3d& depth_to_color_m = ctx.robot().camera.depth_to_color_m;
  const auto occluded = [&](const std::string& what) {
    finish(ctx);
    return Outcome{outcome::kOccluded, target_prefix(ctx) + what + ": " + showing +
                                           " not shown, the light would land on it"};
  };
  if (frame) {
    const light::BeamIntrusion seen = guard_.check(*frame, depth_to_color_m);
    if (seen.blocked) {
      return occluded("something stands in the beam (" + std::to_string(seen.points) +
                      " readings, " + fixed(seen.nearest_m, 2) + " m from the projector; " +
                      std::to_string(standing_->points) + " when the target was captured)");
    }
    // Gone only where it stood reads clear now: too few readings there (a part-dropped frame,
    // a dark coat) is not a clear beam.
    const std::size_t clear = guard_.seen_clear(*frame, depth_to_color_m, at_capture_px_);
    if (10 * clear >= 9 * at_capture_px_.size()) {
      standing_.reset();
      lit_depth_ = std::move(*frame);
      light_first(ctx);
      return std::nullopt;
    }
    unsure_ = clear;
  }
  if (ctx.state_elapsed_s() - shown_at_state_s_ <= timeout_s) return std::nullopt;
  if (unsure_) {
    return occluded("something stood in the beam when the target was captured (" +
                    std::to_string(standing_->points) + " readings) and no depth frame within " +
                    fixed(timeout_s, 1) + " s saw it gone (at best " + std::to_string(*unsure_) +
                    " of its readings clear)");
  }
  finish(ctx);
  return Outcome{outcome::kNoFrame,
                 target_prefix(ctx) + "something stood in the beam when the target " +
                     "was captured and no depth frame with readings came within " +
                     fixed(timeout_s, 1) + " s to see whether it still does"};
}

bool LitCapture::usable(const DepthFrame& frame) const {
  // A frame the camera dropped (few or no readings) says nothing of the scene. The bar is the
  // captured frame's own count, since the same view of the same scene reads about as many: a
  // fixed share of the image would refuse every frame of a far target against an open hall.
  const std::size_t valid = frame.valid_count();
  return valid > 0 && 2 * valid >= captured_valid_;
}

void LitCapture::keep_depth(DepthFrame&& frame) {
  if (!usable(frame)) return;
  if (lit_depth_ && frame.t_s < lit_depth_->t_s) return;
  lit_depth_ = std::move(frame);
}

void LitCapture::show_next(Context& ctx) {
  ctx.drivers().projector->show(source_(static_cast<int>(frames_.size())));
  shown_at_s_ = ctx.now_s();
  shown_at_state_s_ = ctx.state_elapsed_s();
}

std::optional<Outcome> LitCapture::step(Context& ctx, double timeout_s,
                                        const std::string& showing) {
  if (ctx.cancel_requested()) {
    finish(ctx);
    return Outcome{kOutcomeCancelled, "cancelled while showing " + showing};
  }
  if (active_ && standing_) return look_before_lighting(ctx, timeout_s, showing);
  if (active_ && ctx.state_elapsed_s() - shown_at_state_s_ > timeout_s) {
    finish(ctx);
    std::ostringstream s;
    s.precision(1);
    s << std::fixed << (ctx.target ? "target " + ctx.target->id + ": " : std::string())
      << "no colour frame within " << timeout_s << " s of showing " << showing << " (frame "
      << frames_.size() + 1 << " of " << count_ << ")";
    return Outcome{outcome::kNoFrame, s.str()};
  }
  if (active_) {
    if (auto blocked = guard_beam(ctx, showing)) return blocked;
  }
  if (take(ctx)) finish(ctx);
  return std::nullopt;
}

std::optional<Outcome> LitCapture::guard_beam(Context& ctx, const std::string& showing) {
  if (!guard_.armed()) return std::nullopt;
  auto frame = ctx.drivers().depth_camera->grab();
  // A dropped frame (no readings) is clear of everything: it neither blocks nor clears, and
  // blind the light goes dark.
  if (!frame || frame->valid_count() == 0) {
    const double blind_s = guard_.settings().blind_s;
    if (ctx.now_s() - last_read_s_ <= blind_s) return std::nullopt;
    finish(ctx);
    return Outcome{outcome::kNoFrame, target_prefix(ctx) +
                                          "the depth camera read nothing for more " + "than " +
                                          fixed(blind_s, 1) + " s while showing " + showing +
                                          ": blanked, the beam was not watched"};
  }
  last_read_s_ = std::max(last_read_s_, frame->t_s);
  const light::BeamIntrusion seen = guard_.check(*frame, ctx.robot().camera.depth_to_color_m);
  if (!seen.blocked) {
    keep_depth(std::move(*frame));
    return std::nullopt;
  }
  finish(ctx);
  std::ostringstream s;
  s.precision(2);
  s << std::fixed << target_prefix(ctx) << "something in the beam (" << seen.points << " readings, "
    << seen.nearest_m << " m from the projector) while showing " << showing << " (frame "
    << frames_.size() + 1 << " of " << count_ << "): blanked";
  return Outcome{outcome::kBlockedBeam, s.str()};
}

bool LitCapture::take(Context& ctx) {
  if (!active_) return false;
  while (auto frame = ctx.drivers().colour_camera->grab()) {
    // A frame exposed (even partly) before the pattern had settled shows the previous one.
    if (frame->t_s + 1e-6 < shown_at_s_ + hold_s_) continue;
    last_frame_s_ = frame->t_s;
    frames_.push_back(std::move(*frame));
    if (static_cast<int>(frames_.size()) == count_) {
      active_ = false;
      return true;
    }
    show_next(ctx);
    // The next pattern has just gone up: anything still queued predates it.
    while (ctx.drivers().colour_camera->grab()) {
    }
    break;
  }
  return false;
}

void LitCapture::pause(Context& ctx) {
  if (!active_) return;
  ctx.drivers().projector->blank();
}

void LitCapture::resume(Context& ctx) {
  if (!active_) return;
  frames_.clear();
  lit_depth_.reset();
  // What stood in the beam at capture is looked for again: it may have come back meanwhile.
  standing_ = at_capture_;
  unsure_.reset();
  if (standing_) {
    // Only a frame taken after the pause says what stands there now.
    look_after_s_ = std::max(captured_t_s_, ctx.now_s());
    shown_at_state_s_ = ctx.state_elapsed_s();
    return;
  }
  light_first(ctx);
}

void LitCapture::finish(Context& ctx) {
  active_ = false;
  if (ctx.drivers().projector) ctx.drivers().projector->blank();
  if (ctx.drivers().colour_camera) {
    try {
      ctx.drivers().colour_camera->set_exposure_ms(0.0);
    } catch (const std::exception& e) {
      ctx.log().warning(std::string("colour camera: cannot restore automatic exposure: ") +
                        e.what());
    }
  }
}

}  // namespace projtour::closed_loop
