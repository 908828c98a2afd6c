// The testing plugin: scripted behaviours with the outcome sets of the tour's steps, null
// drivers that record their safe stops, and a dead-reckoning localization service, so a tour
// can run end to end without the simulator or hardware.
#include <atomic>
#include <fstream>
#include <mutex>
#include <sstream>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/plugin_author.hpp"
#include "projtour/contract/run_files.hpp"
#include "scripted_behaviour.hpp"

namespace projtour::testing {
namespace {
// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kUnreachable = "unreachable";
inline constexpr const char* kBlocked = "blocked";
inline constexpr const char* kTimeout = "timeout";
inline constexpr const char* kLost = "lost";
inline constexpr const char* kOutOfReach = "out_of_reach";
inline constexpr const char* kReapproach = "reapproach";
inline constexpr const char* kNoFrame = "no_frame";
inline constexpr const char* kPoorFit = "poor_fit";
inline constexpr const char* kNoTarget = "no_target";
inline constexpr const char* kOffScreen = "off_screen";
}  // namespace outcome
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kLogSafeStops = "log_safe_stops";
inline constexpr const char* kPublishConverged = "publish_converged";
}  // namespace param

int validate_scripted(const void* params, char* error, size_t error_size) {
  const std::string why = validate_script(*static_cast<const Params*>(params));
  if (why.empty()) return 0;
  plugin_detail::copy_message(why.c_str(), error, error_size);
  return 1;
}

// A driver that does nothing but note each safe stop in run_dir/test_drivers.log, so tests can
// check that an interrupted or aborted tour stopped every device.
class NullDevice {
 public:
  NullDevice(const char* kind, const Params& params, const RunContext& run)
      : kind_(kind), log_(params.boolean(param::kLogSafeStops)), run_dir_(run.run_dir) {}
  void note_safe_stop() noexcept { note("safe_stop"); }
  // One line "<kind> <event>" per call.
  void note(const std::string& event) noexcept {
    if (!log_ || run_dir_.empty()) return;
    try {
      AppendOnlyFile(run_dir_ / "test_drivers.log").append(std::string(kind_) + " " + event + "\n");
    } catch (const std::exception&) {  // noexcept: called from safe_stop; the log is the tests'
    }
  }

 private:
  const char* kind_;
  bool log_;
  std::filesystem::path run_dir_;
};

// Integrates commanded velocities exactly: odometry is the truth of this null world. Locked:
// the tick watchdog's safe_stop may come from its thread while a tick is inside update().
class TestBase : public BaseDriver {
 public:
  TestBase(const Params& params, const RunContext& run) : device_("test_base", params, run) {
    odometry_.pose = run.mission != nullptr ? run.mission->start : Pose2D{};
  }
  void update(double t_s) override {
    std::lock_guard<std::mutex> lock(mutex_);
    const double dt_s = t_s - odometry_.t_s;
    odometry_.t_s = t_s;
    if (dt_s <= 0) return;
    odometry_.pose.x_m += odometry_.v_mps * std::cos(odometry_.pose.yaw_rad) * dt_s;
    odometry_.pose.y_m += odometry_.v_mps * std::sin(odometry_.pose.yaw_rad) * dt_s;
    odometry_.pose.yaw_rad = wrap_angle_rad(odometry_.pose.yaw_rad + odometry_.w_radps * dt_s);
  }
  void safe_stop() override {
    command_velocity(0, 0);
    device_.note_safe_stop();
  }
  void command_velocity(double v_mps, double w_radps) override {
    std::lock_guard<std::mutex> lock(mutex_);
    odometry_.v_mps = v_mps;
    odometry_.w_radps = w_radps;
  }
  Odometry odometry() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return odometry_;
  }

 private:
  NullDevice device_;
  mutable std::mutex mutex_;
  Odometry odometry_;
};

class TestLaser : public LaserDriver {
 public:
  TestLaser(const Params& params, const RunContext& run) : device_("test_laser", params, run) {}
  void safe_stop() override { device_.note_safe_stop(); }
  std::optional<LaserScan> take_scan() override { return std::nullopt; }

 private:
  NullDevice device_;
};

// Reaches every command at once.
class TestPanTilt : public PanTiltDriver {
 public:
  TestPanTilt(const Params& params, const RunContext& run)
      : device_("test_pan_tilt", params, run) {}
  void safe_stop() override { device_.note_safe_stop(); }
  void command(const JointAngles& angles) override { angles_ = angles; }
  JointAngles measured() const override { return angles_; }
  bool reached() const override { return true; }

 private:
  NullDevice device_;
  JointAngles angles_;
};

class TestDepthCamera : public DepthCameraDriver {
 public:
  TestDepthCamera(const Params& params, const RunContext& run)
      : device_("test_depth_camera", params, run) {}
  void safe_stop() override { device_.note_safe_stop(); }
  std::optional<DepthFrame> grab() override { return std::nullopt; }

 private:
  NullDevice device_;
};

// Never delivers a frame; notes each exposure setting, so tests can check a sequence fixed the
// exposure and gave it back.
class TestColourCamera : public ColourCameraDriver {
 public:
  TestColourCamera(const Params& params, const RunContext& run)
      : device_("test_colour_camera", params, run) {}
  void safe_stop() override { device_.note_safe_stop(); }
  std::optional<ColourFrame> grab() override { return std::nullopt; }
  void set_exposure_ms(double exposure_ms) override {
    std::ostringstream event;
    event << "set_exposure_ms " << exposure_ms;
    device_.note(event.str());
  }

 private:
  NullDevice device_;
};

class TestProjector : public ProjectorDriver {
 public:
  TestProjector(const Params& params, const RunContext& run)
      : device_("test_projector", params, run) {}
  void safe_stop() override {
    blank_ = true;
    device_.note_safe_stop();
  }
  void show(const cv::Mat&) override { blank_ = false; }
  void blank() override { blank_ = true; }
  bool is_blank() const override { return blank_; }

 private:
  NullDevice device_;
  std::atomic<bool> blank_{true};  // safe_stop may come from the watchdog's thread
};

// Dead reckoning: the base's odometry as the localization estimate.
class OdometryLocalization : public Service {
 public:
  OdometryLocalization(const Params& params, const RunContext&)
      : publish_converged_(params.boolean(param::kPublishConverged)) {}
  void start(Context& ctx) override { update(ctx); }
  void update(Context& ctx) override {
    if (!ctx.run->drivers || !ctx.drivers().base) return;
    const Odometry odometry = ctx.drivers().base->odometry();
    PoseEstimate2D estimate;
    estimate.mean = odometry.pose;
    estimate.t_s = ctx.now_s();
    ctx.blackboard().set(keys::kLocalization, estimate);
    if (publish_converged_) ctx.blackboard().set(keys::kLocalizationConverged, true);
  }

 private:
  bool publish_converged_;
};

const char* const kSucceeded[] = {outcome::kSucceeded};
const projtour_key_desc kLocalizationKeys[] = {writes(keys::kLocalization),
                                               writes(keys::kLocalizationConverged)};
const char* const kNavigate[] = {outcome::kSucceeded, outcome::kUnreachable, outcome::kBlocked,
                                 outcome::kTimeout, outcome::kLost};
const char* const kRelocalize[] = {outcome::kSucceeded, outcome::kLost};
const char* const kAim[] = {outcome::kSucceeded, outcome::kOutOfReach, outcome::kReapproach};
const char* const kCapture[] = {outcome::kSucceeded, outcome::kNoFrame};
const char* const kAlign[] = {outcome::kSucceeded, outcome::kPoorFit, outcome::kNoTarget};
const char* const kProject[] = {outcome::kSucceeded, outcome::kOffScreen};
const char* const kNext[] = {outcome::kSucceeded};
const projtour_param_desc kNullDeviceParams[] = {
    {param::kLogSafeStops, "boolean", "true", "append each safe stop to run_dir/test_drivers.log"}};
const projtour_param_desc kColourCameraParams[] = {
    {param::kLogSafeStops, "boolean", "true",
     "append each safe stop and each exposure setting to run_dir/test_drivers.log"}};
const projtour_param_desc kLocalizationParams[] = {
    {param::kPublishConverged, "boolean", "true", "report the estimate as converged"}};

const projtour_kind_desc kKinds[] = {
    behaviour_kind<ScriptedBehaviour>("scripted", "plays a script of outcomes", kScriptedParams,
                                      kSucceeded, validate_scripted),
    behaviour_kind<ScriptedBehaviour>("scripted_navigate", "scripted, navigate's outcomes",
                                      kScriptedParams, kNavigate, validate_scripted),
    behaviour_kind<ScriptedBehaviour>("scripted_relocalize", "scripted, relocalize's outcomes",
                                      kScriptedParams, kRelocalize, validate_scripted),
    behaviour_kind<ScriptedBehaviour>("scripted_aim", "scripted, aim's outcomes", kScriptedParams,
                                      kAim, validate_scripted),
    behaviour_kind<ScriptedBehaviour>("scripted_capture", "scripted, capture's outcomes",
                                      kScriptedParams, kCapture, validate_scripted),
    behaviour_kind<ScriptedBehaviour>("scripted_align", "scripted, align's outcomes",
                                      kScriptedParams, kAlign, validate_scripted),
    behaviour_kind<ScriptedBehaviour>("scripted_project", "scripted, project's outcomes",
                                      kScriptedParams, kProject, validate_scripted),
    behaviour_kind<ScriptedBehaviour>("scripted_next", "scripted, next's outcomes", kScriptedParams,
                                      kNext, validate_scripted),
    driver_kind<TestBase>("test_base", "base", "null base: integrates commands exactly",
                          kNullDeviceParams),
    driver_kind<TestLaser>("test_laser", "laser", "null laser: never scans", kNullDeviceParams),
    driver_kind<TestPanTilt>("test_pan_tilt", "pan_tilt", "null head: reaches at once",
                             kNullDeviceParams),
    driver_kind<TestDepthCamera>("test_depth_camera", "depth_camera", "null camera: no frames",
                                 kNullDeviceParams),
    driver_kind<TestProjector>("test_projector", "projector", "null projector", kNullDeviceParams),
    driver_kind<TestColourCamera>("test_colour_camera", "colour_camera",
                                  "null colour camera: no frames, notes exposure settings",
                                  kColourCameraParams),
    with_keys(service_kind<OdometryLocalization>("odometry_localization", "localization",
                                                 "dead reckoning: base odometry as the estimate",
                                                 kLocalizationParams),
              kLocalizationKeys),
};

}  // namespace
}  // namespace projtour::testing

using projtour::testing::kKinds;
PROJTOUR_PLUGIN("testing", "1.0.0", kKinds)
