// Service `mrpt_localization` (role localization): Monte Carlo localization for the whole tour.
// Every tick it accumulates the base's odometry and takes the laser's newest scan; the filter
// runs when the robot has moved enough or every few scans at rest, and the estimate (the last
// filter mean moved by the odometry since) goes on the blackboard every tick.
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "projtour/blackboard_keys.hpp"
#include "projtour/localizer.hpp"
#include "projtour/plugin_author.hpp"

namespace projtour::localization {
namespace {

LocalizerOptions options_from(const Params& p) {
  LocalizerOptions o;
  o.particles = static_cast<int>(p.integer("particles"));
  o.init_spread_m = p.number("init_spread_m");
  o.init_spread_deg = p.number("init_spread_deg");
  o.odom_trans_noise_frac = p.number("odom_trans_noise_frac");
  o.odom_rot_noise_frac = p.number("odom_rot_noise_frac");
  o.lf_sigma_m = p.number("lf_sigma_m");
  o.lf_decimation = static_cast<int>(p.integer("lf_decimation"));
  o.lf_field = p.string("lf_field") == "occupied" ? LocalizerOptions::Field::occupied
                                                  : LocalizerOptions::Field::boundary;
  o.short_reading_m = p.number("short_reading_m");
  o.inject_max_frac = p.number("inject_max_frac");
  o.converged_std_m = p.number("converged_std_m");
  o.converged_std_deg = p.number("converged_std_deg");
  o.converged_min_fit = p.number("converged_min_fit");
  return o;
}

class MrptLocalization : public Service {
 public:
  MrptLocalization(const Params& params, const RunContext& run)
      : params_(params),
        update_min_dist_m_(params.number("update_min_dist_m")),
        update_min_angle_rad_(deg_to_rad(params.number("update_min_angle_deg"))),
        update_every_scans_(params.integer("update_every_scans")),
        widen_yaw_rad_(deg_to_rad(params.number("widen_yaw_deg"))) {
    if (!run.map) throw std::runtime_error("mrpt_localization needs the mission's map");
    localizer_ = std::make_unique<Localizer>(*run.map, options_from(params), run.seed);
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
    if (last_odometry_) pending_ = pose_compose(pending_, pose_delta(*last_odometry_, odometry));
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
    estimate.mean = pose_compose(estimate.mean, pending_);
    estimate.t_s = ctx.now_s();
    ctx.blackboard().set(keys::kLocalization, estimate);
    ctx.blackboard().set(keys::kLocalizationConverged, localizer_->converged());
  }

  Params params_;
  double update_min_dist_m_;
  double update_min_angle_rad_;
  long long update_every_scans_;
  double widen_yaw_rad_;
  std::unique_ptr<Localizer> localizer_;
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
  if (p.integer("particles") < 10 || p.integer("particles") > kMaxParticles)
    why = "particles: expected from 10 to " + std::to_string(kMaxParticles) + ", got " +
          std::to_string(p.integer("particles"));
  else if (p.integer("lf_decimation") < 1)
    why = "lf_decimation: expected at least 1";
  else if (p.integer("update_every_scans") < 1)
    why = "update_every_scans: expected at least 1";
  else if (!(p.number("lf_sigma_m") > 0.0))
    why = "lf_sigma_m: expected a positive number";
  else if (p.string("lf_field") != "boundary" && p.string("lf_field") != "occupied")
    why = "lf_field: expected \"boundary\" or \"occupied\", got \"" + p.string("lf_field") + "\"";
  else if (!(p.number("short_reading_m") >= 0.0))
    why = "short_reading_m: expected 0 (off) or a positive number";
  else if (!(p.number("inject_max_frac") >= 0.0 && p.number("inject_max_frac") <= 1.0))
    why = "inject_max_frac: expected a number from 0 to 1";
  if (why.empty()) return 0;
  plugin_detail::copy_message(why.c_str(), error, error_size);
  return 1;
}

const projtour_param_desc kParams[] = {
    {"particles", "integer", "1000", "particle count (one update takes about 3 ms per 1000)"},
    {"init_spread_m", "number", "0.3", "initial cloud: +- this around the mission's start"},
    {"init_spread_deg", "number", "10", "initial cloud: +- this heading around the start's"},
    {"odom_trans_noise_frac", "number", "0.08", "odometry error per metre travelled"},
    {"odom_rot_noise_frac", "number", "0.08", "odometry error per radian turned"},
    {"lf_sigma_m", "number", "0.1", "laser likelihood field: range error standard deviation"},
    {"lf_decimation", "integer", "6", "use one laser ray in this many"},
    {"lf_field", "string", "boundary",
     "likelihood field from the walls' boundary (\"boundary\") or every occupied cell "
     "(\"occupied\", MRPT's own; forgives endpoints inside thick walls)"},
    {"short_reading_m", "number", "0.3",
     "once converged, leave out rays this much shorter than the map predicts (0: off)"},
    // Off in a tour: there navigate reports `lost` when the scans stop fitting and relocalize
    // spreads the cloud afresh; a local redraw pre-empts that and can settle on a nearby pose that
    // fits as well (a robot carried 2 m, tests/integration/data/w_kidnap.yaml: 1.5 m off with
    // every ray on a wall). On for `projtour localize`, which has no relocalize.
    {"inject_max_frac", "number", "0",
     "depletion guard: largest share of particles redrawn near the estimate when the scans "
     "suddenly stop fitting (0: off, the default: navigate's lost and relocalize recover)"},
    {"update_min_dist_m", "number", "0.05", "filter update after this much travel"},
    {"update_min_angle_deg", "number", "2", "filter update after this much turning"},
    {"update_every_scans", "integer", "5", "filter update at least every N scans at rest"},
    {"converged_std_m", "number", "0.15", "converged below this position standard deviation"},
    {"converged_std_deg", "number", "5", "converged below this heading standard deviation"},
    {"converged_min_fit", "number", "0.5",
     "and while this share of scan endpoints lands within 0.2 m of the map's walls"},
    {"widen_yaw_deg", "number", "30", "heading spread added when asked to widen the cloud"},
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
