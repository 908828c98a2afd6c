// Behaviour `align`: the target's pose in the camera frame from the captured depth frame.
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "alignment_image.hpp"
#include "pcl_registration.hpp"
#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/plugin_author.hpp"
#include "projtour/head/kinematics.hpp"
#include "projtour/perception/model.hpp"
#include "projtour/perception/registration.hpp"

namespace projtour::align {
namespace {
// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kPoorFit = "poor_fit";
inline constexpr const char* kNoTarget = "no_target";
}  // namespace outcome
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kMethod = "method";
inline constexpr const char* kModelSpacingM = "model_spacing_m";
inline constexpr const char* kCropMarginM = "crop_margin_m";
inline constexpr const char* kMinPoints = "min_points";
inline constexpr const char* kMinInlierFraction = "min_inlier_fraction";
inline constexpr const char* kMaxRmseMm = "max_rmse_mm";
inline constexpr const char* kInlierDistanceM = "inlier_distance_m";
inline constexpr const char* kPclMaxIterations = "pcl_max_iterations";
inline constexpr const char* kPclMaxCorrespondenceM = "pcl_max_correspondence_m";
inline constexpr const char* kDraw = "draw";
}  // namespace param

enum class Method { projective_icp, pcl_icp, pcl_gicp };

bool parse_method(const std::string& text, Method& out) {
  if (text == "projective_icp") return out = Method::projective_icp, true;
  if (text == "pcl_icp") return out = Method::pcl_icp, true;
  if (text == "pcl_gicp") return out = Method::pcl_gicp, true;
  return false;
}

struct Settings {
  Method method = Method::projective_icp;
  std::string method_name;
  double model_spacing_m = 0.0;  // from the parameters (default kDefaultModelSpacingM)
  double crop_margin_m = 0.1;
  long long min_points = 500;
  double min_inlier_fraction = 0.6;
  double max_rmse_mm = 5.0;
  double inlier_distance_m = 0.006;
  long long pcl_max_iterations = 50;
  double pcl_max_correspondence_m = 0.05;
  bool draw = true;
};

// Throws std::invalid_argument naming the parameter; the loader and the constructor share it.
Settings read_settings(const Params& p) {
  Settings s;
  s.method_name = p.string(param::kMethod);
  if (!parse_method(s.method_name, s.method)) {
    throw std::invalid_argument("method: \"" + s.method_name +
                                "\" is not one of projective_icp, pcl_icp, pcl_gicp");
  }
  s.model_spacing_m = p.number(param::kModelSpacingM);
  s.crop_margin_m = p.number(param::kCropMarginM);
  s.min_points = p.integer(param::kMinPoints);
  s.min_inlier_fraction = p.number(param::kMinInlierFraction);
  s.max_rmse_mm = p.number(param::kMaxRmseMm);
  s.inlier_distance_m = p.number(param::kInlierDistanceM);
  s.pcl_max_iterations = p.integer(param::kPclMaxIterations);
  s.pcl_max_correspondence_m = p.number(param::kPclMaxCorrespondenceM);
  s.draw = p.boolean(param::kDraw);
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0)) throw std::invalid_argument(std::string(name) + ": must be > 0");
  };
  positive(s.model_spacing_m, "model_spacing_m");
  positive(s.inlier_distance_m, "inlier_distance_m");
  positive(s.max_rmse_mm, "max_rmse_mm");
  positive(static_cast<double>(s.pcl_max_iterations), "pcl_max_iterations");
  positive(s.pcl_max_correspondence_m, "pcl_max_correspondence_m");
  if (s.crop_margin_m < 0.0) throw std::invalid_argument("crop_margin_m: must be >= 0");
  if (s.min_inlier_fraction < 0.0 || s.min_inlier_fraction > 1.0) {
    throw std::invalid_argument("min_inlier_fraction: must lie in [0, 1]");
  }
  return s;
}

std::string format_quality(const perception::RegistrationResult& r) {
  std::ostringstream s;
  s.precision(3);
  s << "inlier fraction " << r.inlier_fraction << ", RMSE " << r.rmse_mm << " mm, " << r.iterations
    << " iterations";
  return s.str();
}

class Align : public Behaviour {
 public:
  Align(const Params& params, const RunContext&) : settings_(read_settings(params)) {
    icp_options_.inlier_distance_m = settings_.inlier_distance_m;
  }

  void start(Context& ctx) override {
    if (ctx.target == nullptr) return;
    // Loading and resampling a model takes a while: once per visit (re-aims and re-captures
    // reuse it); only the current target's is kept, so memory does not grow over a long tour.
    if (models_.count(ctx.target->id) == 0) {
      models_.clear();
      auto cloud = std::make_shared<const ModelCloud>(
          perception::load_model_cloud(ctx.target->model, settings_.model_spacing_m));
      models_[ctx.target->id] = {cloud, std::make_shared<const perception::IcpModel>(*cloud)};
    }
  }

  std::optional<Outcome> tick(Context& ctx) override {
    if (ctx.cancel_requested()) return Outcome{kOutcomeCancelled, "cancelled"};
    if (ctx.target == nullptr)
      return Outcome{kOutcomeFailed, "align runs only within a target visit"};
    Blackboard& bb = ctx.blackboard();
    const CapturedFrame* captured = bb.find(keys::kCapture);
    if (captured == nullptr) {
      return Outcome{kOutcomeFailed,
                     "no depth frame on the blackboard (capture runs before align)"};
    }
    const DepthFrame& frame = captured->frame;
    const LoadedModel& loaded = models_.at(ctx.target->id);
    const std::shared_ptr<const perception::IcpModel>& model = loaded.icp;
    const CameraSpec& camera = ctx.robot().camera;

    const auto started = std::chrono::steady_clock::now();
    AlignResult out;
    out.model = loaded.cloud;
    out.joints = captured->joints;
    // The camera where it was when the frame was taken, not where it is now.
    const Eigen::Isometry3d T_map_camera =
        isometry_from_pose2d(captured->base_estimate.mean) *
        head::HeadKinematics(ctx.robot()).T_base_camera(out.joints);
    const Eigen::Isometry3d T_camera_model_guess = T_map_camera.inverse() * ctx.target->T_map_model;
    out.T_camera_model_guess = T_camera_model_guess;
    // A visit that has aligned already (after a re-approach, a re-aim, a re-capture) starts from
    // that pose, carried through whatever the base and head did since, and with verify's slide
    // in it: the map's belief may be the very guess ICP slid from.
    Eigen::Isometry3d T_camera_model_start = T_camera_model_guess;
    const AlignResult* previous = bb.find(keys::kAlign);
    if (previous != nullptr && previous->T_camera_model && last_fit_ &&
        last_fit_->target_id == ctx.target->id &&
        last_fit_->joints.pan_rad == previous->joints.pan_rad &&
        last_fit_->joints.tilt_rad == previous->joints.tilt_rad) {
      T_camera_model_start =
          T_map_camera.inverse() * last_fit_->T_map_camera * *previous->T_camera_model;
    }
    const perception::OrganizedCloud scene =
        perception::crop_sphere(frame, camera.depth_to_color_m, T_camera_model_start.translation(),
                                model->bounding_radius_m() + settings_.crop_margin_m);
    const std::size_t scene_points = scene.valid_count();
    if (scene_points < static_cast<std::size_t>(settings_.min_points)) {
      bb.set(keys::kAlign, std::move(out));
      std::ostringstream why;
      why << scene_points << " points within "
          << model->bounding_radius_m() + settings_.crop_margin_m
          << " m of the expected target (at least " << settings_.min_points << " needed)";
      if (settings_.draw) draw(ctx, frame, scene, *model, T_camera_model_guess, nullptr);
      return Outcome{outcome::kNoTarget, why.str()};
    }

    perception::RegistrationResult result = register_scene(model, scene, T_camera_model_start);
    result.time_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started)
            .count();
    out.quality = AlignQuality{settings_.method_name, result.time_ms, result.iterations,
                               result.inlier_fraction, result.rmse_mm};
    if (settings_.draw) draw(ctx, frame, scene, *model, T_camera_model_guess, &result);

    const bool good = result.converged && result.inlier_fraction >= settings_.min_inlier_fraction &&
                      result.rmse_mm <= settings_.max_rmse_mm;
    ctx.log().info("align " + ctx.target->id + " (" + settings_.method_name +
                   "): " + format_quality(result));
    if (!good) {
      bb.set(keys::kAlign, std::move(out));
      std::ostringstream why;
      why << "poor fit: " << format_quality(result)
          << " (gate: inlier fraction >= " << settings_.min_inlier_fraction
          << ", RMSE <= " << settings_.max_rmse_mm << " mm)";
      if (!result.converged) why << "; too few correspondences";
      return Outcome{outcome::kPoorFit, why.str()};
    }
    out.T_camera_model = result.T_camera_model;
    last_fit_ = LastFit{ctx.target->id, out.joints, T_map_camera};
    bb.set(keys::kAlign, std::move(out));
    return Outcome{outcome::kSucceeded, format_quality(result)};
  }

 private:
  perception::RegistrationResult register_scene(
      const std::shared_ptr<const perception::IcpModel>& model,
      const perception::OrganizedCloud& scene, const Eigen::Isometry3d& guess) {
    if (settings_.method == Method::projective_icp) {
      return perception::align_projective_icp(*model, scene, guess, icp_options_);
    }
    PclOptions options;
    options.max_iterations = static_cast<int>(settings_.pcl_max_iterations);
    options.max_correspondence_m = settings_.pcl_max_correspondence_m;
    const PclMethod method = settings_.method == Method::pcl_icp ? PclMethod::icp : PclMethod::gicp;
    const PclRegistration pcl(model, method, options);
    return pcl.align(scene, guess, icp_options_);
  }

  void draw(Context& ctx, const DepthFrame& frame, const perception::OrganizedCloud& scene,
            const perception::IcpModel& model, const Eigen::Isometry3d& guess,
            const perception::RegistrationResult* result) const {
    if (ctx.target_dir.empty()) return;
    try {
      write_alignment_image(ctx.target_dir / "alignment.png", frame, scene, model, guess,
                            result ? &result->T_camera_model : nullptr);
    } catch (const std::exception& e) {
      ctx.log().warning(std::string("align: cannot write alignment.png: ") + e.what());
    }
  }

  Settings settings_;
  perception::IcpOptions icp_options_;
  // The cloud is what align publishes (project's tracking fits the same points); the IcpModel
  // is its registration layout.
  struct LoadedModel {
    std::shared_ptr<const ModelCloud> cloud;
    std::shared_ptr<const perception::IcpModel> icp;
  };
  std::map<std::string, LoadedModel> models_;
  // Where the camera was for the last good fit: the blackboard's AlignResult holds the pose in
  // that capture's camera frame, and the capture on the blackboard is by now the next one.
  struct LastFit {
    std::string target_id;
    JointAngles joints;
    Eigen::Isometry3d T_map_camera;
  };
  std::optional<LastFit> last_fit_;
};

const projtour_param_desc kAlignParams[] = {
    {param::kMethod, "string", "projective_icp", "projective_icp | pcl_icp | pcl_gicp"},
    {param::kModelSpacingM, "number", perception::kDefaultModelSpacingM,
     "spacing of the points resampled on the model"},
    {param::kCropMarginM, "number", "0.1",
     "the frame is cropped to the model's bounding sphere plus this around the guess"},
    {param::kMinPoints, "integer", "500", "fewer points in the crop: no_target"},
    {param::kMinInlierFraction, "number", "0.4",
     "quality gate: less is a poor_fit (verify's colour camera decides whether the content lands; "
     "this refuses only what is plainly not the target, a rough scan fitting at about 0.5)"},
    {param::kMaxRmseMm, "number", "5.0", "quality gate: more is a poor_fit"},
    {param::kInlierDistanceM, "number", "0.006",
     "a visible model point within this of its scene point is an inlier"},
    {param::kPclMaxIterations, "integer", "50", "pcl_icp / pcl_gicp: iteration limit"},
    {param::kPclMaxCorrespondenceM, "number", "0.05",
     "pcl_icp / pcl_gicp: correspondence distance"},
    {param::kDraw, "boolean", "true", "write alignment.png into the target's folder"},
};
const char* const kAlignOutcomes[] = {outcome::kSucceeded, outcome::kPoorFit, outcome::kNoTarget};
const projtour_key_desc kAlignKeys[] = {reads(keys::kCapture), reads_if_present(keys::kAlign),
                                        writes(keys::kAlign)};
const projtour_kind_desc kKinds[] = {with_keys(
    behaviour_kind<Align>("align", "ICP of the target's model against the captured depth frame",
                          kAlignParams, kAlignOutcomes, validator<read_settings>()),
    kAlignKeys)};

}  // namespace
}  // namespace projtour::align

PROJTOUR_PLUGIN("align", "1.0.0", projtour::align::kKinds)
