// Driver `openni2_colour`: colour frames from OpenNI2 (a device URI, an .oni recording, or
// "Dummy"), from the same device as `openni2` when both name it.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "openni2_device.hpp"
#include "projtour/contract/plugin_author.hpp"

namespace projtour::openni2 {
namespace {

constexpr const char* kKind = "openni2_colour";

std::string size_text(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// The robot file's colour intrinsics for a stream of another size: the same lens on a binned or
// resized sensor, so focal lengths and principal point scale per axis (pixel centres at +0.5)
// and the distortion, which acts on normalized coordinates, stays.
PinholeModel intrinsics_for(const PinholeModel& file, int width, int height) {
  if (width == file.width && height == file.height) return file;
  PinholeModel k = file;
  const double sx = static_cast<double>(width) / file.width;
  const double sy = static_cast<double>(height) / file.height;
  k.width = width;
  k.height = height;
  k.fx = file.fx * sx;
  k.fy = file.fy * sy;
  k.cx = (file.cx + 0.5) * sx - 0.5;
  k.cy = (file.cy + 0.5) * sy - 0.5;
  return k;
}

// Milliseconds per step of the device's exposure setting; checked when the mission loads.
double read_exposure_unit_ms(const Params& params) {
  const double unit = params.number("exposure_unit_ms");
  if (!(unit > 0.0) || !std::isfinite(unit)) {
    throw std::invalid_argument("exposure_unit_ms: must be > 0");
  }
  return unit;
}

class OpenNi2Colour : public ColourCameraDriver {
 public:
  OpenNi2Colour(const Params& params, const RunContext& run)
      : file_(run.mission != nullptr ? run.mission->robot.camera.colour : ColourCameraSpec{}),
        exposure_unit_ms_(read_exposure_unit_ms(params)),
        log_(run.log),
        stream_(SharedDevice::acquire(params.string("uri"), kKind), openni::SENSOR_COLOR, kKind,
                "colour", [this](openni::VideoStream& s) { choose_rgb_mode(s); }) {
    const openni::VideoMode mode = stream_.stream().getVideoMode();
    if (mode.getPixelFormat() != openni::PIXEL_FORMAT_RGB888) {
      throw std::runtime_error(std::string(kKind) + ": the colour stream of " +
                               stream_.device().name() + " offers no RGB888 mode");
    }
    intrinsics_ = intrinsics_for(file_.intrinsics, mode.getResolutionX(), mode.getResolutionY());
    const bool same_aspect =
        static_cast<long long>(mode.getResolutionX()) * file_.intrinsics.height ==
        static_cast<long long>(mode.getResolutionY()) * file_.intrinsics.width;
    if (!same_aspect) {
      warn("the robot file's camera.colour is " +
           size_text(file_.intrinsics.width, file_.intrinsics.height) + " but " +
           stream_.device().name() + " streams " +
           size_text(mode.getResolutionX(), mode.getResolutionY()) +
           ": its intrinsics are stretched to fit, calibrate the colour camera at this size");
    }
  }

  void update(double t_s) override { now_s_ = t_s; }
  void safe_stop() override {}  // a camera has nothing to bring to rest

  // The newest frame, so the caller never works on a stale one.
  std::optional<ColourFrame> grab() override {
    openni::VideoFrameRef frame;
    if (!stream_.newest(frame)) return std::nullopt;
    return convert(frame);
  }

  void set_exposure_ms(double exposure_ms) override {
    if (!(exposure_ms >= 0.0) || !std::isfinite(exposure_ms)) {
      throw std::invalid_argument(std::string(kKind) + ": exposure must be >= 0 ms, got " +
                                  std::to_string(exposure_ms));
    }
    apply_exposure(exposure_ms);
    // Frames already queued were exposed before the change; the caller asked for those after.
    openni::VideoFrameRef stale;
    stream_.newest(stale);
  }

 private:
  void apply_exposure(double exposure_ms) {
    used_exposure_ms_ = 0.0;
    openni::CameraSettings* settings = stream_.stream().getCameraSettings();
    if (settings == nullptr) {
      warn_exposure("has no camera settings");
      return;
    }
    if (exposure_ms == 0.0) {
      if (settings->setAutoExposureEnabled(true) != openni::STATUS_OK) {
        warn_exposure("refused automatic exposure: " + extended_error());
      }
      return;
    }
    const double units = std::round(exposure_ms / exposure_unit_ms_);
    if (units < 1.0 || units > std::numeric_limits<int>::max()) {
      warn_exposure("cannot express " + std::to_string(exposure_ms) + " ms in units of " +
                    std::to_string(exposure_unit_ms_) + " ms");
      return;
    }
    if (settings->setAutoExposureEnabled(false) != openni::STATUS_OK ||
        settings->setExposure(static_cast<int>(units)) != openni::STATUS_OK) {
      warn_exposure("refused a fixed exposure: " + extended_error());
      return;
    }
    // What the device settled on (it may round to its own steps), else what was asked.
    int reported = 0;
    const bool read_back = stream_.stream().getProperty(openni::STREAM_PROPERTY_EXPOSURE,
                                                        &reported) == openni::STATUS_OK;
    used_exposure_ms_ = (read_back && reported > 0 ? reported : units) * exposure_unit_ms_;
  }

  // RGB888 at the robot file's size if the sensor offers it, else the nearest size; among
  // equal sizes the rate nearest the file's.
  void choose_rgb_mode(openni::VideoStream& stream) const {
    const auto& modes = stream.getSensorInfo().getSupportedVideoModes();
    int best = -1;
    double best_score = std::numeric_limits<double>::infinity();
    for (int i = 0; i < modes.getSize(); ++i) {
      if (modes[i].getPixelFormat() != openni::PIXEL_FORMAT_RGB888) continue;
      const double size_off = std::abs(modes[i].getResolutionX() - file_.intrinsics.width) +
                              std::abs(modes[i].getResolutionY() - file_.intrinsics.height);
      const double rate_off = std::abs(modes[i].getFps() - file_.rate_hz);
      // Size dominates: a rate difference never outweighs a pixel of size difference.
      const double score = size_off * 1e6 + rate_off;
      if (score < best_score) best_score = score, best = i;
    }
    if (best >= 0) stream.setVideoMode(modes[best]);
  }

  void warn(const std::string& message) const {
    if (log_ != nullptr) log_->warning(std::string(kKind) + ": " + message);
  }

  // Once: set_exposure_ms is called per structured-light sequence, and a device without the
  // setting would say so every time.
  void warn_exposure(const std::string& why) {
    if (warned_exposure_) return;
    warned_exposure_ = true;
    warn(stream_.device().name() + " " + why + "; the colour exposure stays the device's own");
  }

  ColourFrame convert(const openni::VideoFrameRef& frame) {
    if (frame.getVideoMode().getPixelFormat() != openni::PIXEL_FORMAT_RGB888) {
      throw DriverError(std::string(kKind) + ": a colour frame arrived in pixel format " +
                        std::to_string(frame.getVideoMode().getPixelFormat()) + ", not RGB888");
    }
    stream_.check_layout(frame, sizeof(openni::RGB888Pixel));
    ColourFrame out;
    out.width = frame.getWidth();
    out.height = frame.getHeight();
    if (out.width != intrinsics_.width || out.height != intrinsics_.height) {
      intrinsics_ = intrinsics_for(file_.intrinsics, out.width, out.height);
    }
    out.intrinsics = intrinsics_;
    out.sequence = static_cast<std::uint64_t>(frame.getFrameIndex());
    out.t_s = stream_.device().mission_time_s(frame.getTimestamp(), now_s_);
    out.exposure_ms = used_exposure_ms_;
    out.bgr.resize(static_cast<std::size_t>(out.width) * out.height * 3);
    const auto* data = static_cast<const std::uint8_t*>(frame.getData());
    const int stride = frame.getStrideInBytes();
    for (int v = 0; v < out.height; ++v) {
      const auto* src =
          reinterpret_cast<const openni::RGB888Pixel*>(data + static_cast<std::size_t>(v) * stride);
      std::uint8_t* dst = &out.bgr[static_cast<std::size_t>(v) * out.width * 3];
      for (int u = 0; u < out.width; ++u, dst += 3) {
        dst[0] = src[u].b;
        dst[1] = src[u].g;
        dst[2] = src[u].r;
      }
    }
    return out;
  }

  ColourCameraSpec file_;
  double exposure_unit_ms_;
  Logger* log_;
  SensorStream stream_;
  PinholeModel intrinsics_;
  double now_s_ = 0.0;
  // 0 while the exposure is automatic or unknown: OpenNI2 reports no per-frame exposure.
  double used_exposure_ms_ = 0.0;
  bool warned_exposure_ = false;
};

const projtour_param_desc kParams[] = {
    {"uri", "string", "",
     "device URI, .oni recording, or Dummy; empty = the first device (shared with openni2 "
     "of the same uri)"},
    {"exposure_unit_ms", "number", "1",
     "milliseconds per step of the device's exposure setting (OpenNI2 leaves the unit to the "
     "device driver)"},
};

}  // namespace

projtour_kind_desc colour_kind() {
  return driver_kind<OpenNi2Colour>(kKind, "colour_camera",
                                    "colour frames (BGR) from OpenNI2 (device, .oni file or Dummy)",
                                    kParams, validator<read_exposure_unit_ms>());
}

}  // namespace projtour::openni2
