// Laser driver `mrpt_sensor` and depth camera driver `rawlog_depth` (rawlog_depth.cpp).
// `mrpt_sensor` runs a 2-D scanner through MRPT's hwdrivers (CHokuyoURG,
// CSickLaserUSB, CRoboPeakLidar, ...), chosen by the `driver=` key of a section of an MRPT ini
// file, as MRPT's rawlog-grabber does. Scans are collected each tick.
#include <mrpt/config/CConfigFile.h>
#include <mrpt/hwdrivers/CGenericSensor.h>
#include <mrpt/hwdrivers/registerAllClasses.h>
#include <mrpt/obs/CObservation2DRangeScan.h>

#include <filesystem>
#include <mutex>
#include <string>

#include "projtour/contract/plugin_author.hpp"
#include "rawlog_depth.hpp"

namespace projtour::mrpt_sensor {
namespace {

// The serial port or address the section names, for messages about an absent device.
std::string device_of(const mrpt::config::CConfigFileBase& ini, const std::string& section) {
  for (const char* key : {"COM_port_LIN", "serial_port", "port", "IP_DIR", "ip_address"}) {
    const std::string value = ini.read_string(section, key, "");
    if (!value.empty()) return std::string(key) + " = " + value;
  }
  return "no port configured";
}

class MrptSensorLaser : public LaserDriver {
 public:
  MrptSensorLaser(const Params& params, const RunContext& run) {
    std::filesystem::path ini_file = params.string("ini");
    if (ini_file.is_relative() && run.mission != nullptr && !run.mission->robot.file.empty()) {
      ini_file = run.mission->robot.file.parent_path() / ini_file;
    }
    const std::string section = params.string("section");
    if (!std::filesystem::exists(ini_file)) {
      throw DriverError("mrpt_sensor: ini file " + ini_file.string() + " not found");
    }
    const mrpt::config::CConfigFile ini(ini_file.string());
    const std::string driver = ini.read_string(section, "driver", "");
    const std::string where = "[" + section + "] of " + ini_file.string();
    if (driver.empty()) throw DriverError("mrpt_sensor: " + where + " has no driver= key");
    static std::once_flag registered;
    std::call_once(registered, [] { mrpt::hwdrivers::registerAllClasses_mrpt_hwdrivers(); });
    sensor_ = mrpt::hwdrivers::CGenericSensor::createSensorPtr(driver);
    if (!sensor_) {
      throw DriverError("mrpt_sensor: " + where + ": unknown MRPT sensor driver \"" + driver +
                        "\"");
    }
    const std::string device = driver + " (" + device_of(ini, section) + ")";
    try {
      sensor_->loadConfig(ini, section);
      sensor_->initialize();
    } catch (const std::exception& e) {
      throw DriverError("mrpt_sensor: cannot open " + device + " from " + where + ": " +
                        first_line(e.what()));
    }
    if (sensor_->getState() == mrpt::hwdrivers::CGenericSensor::ssError) {
      throw DriverError("mrpt_sensor: cannot open " + device + " from " + where +
                        ": the device does not answer");
    }
    device_ = device;
  }

  void update(double t_s) override {
    try {
      sensor_->doProcess();
    } catch (const std::exception& e) {
      throw DriverError("mrpt_sensor: " + device_ + ": " + first_line(e.what()));
    }
    if (sensor_->getState() == mrpt::hwdrivers::CGenericSensor::ssError) {
      throw DriverError("mrpt_sensor: " + device_ + " stopped answering");
    }
    mrpt::hwdrivers::CGenericSensor::TListObservations observations;
    sensor_->getObservations(observations);
    for (const auto& [stamp, object] : observations) {
      (void)stamp;
      if (const auto scan = std::dynamic_pointer_cast<mrpt::obs::CObservation2DRangeScan>(object)) {
        newest_ = to_scan(*scan, t_s);
      }
    }
  }

  void safe_stop() override {}

  std::optional<LaserScan> take_scan() override {
    auto out = std::move(newest_);
    newest_.reset();
    return out;
  }

 private:
  // MRPT exceptions carry a banner, the message and a backtrace; only the message matters here.
  static std::string first_line(const std::string& text) {
    std::string line;
    std::size_t start = 0;
    const auto message = text.find("Message:");
    if (message != std::string::npos) start = message + 8;
    const auto end = text.find('\n', start);
    line = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
    const auto first = line.find_first_not_of(' ');
    return first == std::string::npos ? text : line.substr(first);
  }

  static LaserScan to_scan(const mrpt::obs::CObservation2DRangeScan& obs, double t_s) {
    LaserScan scan;
    scan.t_s = t_s;
    const std::size_t n = obs.getScanSize();
    const double span = n > 1 ? obs.aperture / static_cast<double>(n - 1) : 0.0;
    scan.angle_increment_rad = obs.rightToLeft ? span : -span;
    scan.angle_min_rad = obs.rightToLeft ? -0.5 * obs.aperture : 0.5 * obs.aperture;
    scan.max_range_m = obs.maxRange;
    for (std::size_t i = 0; i < n; ++i) {
      scan.ranges_m.push_back(obs.getScanRange(i));
      scan.valid.push_back(obs.getScanRangeValidity(i) ? 1 : 0);
    }
    const auto& p = obs.sensorPose;
    scan.T_base_laser = isometry_from_xyz_rpy(p.x(), p.y(), p.z(), p.roll(), p.pitch(), p.yaw());
    return scan;
  }

  mrpt::hwdrivers::CGenericSensor::Ptr sensor_;
  std::string device_;
  std::optional<LaserScan> newest_;
};

int validate(const void* raw, char* error, size_t error_size) {
  const Params& p = *static_cast<const Params*>(raw);
  if (!p.string("ini").empty() && !p.string("section").empty()) return 0;
  plugin_detail::copy_message("ini and section must name an MRPT ini file and its sensor section",
                              error, error_size);
  return 1;
}

const projtour_param_desc kParams[] = {
    {"ini", "string", "", "MRPT ini file (relative to the robot file) describing the scanner"},
    {"section", "string", "LASER_2D", "its section; driver= names the MRPT class"},
};

int validate_rawlog(const void* raw, char* error, size_t error_size) {
  const Params& p = *static_cast<const Params*>(raw);
  const char* problem = p.string("file").empty()        ? "file must name an MRPT rawlog"
                        : !(p.number("period_s") > 0.0) ? "period_s must be > 0"
                                                        : nullptr;
  if (problem == nullptr) return 0;
  plugin_detail::copy_message(problem, error, error_size);
  return 1;
}

const projtour_param_desc kRawlogParams[] = {
    {"file", "string", "",
     "MRPT rawlog (relative to the robot file) whose CObservation3DRangeScan frames are replayed"},
    {"period_s", "number", "0.0333333", "mission seconds between frames"},
    {"loop", "boolean", "true", "after the last frame, start again (else no more frames)"},
};

const projtour_kind_desc kKinds[] = {
    projtour::driver_kind<MrptSensorLaser>(
        "mrpt_sensor", "laser", "2-D laser scanner through MRPT hwdrivers (Hokuyo, SICK, RPLIDAR)",
        kParams, &validate),
    projtour::driver_kind<RawlogDepth>(
        "rawlog_depth", "depth_camera",
        "depth frames replayed from an MRPT rawlog (CObservation3DRangeScan), e.g. recorded at "
        "the site with rawlog-grabber",
        kRawlogParams, &validate_rawlog)};

}  // namespace
}  // namespace projtour::mrpt_sensor

PROJTOUR_PLUGIN("mrpt_sensor", "1.0.0", projtour::mrpt_sensor::kKinds)
