// project: Model Points -> camera (align's T_camera_model) -> projector (the calibrated mount at
// the measured joint angles) -> projector pixels; the content's corners go there by a homography
// on the ideal pinhole image and the projector's lens distortion by inverse mapping; the warped
// frame is shown for the dwell time of mission time and the projector is blanked afterwards.
// With `track`, each new depth frame re-aligns the target while the content is shown, and the
// frame is re-warped (the projector stays lit) when the Model Points move past a threshold.
//
// The beam guard (core/light/beam_guard.hpp) watches every depth frame while the content is up:
// anything in the lit frustum nearer than the target blanks the projector at once (the tick
// that frame arrives on), and the content comes back once the beam has been clear for
// beam_clear_s. Blanked time does not count towards the dwell, so the content is shown its full
// time; blanked longer than beam_max_blocked_s in one go, the visit ends `blocked_beam`.
#include <chrono>
#include <cmath>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

#include "content_source.hpp"
#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/plugin_author.hpp"
#include "projtour/contract/run_image.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/head/projection.hpp"
#include "projtour/light/beam_guard.hpp"
#include "projtour/perception/model.hpp"
#include "step_names.hpp"
#include "tracker.hpp"

namespace projtour {
namespace {

using namespace project::names;
using project::PoseTracker;
using project::read_track_settings;
using project::TrackSettings;

light::BeamGuardSettings read_guard_settings(const Params& params) {
  light::BeamGuardSettings s;
  s.margin_m = params.number(param::kBeamMarginM);
  s.guard_m = params.number(param::kBeamGuardM);
  s.min_points = static_cast<int>(params.number(param::kBeamMinPoints));
  return s;
}

std::string fmt_quad(const head::Quad2d& q) {
  std::ostringstream s;
  s.precision(1);
  s << std::fixed;
  for (int i = 0; i < 4; ++i) s << (i ? " " : "") << "(" << q[i].x() << ", " << q[i].y() << ")";
  return s.str();
}

class Project : public Behaviour {
 public:
  Project(const Params& params, const RunContext& run)
      : dwell_param_s_(params.number(param::kDwellS)),
        planarity_warn_mm_(params.number(param::kPlanarityWarnMm)),
        min_area_px2_(params.number(param::kMinAreaPx2)),
        track_(read_track_settings(params)),
        tracker_(track_),
        guard_enabled_(params.boolean(param::kBeamGuard)),
        guard_(read_guard_settings(params)),
        beam_clear_s_(params.number(param::kBeamClearS)),
        beam_max_blocked_s_(params.number(param::kBeamMaxBlockedS)) {
    if (run.mission == nullptr) throw std::invalid_argument("project needs the mission's robot");
    // The undistortion maps depend only on the projector: computed once for the whole tour.
    warper_ = std::make_unique<head::ContentWarper>(run.mission->robot.projector.intrinsics);
  }

  void start(Context& ctx) override {
    early_.reset();
    showing_ = false;
    paused_ = false;
    content_.reset();
    tracking_ = false;
    beam_blanked_ = false;
    blanked_before_s_ = 0.0;
    beam_clear_since_s_.reset();
    if (ctx.target == nullptr) throw std::runtime_error("project runs only inside a visit");
    // The calibration believed now: calibrate may have measured it on this very target.
    kinematics_ = std::make_unique<head::HeadKinematics>(
        head::believed_kinematics(ctx.robot(), ctx.blackboard().find(keys::kCalibration)));
    early_ = prepare(ctx);
    if (early_) return;
    if (track_.enabled) start_tracking(ctx);
    if (guard_enabled_) arm_guard(ctx, *ctx.blackboard().find(keys::kAlign));
    t_start_s_ = ctx.state_elapsed_s();
    last_read_s_ = t_start_s_;
    result_.shown_s = 0.0;
    publish(ctx);
    show_current(ctx, /*force=*/true);
    if (!ctx.target_dir.empty()) {
      const std::filesystem::path file = ctx.target_dir / "projector.png";
      try {
        write_run_image(file, last_frame_);
      } catch (const std::exception& e) {
        ctx.log().warning("target " + ctx.target->id + ": " + e.what());
      }
    }
  }

  std::optional<Outcome> tick(Context& ctx) override {
    if (early_) return early_;
    if (ctx.cancel_requested()) {
      finish(ctx);
      return Outcome{kOutcomeCancelled, "cancelled while projecting"};
    }
    if (paused_) return std::nullopt;
    // Per-frame timing while tracking, for the visit's summary (in its outcome's message).
    const auto frame_started = std::chrono::steady_clock::now();
    const auto since_ms = [](std::chrono::steady_clock::time_point t) {
      return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t)
          .count();
    };
    auto& stats = tracker_.stats();
    std::optional<DepthFrame> frame;
    double grab_ms = 0.0;
    if (guard_.armed() || tracking_) {
      try {
        frame = ctx.drivers().depth_camera->grab();
        grab_ms = since_ms(frame_started);
        if (tracking_) stats.capture_ms.push_back(grab_ms);
      } catch (const DriverError& e) {
        if (guard_.armed()) {
          // Blind, the robot cannot keep anyone out of the light: dark is the safe state.
          finish(ctx);
          return Outcome{kOutcomeFailed, "target " + ctx.target->id + ": depth camera: " +
                                             e.what() + "; the beam cannot be guarded"};
        }
        ctx.log().warning("target " + ctx.target->id + ": depth camera: " + e.what() +
                          "; tracking stops");
        tracking_ = false;
      }
    }
    // A dropped frame (no readings) is clear of everything: it neither blanks nor clears.
    if (frame && guard_.armed() && frame->valid_count() > 0) {
      const auto beam_started = std::chrono::steady_clock::now();
      last_read_s_ = ctx.state_elapsed_s();
      if (auto blocked = guard_beam(ctx, *frame)) return blocked;
      if (tracking_) stats.beam_ms.push_back(since_ms(beam_started));
    } else if (guard_.armed()) {
      if (auto blind = guard_blind(ctx)) return blind;
    }
    if (beam_blanked_) return std::nullopt;
    const double shown_s = elapsed_s(ctx);
    result_.shown_s = std::min(shown_s, dwell_s_);
    publish(ctx);
    if (shown_s >= dwell_s_) {
      const std::string tracked = tracking_ ? "; tracking: " + stats.summary() : "";
      finish(ctx);
      std::ostringstream s;
      s.precision(1);
      s << std::fixed << "projected on " << ctx.target->id << " for " << dwell_s_ << " s"
        << tracked;
      return Outcome{outcome::kSucceeded, s.str()};
    }
    if (tracking_ && frame) track(ctx, *frame);
    if (content_->is_video()) show_current(ctx, /*force=*/false);
    if (tracking_ && frame) {
      stats.frame_ms.push_back(since_ms(frame_started));
      stats.work_ms.push_back(stats.frame_ms.back() - grab_ms);
    }
    return std::nullopt;
  }

  void stop(Context& ctx) override {
    if (showing_) finish(ctx);
    if (ctx.drivers().projector) {
      try {
        ctx.drivers().projector->blank();
      } catch (const std::exception& e) {
        ctx.log().error(std::string("project: blanking failed: ") + e.what());
      }
    }
  }

  void pause(Context& ctx) override {
    if (!showing_ || paused_) return;
    paused_ = true;
    ctx.drivers().projector->blank();
  }
  void resume(Context& ctx) override {
    if (!paused_) return;
    paused_ = false;
    last_read_s_ = ctx.state_elapsed_s();
    if (!beam_blanked_) ctx.drivers().projector->show(last_frame_);
  }

 private:
  // Everything up to the first frame; an outcome when the target cannot be projected on.
  std::optional<Outcome> prepare(Context& ctx) {
    const TargetSpec& target = *ctx.target;
    const std::string who = "target " + target.id + ": ";
    dwell_s_ = dwell_param_s_ >= 0 ? dwell_param_s_ : target.dwell_s;
    if (!ctx.drivers().projector) return Outcome{kOutcomeFailed, who + "no projector driver"};
    if (!ctx.drivers().pan_tilt) return Outcome{kOutcomeFailed, who + "no pan-tilt driver"};
    result_ = ProjectResult{};
    const AlignResult* aligned = ctx.blackboard().find(keys::kAlign);
    if (aligned == nullptr || !aligned->T_camera_model) {
      return Outcome{kOutcomeFailed,
                     who + "no aligned pose on the blackboard (" + keys::kAlign.name + ")"};
    }
    const Eigen::Isometry3d& T_camera_model = *aligned->T_camera_model;
    const PinholeModel& projector = ctx.robot().projector.intrinsics;
    warp_q_ = ctx.drivers().pan_tilt->measured();
    const Eigen::Isometry3d T_projector_camera = kinematics_->T_projector_camera(warp_q_);

    // Where the content would land from the guess alone: the report's "before alignment".
    const head::ProjectedQuad before = head::project_model_points(
        target.model_points, T_projector_camera * aligned->T_camera_model_guess, projector);
    if (before.in_front) result_.pixels_before_align = before.pixels;
    shown_T_projector_model_ = T_projector_camera * T_camera_model;
    const head::ProjectedQuad quad =
        head::project_model_points(target.model_points, shown_T_projector_model_, projector);
    if (quad.in_front) result_.pixels_after_align = quad.pixels;
    publish(ctx);
    if (!quad.on_screen) return Outcome{outcome::kOffScreen, who + quad.problem};

    const std::string degenerate = head::quad_problem(quad.ideal_pixels, min_area_px2_);
    if (!degenerate.empty()) {
      return Outcome{kOutcomeFailed, who + "degenerate projection quadrilateral (" + degenerate +
                                         ") at pixels " + fmt_quad(quad.pixels)};
    }
    const double residual_mm = head::planarity_residual_m(target.model_points) * 1e3;
    if (residual_mm > planarity_warn_mm_) {
      std::ostringstream s;
      s.precision(1);
      s << std::fixed << who << "Model Points are not coplanar: " << residual_mm
        << " mm from their best-fit plane (warning above " << planarity_warn_mm_
        << " mm); projecting anyway, the content will not lie flat between them";
      ctx.log().warning(s.str());
    }
    try {
      content_ = std::make_unique<ContentSource>(target.content);
    } catch (const std::exception& e) {
      return Outcome{kOutcomeFailed, who + e.what()};
    }
    warper_->set_target(content_->size(), quad);
    return std::nullopt;
  }

  void start_tracking(Context& ctx) {
    const std::string who = "target " + ctx.target->id + ": ";
    if (!ctx.drivers().depth_camera) {
      ctx.log().warning(who + "no depth camera driver: projecting without tracking");
      return;
    }
    const AlignResult* aligned = ctx.blackboard().find(keys::kAlign);
    try {
      if (aligned == nullptr || !aligned->model || !aligned->T_camera_model) {
        throw std::runtime_error("align published no model and pose");
      }
      tracker_.start(aligned->model, *aligned->T_camera_model);
    } catch (const std::exception& e) {
      ctx.log().warning(who + "cannot track (" + e.what() + "): projecting without tracking");
      return;
    }
    tracking_ = true;
    rejected_in_a_row_ = 0;
  }

  // Anything in the beam: blank now; clear again for beam_clear_s: show again. An outcome when
  // the beam has stayed blocked too long.
  std::optional<Outcome> guard_beam(Context& ctx, const DepthFrame& frame) {
    const light::BeamIntrusion seen = guard_.check(frame, ctx.robot().camera.depth_to_color_m);
    if (seen.blocked) {
      std::ostringstream s;
      s.precision(2);
      s << std::fixed << "something in the beam (" << seen.points << " readings, " << seen.nearest_m
        << " m from the projector, the target " << guard_.limit_m() + guard_.settings().margin_m
        << " m)";
      return blank_for(ctx, s.str(), std::to_string(seen.points) + " readings in it");
    }
    const double now_s = ctx.state_elapsed_s();
    if (!beam_blanked_) return std::nullopt;
    if (!beam_clear_since_s_) beam_clear_since_s_ = now_s;
    if (now_s - *beam_clear_since_s_ + 1e-9 >= beam_clear_s_) {
      blanked_before_s_ += now_s - blanked_since_s_;
      result_.blanked_s = blanked_before_s_;
      beam_blanked_ = false;
      beam_clear_since_s_.reset();
      if (!paused_) ctx.drivers().projector->show(last_frame_);
      publish(ctx);
    }
    return std::nullopt;
  }

  // Blind, the guard cannot keep anyone out of the light: dark until it sees the beam clear.
  std::optional<Outcome> guard_blind(Context& ctx) {
    const double blind_s = ctx.state_elapsed_s() - last_read_s_;
    if (blind_s <= guard_.settings().blind_s) return std::nullopt;
    std::ostringstream s;
    s.precision(1);
    s << std::fixed << "the depth camera read nothing for " << blind_s << " s";
    return blank_for(ctx, s.str(), "the depth camera reading nothing");
  }

  // The beam is not clear (`why`): blank now, and end blocked_beam once it has stayed so for
  // beam_max_blocked_s (`still` says what held it).
  std::optional<Outcome> blank_for(Context& ctx, const std::string& why, const std::string& still) {
    const double now_s = ctx.state_elapsed_s();
    beam_clear_since_s_.reset();
    if (!beam_blanked_) {
      ctx.drivers().projector->blank();
      beam_blanked_ = true;
      blanked_since_s_ = now_s;
      ++result_.beam_interruptions;
      ctx.log().warning("target " + ctx.target->id + ": " + why + ": blanked");
    }
    if (now_s - blanked_since_s_ > beam_max_blocked_s_) {
      finish(ctx);
      std::ostringstream s;
      s.precision(1);
      s << std::fixed << "target " << ctx.target->id << ": the beam stayed blocked for more than "
        << beam_max_blocked_s_ << " s (" << still << ")";
      return Outcome{outcome::kBlockedBeam, s.str()};
    }
    return std::nullopt;
  }

  void arm_guard(Context& ctx, const AlignResult& aligned) {
    const std::string who = "target " + ctx.target->id + ": ";
    if (!ctx.drivers().depth_camera || !aligned.model) {
      ctx.log().warning(who + (aligned.model ? "no depth camera" : "no model from align") +
                        ": the beam is not guarded");
      return;
    }
    const head::ProjectedQuad quad = head::project_model_points(
        ctx.target->model_points, shown_T_projector_model_, ctx.robot().projector.intrinsics);
    guard_.arm(kinematics_->T_projector_camera(warp_q_), ctx.robot().projector.intrinsics,
               quad.ideal_pixels, *aligned.model,
               kinematics_->T_projector_camera(warp_q_).inverse() * shown_T_projector_model_);
  }

  // One camera frame: re-align, and re-warp when the quad has moved.
  void track(Context& ctx, const DepthFrame& frame) {
    const std::string who = "target " + ctx.target->id + ": ";
    const auto result = tracker_.update(frame, ctx.robot().camera.depth_to_color_m);
    if (!result) return;
    if (!tracker_.accepted(*result)) {
      // One bad frame is noise; many in a row mean the target is gone or occluded.
      if (++rejected_in_a_row_ == kRejectedFramesToWarn) {
        std::ostringstream s;
        s.precision(2);
        s << who << kRejectedFramesToWarn << " frames in a row failed the tracking gate (inlier "
          << "fraction " << result->inlier_fraction << " < " << track_.min_inlier_fraction
          << "); showing the last good warp";
        ctx.log().warning(s.str());
      }
      return;
    }
    rejected_in_a_row_ = 0;
    const Eigen::Isometry3d& T_camera_model = tracker_.T_camera_model();
    result_.T_camera_model_tracked = T_camera_model;
    publish(ctx);
    // The head stands still while lit: its encoders' noise must not shake the content, so the
    // angles of the last warp stand until the head has really moved (beyond its tolerance).
    const JointAngles q = ctx.drivers().pan_tilt->measured();
    const double tolerance_rad = deg_to_rad(ctx.robot().pan_tilt.tolerance_deg);
    if (std::abs(q.pan_rad - warp_q_.pan_rad) > tolerance_rad ||
        std::abs(q.tilt_rad - warp_q_.tilt_rad) > tolerance_rad) {
      warp_q_ = q;
    }
    const Eigen::Isometry3d T_projector_model =
        kinematics_->T_projector_camera(warp_q_) * T_camera_model;
    const project::QuadMotion motion = project::model_points_motion(
        ctx.target->model_points, T_projector_model, shown_T_projector_model_);
    if (motion.max_point_m * 1e3 <= track_.threshold_mm &&
        rad_to_deg(motion.rotation_rad) <= track_.threshold_deg) {
      return;
    }
    rewarp(ctx, T_projector_model);
  }

  void rewarp(Context& ctx, const Eigen::Isometry3d& T_projector_model) {
    const auto started = std::chrono::steady_clock::now();
    const head::ProjectedQuad quad = head::project_model_points(
        ctx.target->model_points, T_projector_model, ctx.robot().projector.intrinsics);
    const std::string problem =
        quad.on_screen ? head::quad_problem(quad.ideal_pixels, min_area_px2_) : quad.problem;
    if (!problem.empty()) {
      // Keep the last good frame up: a partial quad would put content off the target.
      if (problem != rewarp_problem_) {
        ctx.log().warning("target " + ctx.target->id + ": not re-warping (" + problem + ")");
      }
      rewarp_problem_ = problem;
      return;
    }
    rewarp_problem_.clear();
    warper_->set_target(content_->size(), quad);
    warper_->warp(content_->frame_at(elapsed_s(ctx), nullptr), last_frame_);
    if (!beam_blanked_) ctx.drivers().projector->show(last_frame_);
    shown_T_projector_model_ = T_projector_model;
    if (guard_.armed()) arm_guard(ctx, *ctx.blackboard().find(keys::kAlign));
    result_.pixels_after_align = quad.pixels;
    publish(ctx);
    auto& stats = tracker_.stats();
    ++stats.rewarps;
    stats.rewarp_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started)
            .count());
  }

  void publish(Context& ctx) const { ctx.blackboard().set(keys::kProject, result_); }

  // Dwell and video time: state time, which stands still while paused (the projector is blank
  // then, so the content neither advances nor counts as shown).
  // Blanked time (the beam guard) is left out too: the dwell is extended by the time lost.
  double elapsed_s(const Context& ctx) const {
    const double blanked_now_s = beam_blanked_ ? ctx.state_elapsed_s() - blanked_since_s_ : 0.0;
    return ctx.state_elapsed_s() - t_start_s_ - blanked_before_s_ - blanked_now_s;
  }

  void show_current(Context& ctx, bool force) {
    bool changed = false;
    const cv::Mat& frame = content_->frame_at(elapsed_s(ctx), &changed);
    if (!changed && !force) return;
    warper_->warp(frame, last_frame_);
    if (!beam_blanked_) ctx.drivers().projector->show(last_frame_);
    showing_ = true;
  }

  void finish(Context& ctx) {
    if (!showing_) return;
    showing_ = false;
    if (tracking_) {
      ctx.log().info("project " + ctx.target->id + " tracking: " + tracker_.stats().summary());
      tracking_ = false;
    }
    const double shown_s = std::min(elapsed_s(ctx), dwell_s_);
    result_.shown_s = std::max(0.0, shown_s);
    if (beam_blanked_) {
      result_.blanked_s = blanked_before_s_ + ctx.state_elapsed_s() - blanked_since_s_;
      beam_blanked_ = false;
    }
    publish(ctx);
    ctx.drivers().projector->blank();
  }

  double dwell_param_s_;
  double planarity_warn_mm_;
  double min_area_px2_;
  TrackSettings track_;
  PoseTracker tracker_;
  bool tracking_ = false;
  static constexpr int kRejectedFramesToWarn = 15;
  int rejected_in_a_row_ = 0;
  std::string rewarp_problem_;
  JointAngles warp_q_;  // head angles the projector pose is computed from
  // The model in the projector frame the frame on show was warped with.
  Eigen::Isometry3d shown_T_projector_model_ = Eigen::Isometry3d::Identity();
  std::unique_ptr<head::HeadKinematics> kinematics_;
  std::unique_ptr<head::ContentWarper> warper_;
  std::unique_ptr<ContentSource> content_;
  ProjectResult result_;
  std::optional<Outcome> early_;
  cv::Mat last_frame_;
  double dwell_s_ = 0.0;
  double t_start_s_ = 0.0;
  bool showing_ = false;
  bool paused_ = false;  // blanked by pause(): resume() shows last_frame_ again
  bool guard_enabled_;
  light::BeamGuard guard_;
  double beam_clear_s_;
  double beam_max_blocked_s_;
  bool beam_blanked_ = false;  // by the beam guard
  double blanked_since_s_ = 0.0;
  double blanked_before_s_ = 0.0;  // earlier blanks of this visit
  std::optional<double> beam_clear_since_s_;
  double last_read_s_ = 0.0;  // state time of the newest depth frame with readings
};

void check_params(const Params& params) {
  if (params.number(param::kPlanarityWarnMm) < 0 || params.number(param::kMinAreaPx2) < 0) {
    throw std::invalid_argument("planarity_warn_mm and min_area_px2 must be >= 0");
  }
  for (const char* key : {param::kBeamMarginM, param::kBeamGuardM, param::kBeamClearS}) {
    if (!(params.number(key) >= 0)) throw std::invalid_argument(std::string(key) + " must be >= 0");
  }
  if (!(params.number(param::kBeamMinPoints) >= 1) ||
      !(params.number(param::kBeamMaxBlockedS) > 0)) {
    throw std::invalid_argument("beam_min_points must be >= 1 and beam_max_blocked_s > 0");
  }
  read_track_settings(params);
}

const projtour_param_desc kParams[] = {
    {param::kDwellS, "number", "-1",
     "seconds to show the content; negative = the target's dwell_s"},
    {param::kTrack, "boolean", "false",
     "re-capture and re-align while showing, re-warping when the pose moves"},
    {param::kTrackThresholdMm, "number", "1.0",
     "track: re-warp when a Model Point moves more than this (projector frame)"},
    {param::kTrackThresholdDeg, "number", "0.5", "track: ... or the target turns more than this"},
    {param::kTrackMinInlierFraction, "number", "0.6",
     "track: a frame whose fit has fewer inliers is skipped"},
    {param::kTrackCropMarginM, "number", "0.05",
     "track: each frame is cropped to the model's bounding sphere plus this"},
    {param::kPlanarityWarnMm, "number", "5",
     "warn when the Model Points lie farther than this from a common plane"},
    {param::kMinAreaPx2, "number", "100", "smaller projected quadrilaterals count as zero area"},
    {param::kBeamGuard, "boolean", "true",
     "blank the projector while anything stands in the beam nearer than the target"},
    {param::kBeamMarginM, "number", "0.10",
     "beam guard: nearer than the target's nearest lit point by this counts"},
    {param::kBeamGuardM, "number", "0.15",
     "beam guard: the lit region grown by this on every side, at each reading's depth"},
    {param::kBeamMinPoints, "number", "30",
     "beam guard: depth readings (every 2nd pixel each way) it takes to blank"},
    {param::kBeamClearS, "number", "1.0", "beam guard: shown again once clear this long"},
    {param::kBeamMaxBlockedS, "number", "15",
     "beam guard: blanked longer than this in one go ends the visit blocked_beam"}};
const char* const kOutcomes[] = {outcome::kSucceeded, outcome::kOffScreen, outcome::kBlockedBeam};
const projtour_key_desc kKeys[] = {reads(keys::kAlign), reads_if_present(keys::kCalibration),
                                   writes(keys::kProject)};
const projtour_kind_desc kKinds[] = {with_keys(
    behaviour_kind<Project>("project",
                            "warp the content onto the Model Points and show it for the dwell "
                            "time",
                            kParams, kOutcomes, validator<check_params>()),
    kKeys)};

}  // namespace
}  // namespace projtour

PROJTOUR_PLUGIN("project", "1.0.0", projtour::kKinds)
