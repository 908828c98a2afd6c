// Service `mrpt_localization` (role localization): Monte Carlo localization for the whole tour.
// Every tick it accumulates the base's odometry and takes the laser's newest scan; the filter
// runs when the robot has moved enough or every few scans at rest, and the estimate (the last
// filter mean moved by the odometry since) goes on the blackboard every tick.
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/plugin_author.hpp"
#include "projtour/navigation/localizer.hpp"

namespace projtour::localization {
namespace {
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kParticles = "particles";
inline constexpr const char* kInitSpreadM = "init_spread_m";
inline constexpr const char* kInitSpreadDeg = "init_spread_deg";
inline constexpr const char* kOdomTransNoiseFrac = "odom_trans_noise_frac";
inline constexpr const char* kOdomRotNoiseFrac = "odom_rot_noise_frac";
inline constexpr const char* kLfSigmaM = "lf_sigma_m";
inline constexpr const char* kLfDecimation = "lf_decimation";
inline constexpr const char* kLfField = "lf_field";
inline constexpr const char* kShortReadingM = "short_reading_m";
inline constexpr const char* kInjectMaxFrac = "inject_max_frac";
inline constexpr const char* kUpdateMinDistM = "update_min_dist_m";
inline constexpr const char* kUpdateMinAngleDeg = "update_min_angle_deg";
inline constexpr const char* kUpdateEveryScans = "update_every_scans";
inline constexpr const char* kConvergedStdM = "converged_std_m";
inline constexpr const char* kConvergedStdDeg = "converged_std_deg";
inline constexpr const char* kConvergedMinFit = "converged_min_fit";
inline constexpr const char* kWidenYawDeg = "widen_yaw_deg";
}  // namespace param

navigation::LocalizerOptions options_from(const Params& p) {
  navigation::LocalizerOptions o;
  o.particles = static_cast<int>(p.integer(param::kParticles));
  o.init_spread_m = p.number(param::kInitSpreadM);
  o.init_spread_deg = p.number(param::kInitSpreadDeg);
  o.odom_trans_noise_frac = p.number(param::kOdomTransNoiseFrac);
  o.odom_rot_noise_frac = p.number(param::kOdomRotNoiseFrac);
  o.lf_sigma_m = p.number(param::kLfSigmaM);
  o.lf_decimation = static_cast<int>(p.integer(param::kLfDecimation));
  o.lf_field = p.string(param::kLfField) == "occupied"
                   ? navigation::LocalizerOptions::Field::occupied
                   : navigation::LocalizerOptions::Field::boundary;
  o.short_reading_m = p.number(param::kShortReadingM);
  o.inject_max_frac = p.number(param::kInjectMaxFrac);
  o.converged_std_m = p.number(param::kConvergedStdM);
  o.converged_std_deg = p.number(param::kConvergedStdDeg);
  o.converged_min_fit = p.number(param::kConvergedMinFit);
  return o;
}

class MrptLocalization : public Service {
 public:
  MrptLocalization(const Params& params, const RunContext& run)
      : params_(params),
        update_min_dist_m_(params.number(param::kUpdateMinDistM)),
        update_min_angle_rad_(deg_to_rad(params.number(param::kUpdateMinAngleDeg))),
        update_every_scans_(params.integer(param::kUpdateEveryScans)),
        widen_yaw_rad_(deg_to_rad(params.number(param::kWidenYawDeg))) {
    if (!run.map) throw std::runtime_error("mrpt_localization needs the mission's map");
    localizer_ = std::make_unique<navigation::Localizer>(*run.map, options_from(params), run.seed);
  }

  void start(Context& ctx) override {
    if (!ctx.drivers().base || !ctx.drivers().laser) {
      throw std::runtime_error("mrpt_localization needs a base and a laser driver");
    }
    localizer_->reset(ctx.mission().start);
    last_odometry_.reset();
    pending_ = Pose2D{};
    scans_since_update_ = 0;
    publish(ctx);
  }

  void update(Context& ctx) override {
    Blackboard& board = ctx.blackboard();
    const Pose2D odometry = ctx.drivers().base->odometry().pose;
    if (last_odometry_)
      pending_ =
          navigation::pose_compose(pending_, navigation::pose_delta(*last_odometry_, odometry));
    last_odometry_ = odometry;

    if (const double* widen_m = board.find(keys::kLocalizationWiden)) {
      if (*widen_m > 0.0) localizer_->widen(*widen_m, widen_yaw_rad_);
      board.erase(keys::kLocalizationWiden);
    }

    if (auto scan = ctx.drivers().laser->take_scan()) {
      ++scans_since_update_;
      const bool moved = std::hypot(pending_.x_m, pending_.y_m) >= update_min_dist_m_ ||
                         std::abs(pending_.yaw_rad) >= update_min_angle_rad_;
      if (moved || scans_since_update_ >= update_every_scans_) {
        localizer_->update(pending_, *scan);
        pending_ = Pose2D{};
        scans_since_update_ = 0;
      }
      board.set(keys::kLaserScan, std::move(*scan));
    }
    publish(ctx);
  }

  void stop(Context&) override {}

 private:
  void publish(Context& ctx) {
    PoseEstimate2D estimate = localizer_->estimate();
    estimate.mean = navigation::pose_compose(estimate.mean, pending_);
    estimate.t_s = ctx.now_s();
    ctx.blackboard().set(keys::kLocalization, estimate);
    ctx.blackboard().set(keys::kLocalizationConverged, localizer_->converged());
  }

  Params params_;
  double update_min_dist_m_;
  double update_min_angle_rad_;
  long long update_every_scans_;
  double widen_yaw_rad_;
  std::unique_ptr<navigation::Localizer> localizer_;
  std::optional<Pose2D> last_odometry_;
  Pose2D pending_;
  long long scans_since_update_ = 0;
};

int validate(const void* raw, char* error, size_t error_size) {
  const Params& p = *static_cast<const Params*>(raw);
  std::string why;
  // A million particles take about 3 s an update: no tour keeps up with that (40,000 localize
  // a robot over a whole campus from nothing).
  constexpr long long kMaxParticles = 1000000;
  if (p.integer(param::kParticles) < 10 || p.integer(param::kParticles) > kMaxParticles)
    why = "particles: expected from 10 to " + std::to_string(kMaxParticles) + ", got " +
          std::to_string(p.integer(param::kParticles));
  else if (p.integer(param::kLfDecimation) < 1)
    why = "lf_decimation: expected at least 1";
  else if (p.integer(param::kUpdateEveryScans) < 1)
    why = "update_every_scans: expected at least 1";
  else if (!(p.number(param::kLfSigmaM) > 0.0))
    why = "lf_sigma_m: expected a positive number";
  else if (p.string(param::kLfField) != "boundary" && p.string(param::kLfField) != "occupied")
    why = "lf_field: expected \"boundary\" or \"occupied\", got \"" + p.string(param::kLfField) +
          "\"";
  else if (!(p.number(param::kShortReadingM) >= 0.0))
    why = "short_reading_m: expected 0 (off) or a positive number";
  else if (!(p.number(param::kInjectMaxFrac) >= 0.0 && p.number(param::kInjectMaxFrac) <= 1.0))
    why = "inject_max_frac: expected a number from 0 to 1";
  if (why.empty()) return 0;
  plugin_detail::copy_message(why.c_str(), error, error_size);
  return 1;
}

const projtour_param_desc kParams[] = {
    {param::kParticles, "integer", "1000", "particle count (one update takes about 3 ms per 1000)"},
    {param::kInitSpreadM, "number", "0.3", "initial cloud: +- this around the mission's start"},
    {param::kInitSpreadDeg, "number", "10", "initial cloud: +- this heading around the start's"},
    {param::kOdomTransNoiseFrac, "number", "0.08", "odometry error per metre travelled"},
    {param::kOdomRotNoiseFrac, "number", "0.08", "odometry error per radian turned"},
    {param::kLfSigmaM, "number", "0.1", "laser likelihood field: range error standard deviation"},
    {param::kLfDecimation, "integer", "6", "use one laser ray in this many"},
    {param::kLfField, "string", "boundary",
     "likelihood field from the walls' boundary (\"boundary\") or every occupied cell "
     "(\"occupied\", MRPT's own; forgives endpoints inside thick walls)"},
    {param::kShortReadingM, "number", "0.3",
     "once converged, leave out rays this much shorter than the map predicts (0: off)"},
    // Off in a tour: there navigate reports `lost` when the scans stop fitting and relocalize
    // spreads the cloud afresh; a local redraw pre-empts that and can settle on a nearby pose that
    // fits as well (a robot carried 2 m, tests/integration/data/w_kidnap.yaml: 1.5 m off with
    // every ray on a wall). On for `projtour localize`, which has no relocalize.
    {param::kInjectMaxFrac, "number", "0",
     "depletion guard: largest share of particles redrawn near the estimate when the scans "
     "suddenly stop fitting (0: off, the default: navigate's lost and relocalize recover)"},
    {param::kUpdateMinDistM, "number", "0.05", "filter update after this much travel"},
    {param::kUpdateMinAngleDeg, "number", "2", "filter update after this much turning"},
    {param::kUpdateEveryScans, "integer", "5", "filter update at least every N scans at rest"},
    {param::kConvergedStdM, "number", "0.15", "converged below this position standard deviation"},
    {param::kConvergedStdDeg, "number", "5", "converged below this heading standard deviation"},
    {param::kConvergedMinFit, "number", "0.5",
     "and while this share of scan endpoints lands within 0.2 m of the map's walls"},
    {param::kWidenYawDeg, "number", "30", "heading spread added when asked to widen the cloud"},
};

const projtour_key_desc kKeys[] = {writes(keys::kLocalization),
                                   writes(keys::kLocalizationConverged), writes(keys::kLaserScan),
                                   reads_if_present(keys::kLocalizationWiden)};

const projtour_kind_desc kKinds[] = {with_keys(
    projtour::service_kind<MrptLocalization>(
        "mrpt_localization", "localization",
        "MRPT Monte Carlo localization: odometry motion model, laser likelihood field on the map",
        kParams, &validate),
    kKeys)};

}  // namespace
}  // namespace projtour::localization

PROJTOUR_PLUGIN("localization", "1.0.0", projtour::localization::kKinds)
