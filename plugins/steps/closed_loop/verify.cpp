// verify: the colour camera's check of where the content will land, through the very warp
// project shows it with. Three frames: dark, a dot on each Model Point's pixel, and the content
// area lit white. The dots are found in the colour image, lifted to 3-D with the registered
// depth and compared with the Model Points where the camera sees the target (observed_error_mm):
// at the aligned pose slid along their plane by as much as the target's outline in the dark frame
// stands from the model's (a clear outline's slide always; a faint one's when gross, as ICP leaves
// a flat face slid along itself). A miss that is the pose's corrects the pose (misaligned: the
// pose slides, verify looks again).
// The lit area shows whether the light lands on the target or on something in front of it.
// measure() only measures; judge_verify (verify_judgement.hpp) chooses the outcome from that.
#include "verify.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/run_image.hpp"
#include "projtour/light/light_check.hpp"
#include "projtour/light/outline_match.hpp"
#include "projtour/light/registered_depth.hpp"
#include "projtour/perception/registration.hpp"

namespace projtour::closed_loop {

struct VerifySettings {
  double edge_margin_px = 8.0;
  int dot_radius_px = 10;
  double search_px = 40.0;
  double min_on_target = 0.95;
  double tolerance_mm = -1.0;  // negative: the target's tolerance_mm
  double frame_timeout_s = 1.0;
  int outline_search_px = 80;
  double min_outline_matched = 0.35;
  double gross_slide_tolerances = 2.0;
  double clear_outline_matched = 0.7;
  double spread_sigmas = 4.0;
};

static VerifySettings read_verify_settings(const Params& p) {
  VerifySettings s;
  s.edge_margin_px = p.number(param::kEdgeMarginPx);
  s.dot_radius_px = static_cast<int>(p.integer(param::kDotRadiusPx));
  s.search_px = p.number(param::kSearchPx);
  s.min_on_target = p.number(param::kMinOnTarget);
  s.tolerance_mm = p.number(param::kToleranceMm);
  s.frame_timeout_s = p.number(param::kFrameTimeoutS);
  s.outline_search_px = static_cast<int>(p.integer(param::kOutlineSearchPx));
  s.min_outline_matched = p.number(param::kMinOutlineMatched);
  s.gross_slide_tolerances = p.number(param::kGrossSlideTolerances);
  s.clear_outline_matched = p.number(param::kClearOutlineMatched);
  s.spread_sigmas = p.number(param::kSpreadSigmas);
  if (s.edge_margin_px < 0) throw std::invalid_argument("edge_margin_px: must be >= 0");
  if (s.dot_radius_px < 1 || s.dot_radius_px > 100) {
    throw std::invalid_argument("dot_radius_px: must lie in [1, 100]");
  }
  if (!(s.search_px > 0)) throw std::invalid_argument("search_px: must be > 0");
  if (!(s.min_on_target >= 0.0 && s.min_on_target <= 1.0)) {
    throw std::invalid_argument("min_on_target: must lie in [0, 1]");
  }
  if (s.tolerance_mm == 0.0) throw std::invalid_argument("tolerance_mm: must not be 0");
  if (!(s.frame_timeout_s > 0)) throw std::invalid_argument("frame_timeout_s: must be > 0");
  if (s.outline_search_px < 1 || s.outline_search_px > 200) {
    throw std::invalid_argument("outline_search_px: must lie in [1, 200]");
  }
  if (!(s.min_outline_matched > 0.0 && s.min_outline_matched <= 1.0)) {
    throw std::invalid_argument("min_outline_matched: must lie in (0, 1]");
  }
  if (!(s.clear_outline_matched >= s.min_outline_matched && s.clear_outline_matched <= 1.0)) {
    throw std::invalid_argument("clear_outline_matched: must lie in [min_outline_matched, 1]");
  }
  if (!(s.spread_sigmas >= 0.0)) throw std::invalid_argument("spread_sigmas: must be >= 0");
  if (!(s.gross_slide_tolerances >= 0.0)) {
    throw std::invalid_argument("gross_slide_tolerances: must be >= 0");
  }
  return s;
}

void check_verify_params(const Params& params) {
  read_verify_settings(params);
}

namespace {

// A gross slide also moves the outline more than this in the image (Canny places an edge to a
// pixel) and matches it at most this share of the cost where the model has it (a sign slid
// sideways still matches its top and bottom edges unshifted: the share cannot be much lower).
constexpr double kGrossShiftPx = 3.0;
constexpr double kGrossCostShare = 0.85;

// Where the colour ray through `px` meets the target: the registered depth's surface, or where
// the Kinect read nothing there (a grazing rim, its shadow beside an edge) the aligned model's
// tangent plane at the Model Point.
std::optional<Eigen::Vector3d> lift_on_target(const light::RegisteredDepth& depth,
                                              const PinholeModel& colour, const Eigen::Vector2d& px,
                                              const Eigen::Vector3d& plane_point,
                                              const Eigen::Vector3d& plane_normal) {
  if (const auto p = light::lift(depth, px)) return p;
  const Eigen::Vector3d ray = colour.unproject(px);
  const double denom = plane_normal.dot(ray);
  if (std::abs(denom) < 1e-6) return std::nullopt;
  const double s = plane_normal.dot(plane_point) / denom;
  if (!(s > 0.0)) return std::nullopt;
  return s * ray;
}

// The model's normal (camera frame) at its sample nearest to `p_model`.
Eigen::Vector3d normal_near(const ModelCloud& model, const Eigen::Isometry3d& T_camera_model,
                            const Eigen::Vector3d& p_model) {
  std::size_t best = 0;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < model.points.size(); ++i) {
    const double d2 = (model.points[i].cast<double>() - p_model).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = i;
    }
  }
  if (model.normals.size() != model.points.size())
    return -T_camera_model.translation().normalized();
  return T_camera_model.linear() * model.normals[best].cast<double>();
}

cv::Mat as_mat(const ColourFrame& f) {
  return cv::Mat(f.height, f.width, CV_8UC3, const_cast<std::uint8_t*>(f.bgr.data())).clone();
}

}  // namespace

Verify::Verify(const Params& params, const RunContext& run)
    : settings_(std::make_unique<VerifySettings>(read_verify_settings(params))) {
  if (run.mission == nullptr) throw std::invalid_argument("verify needs the mission's robot");
  warper_ = std::make_unique<head::ContentWarper>(run.mission->robot.projector.intrinsics);
}

Verify::~Verify() = default;

void Verify::start(Context& ctx) {
  early_.reset();
  view_.reset();
  frames_.clear();
  result_ = VerifyResult{};
  result_.tolerance_mm = settings_->tolerance_mm > 0 ? settings_->tolerance_mm
                         : ctx.target                ? ctx.target->tolerance_mm
                                                     : 3.0;
  auto looked = look_at_target(ctx, settings_->edge_margin_px);
  if (looked.outcome) {
    early_ = looked.outcome;
    return;
  }
  view_ = std::move(looked.view);
  const RobotSpec& robot = ctx.robot();
  const PinholeModel& projector = robot.projector.intrinsics;
  frames_.push_back(cv::Mat(projector.height, projector.width, CV_8UC3, cv::Scalar::all(0)));
  const cv::Mat dots = light::dots_frame(projector, view_->quad.pixels, settings_->dot_radius_px);
  frames_.push_back(dots.channels() == 3 ? dots : [&] {
    cv::Mat bgr;
    cv::cvtColor(dots, bgr, cv::COLOR_GRAY2BGR);
    return bgr;
  }());
  const cv::Size content(256, 256);
  warper_->set_target(content, view_->quad);
  frames_.push_back(warper_->warp(cv::Mat(content, CV_8UC3, cv::Scalar::all(255))));
  capture_.start(
      ctx, *view_, static_cast<int>(frames_.size()), [this](int i) { return frames_[i]; },
      robot.structured_light.hold_s, robot.structured_light.exposure_ms);
}

std::optional<Outcome> Verify::tick(Context& ctx) {
  if (early_) return early_;
  if (auto ended = capture_.step(ctx, settings_->frame_timeout_s, "the verification pattern")) {
    return ended;
  }
  if (!capture_.done()) return std::nullopt;
  const VerifyMeasured measured = measure(ctx);
  const VerifyJudgement judged = judge_verify(
      measured, {result_.tolerance_mm, settings_->min_on_target, settings_->spread_sigmas});
  if (judged.correct_pose) correct_pose(ctx);
  ctx.blackboard().set(keys::kVerify, result_);
  write_view(ctx);
  return Outcome{judged.outcome, target_prefix(ctx) + judged.reason};
}

VerifyMeasured Verify::measure(Context& ctx) {
  const RobotSpec& robot = ctx.robot();
  const PinholeModel& colour = robot.camera.colour.intrinsics;
  const std::vector<ColourFrame>& f = capture_.frames();
  const ColourFrame& dark = f[0];
  const ColourFrame& area = f[2];
  for (int i = 0; i < 4; ++i) {
    const auto px = colour.project(view_->model_points_camera[i]);
    result_.expected_colour_px[i] = px ? *px : Eigen::Vector2d(-1, -1);
  }
  // What stands before the target and where the dots land, in depth taken while the patterns
  // were up (the captured frame is the fit's: something in front of the target then may be
  // gone, which the beam guard's fresh look allowed).
  const DepthFrame& depth_now =
      capture_.lit_depth() ? *capture_.lit_depth() : view_->capture->frame;
  const light::RegisteredDepth depth =
      light::register_depth(depth_now, robot.camera.depth_to_color_m, colour);
  const std::vector<float> model_z =
      light::model_depth(*view_->model, view_->T_camera_model, colour);
  const light::LightOnTarget light = light::light_on_target(dark, area, depth, model_z);
  result_.light_on_target_fraction = light.on_target_fraction;
  VerifyMeasured m;
  m.on_target_fraction = light.on_target_fraction;
  m.in_front_fraction = light.in_front_fraction;

  // What the depth fit is worth at the Model Points: the spread of the fits made without each
  // part of the model.
  const perception::IcpModel icp_model(*view_->model);
  const perception::OrganizedCloud scene =
      perception::organized_cloud(view_->capture->frame, robot.camera.depth_to_color_m);
  const perception::PoseSpread spread =
      perception::pose_spread(icp_model, scene, view_->T_camera_model,
                              {ctx.target->model_points.begin(), ctx.target->model_points.end()});
  m.spread_model_point_mm = spread.model_point_mm;
  m.spread_blocks = spread.blocks;
  m.spread_matches = spread.matches;

  see_outline(colour, dark, model_z, m);
  measure_dots(ctx, depth, m);
  for (const Eigen::Vector3d& s : slide_at_) m.moves_mm = std::max(m.moves_mm, 1e3 * s.norm());
  return m;
}

// Where the camera sees the target, from its outline in the dark frame: the Model Points slide
// with it along their plane. The depth fixes the face's plane; the outline, where on the plane.
void Verify::see_outline(const PinholeModel& colour, const ColourFrame& dark,
                         const std::vector<float>& model_z, VerifyMeasured& m) {
  const std::array<Eigen::Vector3d, 4>& M = view_->model_points_camera;
  const Eigen::Vector3d centre = 0.25 * (M[0] + M[1] + M[2] + M[3]);
  Eigen::Vector3d plane_normal = (M[2] - M[0]).cross(M[3] - M[1]);
  plane_normal = plane_normal.norm() > 1e-12 ? plane_normal.normalized()
                                             : Eigen::Vector3d(-centre.normalized());
  light::OutlineSettings outline_settings;
  outline_settings.search_px = settings_->outline_search_px;
  const auto outline = light::match_outline(dark, model_z, outline_settings);
  Eigen::Vector3d slide = Eigen::Vector3d::Zero();
  // Each Model Point's own slide: the outline's shift and its turn about the face's normal.
  slide_at_.fill(Eigen::Vector3d::Zero());
  // An outline that fixes no image direction checks nothing.
  if (!(outline && outline->matched_fraction >= settings_->min_outline_matched &&
        outline->fixed_directions > 0)) {
    m.outline_text = outline ? "the outline not matched (" +
                                   fixed(100.0 * outline->matched_fraction, 0) + " % of it, " +
                                   fixed(100.0 * settings_->min_outline_matched, 0) + " % needed)"
                             : "no outline in view";
    return;
  }
  const Eigen::Vector3d seen =
      light::slide_for_shift(colour, centre, plane_normal, outline->shift_px);
  // A clear outline (a sign's, a pillar's sides) resolves a millimetre; a faint one (a rough
  // bunny's a metre away, its outline the rough surface's own) only a gross slide, beyond
  // gross_slide_tolerances: the slide ICP leaves a flat face with.
  const bool clear = outline->matched_fraction >= settings_->clear_outline_matched;
  // Gross: beyond the tolerances, beyond what a pixel's doubt in the edges could make, and a
  // better match there than where the model is (a faint outline's best is often only as bad).
  const bool gross = 1e3 * seen.norm() > settings_->gross_slide_tolerances * result_.tolerance_mm &&
                     outline->shift_px.norm() > kGrossShiftPx &&
                     (clear || outline->cost_px < kGrossCostShare * outline->cost_at_zero_px);
  if (clear || gross) slide = seen;
  // A clear outline's turn is measured too (a gross slide is corrected, then looked at again).
  for (int i = 0; i < 4; ++i) {
    slide_at_[i] = slide;
    if (!clear || gross || result_.expected_colour_px[i].x() < 0) continue;
    slide_at_[i] = light::slide_for_shift(
        colour, M[i], plane_normal, light::outline_moves(*outline, result_.expected_colour_px[i]));
  }
  m.outline_clear = clear;
  m.outline_gross = gross;
  m.outline_text = "the outline seen " + fixed(1e3 * seen.norm(), 1) +
                   " mm from the aligned pose (" + fixed(outline->shift_px.x(), 1) + ", " +
                   fixed(outline->shift_px.y(), 1) + " px, turned " +
                   fixed(rad_to_deg(outline->rotation_rad), 2) + " deg, " +
                   std::to_string(outline->fixed_directions) + " directions fixed, " +
                   fixed(100.0 * outline->matched_fraction, 0) + " % matched)";
}

// The dots in the colour image, lifted onto the surface and compared with the Model Points.
void Verify::measure_dots(const Context& ctx, const light::RegisteredDepth& depth,
                          VerifyMeasured& m) {
  const PinholeModel& colour = ctx.robot().camera.colour.intrinsics;
  const std::array<Eigen::Vector3d, 4>& M = view_->model_points_camera;
  // On a small target the four dots lie closer than search_px: each window must hold one dot
  // only, or the centroid of two is reported as each.
  double search_px = settings_->search_px;
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) {
      search_px = std::min(
          search_px, 0.45 * (result_.expected_colour_px[i] - result_.expected_colour_px[j]).norm());
    }
  }
  const auto found = light::find_dots(capture_.frames()[0], capture_.frames()[1],
                                      result_.expected_colour_px, search_px);
  std::array<Eigen::Vector2d, 4> observed{};
  int seen = 0;
  double sum_mm = 0.0, sum_at_pose_mm = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (!found[i]) {
      m.unseen += (m.unseen.empty() ? "" : ", ") + std::to_string(i + 1);
      continue;
    }
    observed[i] = *found[i];
    // Light lands on the surface, so the error is measured on it: the dot against the Model
    // Point carried along the camera's ray onto the same surface (a Model Point of a rough model
    // floats a few millimetres off the real surface, where no light can land), where the outline
    // puts it; and, apart, where the aligned pose does: the light's miss of the pose is the
    // calibration's.
    const Eigen::Vector3d n =
        normal_near(*view_->model, view_->T_camera_model, ctx.target->model_points[i]);
    const auto on_surface = [&](const Eigen::Vector3d& point) {
      const auto px = colour.project(point);
      return (px ? lift_on_target(depth, colour, *px, point, n) : std::nullopt).value_or(point);
    };
    const Eigen::Vector3d M_seen = M[i] + slide_at_[i];
    const auto p = lift_on_target(depth, colour, *found[i], M_seen, n);
    if (!p) {
      m.unseen += (m.unseen.empty() ? "" : ", ") + std::to_string(i + 1) + " (no surface)";
      continue;
    }
    const double e_mm = 1e3 * (*p - on_surface(M_seen)).norm();
    result_.corner_error_mm[i] = e_mm;
    sum_mm += e_mm;
    sum_at_pose_mm += 1e3 * (*p - on_surface(M[i])).norm();
    ++seen;
  }
  if (seen > 0) result_.observed_colour_px = observed;
  if (seen > 0) result_.observed_error_mm = sum_mm / seen;
  if (seen > 0) m.at_pose_mm = sum_at_pose_mm / seen;
  m.dots_seen = seen;
  m.observed_error_mm = result_.observed_error_mm;
  m.corner_error_mm = result_.corner_error_mm;
}

// The rigid move that carries the Model Points onto where the outline sees them (its shift and
// its turn; a gross slide's is the shift alone), made to the aligned pose for the next look.
void Verify::correct_pose(Context& ctx) const {
  const std::array<Eigen::Vector3d, 4>& M = view_->model_points_camera;
  AlignResult corrected = *ctx.blackboard().find(keys::kAlign);
  Eigen::Matrix<double, 3, 4> from, to;
  for (int i = 0; i < 4; ++i) {
    from.col(i) = M[i];
    to.col(i) = M[i] + slide_at_[i];
  }
  const Eigen::Isometry3d T_seen_aligned(Eigen::umeyama(from, to, false));
  corrected.T_camera_model = T_seen_aligned * view_->T_camera_model;
  ctx.blackboard().set(keys::kAlign, std::move(corrected));
}

// The camera's own view of the check, for a person: the lit content area, the Model Points where
// the robot expects them (green) and the dots where it saw them (red).
void Verify::write_view(const Context& ctx) const {
  if (ctx.target_dir.empty() || capture_.frames().size() < 3) return;
  cv::Mat view = as_mat(capture_.frames()[2]);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d& e = result_.expected_colour_px[i];
    cv::drawMarker(view, cv::Point2d(e.x(), e.y()), cv::Scalar(0, 255, 0), cv::MARKER_CROSS, 12, 1);
    if (result_.observed_colour_px && result_.corner_error_mm[i]) {
      const Eigen::Vector2d& o = (*result_.observed_colour_px)[i];
      cv::circle(view, cv::Point2d(o.x(), o.y()), 6, cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
    }
  }
  const std::filesystem::path file = ctx.target_dir / "camera_view.png";
  try {
    write_run_image(file, view);
  } catch (const std::exception& e) {
    ctx.log().warning(target_prefix(ctx) + e.what());
  }
}

}  // namespace projtour::closed_loop
