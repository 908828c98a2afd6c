#pragma once
// Driver interfaces: what behaviours and services see of the hardware (or of the simulator,
// which they cannot tell apart).
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/depth_frame.hpp"
#include "projtour/contract/geometry.hpp"

namespace cv {
class Mat;
}

namespace projtour {

class GroundTruth;

// A device failed (disconnected, not responding). Behaviours turn it into an outcome.
class DriverError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Driver {
 public:
  virtual ~Driver();
  // Called once per executor tick with the mission time; simulated devices advance here.
  virtual void update(double t_s);
  // Bring the device to a safe state (base stopped, head holding, projector blank). Must not
  // throw and must be callable at any time, any number of times, and from any thread: the tick
  // watchdog calls it from its own while a hung tick may be inside this driver. So it takes
  // only locks the driver's other calls hold briefly, and stopping the device wins over
  // keeping the driver's other state consistent (the process ends right after).
  virtual void safe_stop() = 0;
  // Only simulated drivers know the truth; hardware returns null.
  virtual GroundTruth* ground_truth();
};

struct Odometry {
  double t_s = 0.0;
  Pose2D pose;  // integrated wheel odometry, drifts
  double v_mps = 0.0;
  double w_radps = 0.0;
};

class BaseDriver : public Driver {
 public:
  virtual void command_velocity(double v_mps, double w_radps) = 0;
  virtual Odometry odometry() const = 0;
};

struct LaserScan {
  double t_s = 0.0;
  double angle_min_rad = 0.0;
  double angle_increment_rad = 0.0;
  double max_range_m = 0.0;
  std::vector<float> ranges_m;
  std::vector<char> valid;  // one per range
  Eigen::Isometry3d T_base_laser = Eigen::Isometry3d::Identity();
};

class LaserDriver : public Driver {
 public:
  // The newest scan not yet returned, or nullopt.
  virtual std::optional<LaserScan> take_scan() = 0;
};

struct JointAngles {
  double pan_rad = 0.0;
  double tilt_rad = 0.0;
};

class PanTiltDriver : public Driver {
 public:
  virtual void command(const JointAngles& angles) = 0;
  virtual JointAngles measured() const = 0;
  // True once the measured angles are within tolerance of the last command and at rest.
  virtual bool reached() const = 0;
};

class DepthCameraDriver : public Driver {
 public:
  // The newest frame not yet returned, or nullopt when none is ready (a dropped frame is a
  // frame with no valid pixels). Throws DriverError when the device is gone.
  virtual std::optional<DepthFrame> grab() = 0;
};

// The Kinect's colour camera, registered to the depth camera by the robot file's
// camera.depth_to_color_m: its optical frame is the robot's `camera` frame.
class ColourCameraDriver : public Driver {
 public:
  // The newest frame not yet returned, or nullopt. Throws DriverError when the device is gone.
  virtual std::optional<ColourFrame> grab() = 0;
  // Fixed exposure for the frames that follow (structured light needs it fixed); 0 = automatic.
  virtual void set_exposure_ms(double exposure_ms) = 0;
};

class ProjectorDriver : public Driver {
 public:
  // Shows a BGR frame of the projector's size. Throws DriverError when the device fails.
  virtual void show(const cv::Mat& frame_bgr) = 0;
  virtual void blank() = 0;
  virtual bool is_blank() const = 0;
};

// The drivers of one run, by interface.
struct DriverSet {
  std::shared_ptr<BaseDriver> base;
  std::shared_ptr<LaserDriver> laser;
  std::shared_ptr<PanTiltDriver> pan_tilt;
  std::shared_ptr<DepthCameraDriver> depth_camera;
  std::shared_ptr<ProjectorDriver> projector;
  std::shared_ptr<ColourCameraDriver> colour_camera;  // optional: the closed loop needs it

  std::vector<std::shared_ptr<Driver>> all() const;
  // The first driver that knows the truth, or null (hardware).
  GroundTruth* ground_truth() const;
};

}  // namespace projtour
