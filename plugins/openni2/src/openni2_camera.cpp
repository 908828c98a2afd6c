// Driver `openni2`: depth frames from OpenNI2 (a device URI, an .oni recording, or "Dummy").
#include <OpenNI.h>

#include <cmath>
#include <cstring>
#include <mutex>
#include <string>

#include "projtour/geometry.hpp"
#include "projtour/plugin_author.hpp"

namespace projtour::openni2 {
namespace {

std::string extended_error() {
  std::string e = openni::OpenNI::getExtendedError();
  while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
  while (!e.empty() && (e.front() == '\t' || e.front() == ' ')) e.erase(e.begin());
  return e;
}

// OpenNI is initialized once per process and never shut down: shutting down right after a
// device closes unloads its driver while the driver's thread still runs (the Dummy device
// crashes that way), and the process exit reclaims everything anyway.
void ensure_initialized() {
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [] {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) failure = extended_error();
  });
  if (!failure.empty()) throw std::runtime_error("openni2: cannot initialize OpenNI: " + failure);
}

class OpenNi2Camera : public DepthCameraDriver {
 public:
  OpenNi2Camera(const Params& params, const RunContext&)
      : uri_(params.string("uri")),
        fallback_hfov_rad_(deg_to_rad(params.number("fallback_hfov_deg"))),
        fallback_vfov_rad_(deg_to_rad(params.number("fallback_vfov_deg"))) {
    ensure_initialized();
    const char* uri = uri_.empty() ? openni::ANY_DEVICE : uri_.c_str();
    const std::string name = uri_.empty() ? "any device" : "\"" + uri_ + "\"";
    if (device_.open(uri) != openni::STATUS_OK) {
      throw std::runtime_error("openni2: cannot open " + name + ": " + extended_error());
    }
    if (stream_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
      device_.close();
      throw std::runtime_error("openni2: " + name + " has no depth stream: " + extended_error());
    }
    choose_millimetre_mode();
    if (stream_.start() != openni::STATUS_OK) {
      const std::string why = extended_error();
      stream_.destroy();
      device_.close();
      throw std::runtime_error("openni2: cannot start the depth stream of " + name + ": " + why);
    }
    mode_ = stream_.getVideoMode();
    intrinsics_ = intrinsics_from_fov();
  }

  ~OpenNi2Camera() override {
    stream_.stop();
    stream_.destroy();
    device_.close();
  }

  void update(double t_s) override { now_s_ = t_s; }
  void safe_stop() override {}  // a camera has nothing to bring to rest

  std::optional<DepthFrame> grab() override {
    // Drain what is queued so the caller gets the newest frame.
    std::optional<DepthFrame> newest;
    for (;;) {
      openni::VideoStream* streams[] = {&stream_};
      int ready = -1;
      const openni::Status status = openni::OpenNI::waitForAnyStream(streams, 1, &ready, 0);
      if (status == openni::STATUS_TIME_OUT) break;
      if (status != openni::STATUS_OK) {
        throw DriverError("openni2: waiting for a depth frame failed: " + extended_error());
      }
      openni::VideoFrameRef frame;
      if (stream_.readFrame(&frame) != openni::STATUS_OK || !frame.isValid()) {
        throw DriverError("openni2: reading a depth frame failed: " + extended_error());
      }
      newest = convert(frame);
    }
    return newest;
  }

 private:
  void choose_millimetre_mode() {
    const auto& modes = stream_.getSensorInfo().getSupportedVideoModes();
    for (int i = 0; i < modes.getSize(); ++i) {
      if (modes[i].getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_1_MM &&
          modes[i].getResolutionX() == 640) {
        stream_.setVideoMode(modes[i]);
        return;
      }
    }
  }

  // A device that reports no field of view (the Dummy device reports 0) gets the Kinect v1's.
  PinholeModel intrinsics_from_fov() {
    PinholeModel k;
    k.width = mode_.getResolutionX();
    k.height = mode_.getResolutionY();
    double hfov = stream_.getHorizontalFieldOfView(), vfov = stream_.getVerticalFieldOfView();
    if (!(hfov > 0.0 && hfov < kPi)) hfov = fallback_hfov_rad_;
    if (!(vfov > 0.0 && vfov < kPi)) vfov = fallback_vfov_rad_;
    k.fx = k.width / (2.0 * std::tan(hfov / 2.0));
    k.fy = k.height / (2.0 * std::tan(vfov / 2.0));
    k.cx = (k.width - 1) / 2.0;
    k.cy = (k.height - 1) / 2.0;
    return k;
  }

  DepthFrame convert(const openni::VideoFrameRef& frame) {
    DepthFrame out;
    out.width = frame.getWidth();
    out.height = frame.getHeight();
    out.intrinsics = intrinsics_;
    if (out.width != intrinsics_.width || out.height != intrinsics_.height) {
      // Cropping or a mode change: the focal length stays, the principal point follows.
      out.intrinsics.width = out.width;
      out.intrinsics.height = out.height;
      out.intrinsics.cx = (out.width - 1) / 2.0;
      out.intrinsics.cy = (out.height - 1) / 2.0;
    }
    out.sequence = static_cast<std::uint64_t>(frame.getFrameIndex());
    // Device time (microseconds) anchored to mission time at the first frame, so frames keep
    // the device's spacing however late the executor polls.
    const double device_s = static_cast<double>(frame.getTimestamp()) * 1e-6;
    if (!anchored_) anchor_mission_s_ = now_s_ - device_s, anchored_ = true;
    out.t_s = anchor_mission_s_ + device_s;
    out.depth_mm.resize(static_cast<std::size_t>(out.width) * out.height);
    const auto* data = static_cast<const std::uint8_t*>(frame.getData());
    const int stride = frame.getStrideInBytes();
    const bool hundred_um =
        frame.getVideoMode().getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM;
    for (int v = 0; v < out.height; ++v) {
      const auto* row =
          reinterpret_cast<const openni::DepthPixel*>(data + static_cast<std::size_t>(v) * stride);
      std::uint16_t* dst = &out.depth_mm[static_cast<std::size_t>(v) * out.width];
      if (hundred_um) {
        for (int u = 0; u < out.width; ++u) dst[u] = static_cast<std::uint16_t>((row[u] + 5) / 10);
      } else {
        std::memcpy(dst, row, sizeof(std::uint16_t) * out.width);
      }
    }
    return out;
  }

  std::string uri_;
  double fallback_hfov_rad_, fallback_vfov_rad_;
  openni::Device device_;
  openni::VideoStream stream_;
  openni::VideoMode mode_;
  PinholeModel intrinsics_;
  double now_s_ = 0.0;
  bool anchored_ = false;
  double anchor_mission_s_ = 0.0;
};

const projtour_param_desc kParams[] = {
    {"uri", "string", "", "device URI, .oni recording, or Dummy; empty = the first device"},
    {"fallback_hfov_deg", "number", "58.5",
     "horizontal field of view when the device reports none"},
    {"fallback_vfov_deg", "number", "45.6", "vertical field of view when the device reports none"},
};
const projtour_kind_desc kKinds[] = {driver_kind<OpenNi2Camera>(
    "openni2", "depth_camera", "depth frames from OpenNI2 (device, .oni file or Dummy)", kParams)};

}  // namespace
}  // namespace projtour::openni2

PROJTOUR_PLUGIN("openni2", "1.0.0", projtour::openni2::kKinds)
