// A Directed Perception pan-tilt unit through MRPT's CPtuDPerception. The unit's own angle
// conventions are mapped to the robot file's (positive pan left, positive tilt down) by the
// `pan_sign`/`tilt_sign` parameters, since PTU firmware counts tilt positive upward.
#include <mrpt/hwdrivers/CPtuDPerception.h>
#include <cmath>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include "projtour/contract/plugin_author.hpp"

namespace projtour {
namespace {

class PtuDPerception : public PanTiltDriver {
 public:
  PtuDPerception(const Params& params, const RunContext& run)
      : port_(params.string("port")),
        pan_sign_(params.number("pan_sign")),
        tilt_sign_(params.number("tilt_sign")) {
    if (run.mission != nullptr) {
      tolerance_rad_ = deg_to_rad(run.mission->robot.pan_tilt.tolerance_deg);
    }
    if (port_.empty()) throw DriverError("pan_tilt ptu_dperception: parameter `port` is empty");
    // CPtuDPerception::init reports a missing port only on stderr; say which port here.
    if (port_.rfind("COM", 0) != 0 && !std::filesystem::exists(port_)) {
      throw DriverError("pan_tilt ptu_dperception: serial port " + port_ +
                        " does not exist (is the PTU connected and powered?)");
    }
    bool ok = false;
    try {
      ok = ptu_.init(port_);
    } catch (const std::exception& e) {
      throw DriverError("pan_tilt ptu_dperception: cannot open serial port " + port_ + ": " +
                        e.what());
    }
    if (!ok) {
      throw DriverError("pan_tilt ptu_dperception: no PTU answering on serial port " + port_);
    }
    read_position();
  }
  ~PtuDPerception() override { ptu_.close(); }

  void update(double) override { read_position(); }

  void command(const JointAngles& angles) override {
    commanded_ = angles;
    has_command_ = true;
    if (!ptu_.moveToAbsPos('P', pan_sign_ * angles.pan_rad) ||
        !ptu_.moveToAbsPos('T', tilt_sign_ * angles.tilt_rad)) {
      throw DriverError("pan_tilt ptu_dperception: move command failed on " + port_);
    }
  }
  JointAngles measured() const override { return measured_; }
  bool reached() const override {
    if (!has_command_) return true;
    return std::abs(measured_.pan_rad - commanded_.pan_rad) <= tolerance_rad_ &&
           std::abs(measured_.tilt_rad - commanded_.tilt_rad) <= tolerance_rad_ &&
           std::abs(measured_.pan_rad - previous_.pan_rad) <= tolerance_rad_ / 4 &&
           std::abs(measured_.tilt_rad - previous_.tilt_rad) <= tolerance_rad_ / 4;
  }
  void safe_stop() override {
    try {
      ptu_.haltAll();
    } catch (...) {  // must not throw
    }
  }

 private:
  void read_position() {
    double pan = 0.0, tilt = 0.0;
    if (!ptu_.absPosQ('P', pan) || !ptu_.absPosQ('T', tilt)) {
      throw DriverError("pan_tilt ptu_dperception: position query failed on " + port_);
    }
    previous_ = measured_;
    measured_ = {pan_sign_ * pan, tilt_sign_ * tilt};
  }

  std::string port_;
  double pan_sign_, tilt_sign_;
  double tolerance_rad_ = deg_to_rad(0.2);
  mrpt::hwdrivers::CPtuDPerception ptu_;
  JointAngles measured_, previous_, commanded_;
  bool has_command_ = false;
};

void check_params(const Params& params) {
  for (const char* name : {"pan_sign", "tilt_sign"}) {
    if (std::abs(std::abs(params.number(name)) - 1.0) > 1e-12) {
      throw std::invalid_argument(std::string(name) + " must be 1 or -1");
    }
  }
}

const projtour_param_desc kParams[] = {
    {"port", "string", "/dev/ttyUSB0", "serial port of the PTU"},
    {"pan_sign", "number", "1", "1 when the PTU's positive pan turns left, else -1"},
    {"tilt_sign", "number", "-1", "1 when the PTU's positive tilt looks down, else -1"}};

const projtour_kind_desc kKinds[] = {driver_kind<PtuDPerception>(
    "ptu_dperception", "pan_tilt", "Directed Perception PTU over a serial port (MRPT)", kParams,
    validator<check_params>())};

}  // namespace
}  // namespace projtour

PROJTOUR_PLUGIN("ptu_dperception", "1.0.0", projtour::kKinds)
