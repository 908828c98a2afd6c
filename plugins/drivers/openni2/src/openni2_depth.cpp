// Driver `openni2`: depth frames from OpenNI2 (a device URI, an .oni recording, or "Dummy").
#include <cmath>
#include <cstring>
#include <string>

#include "openni2_device.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/contract/plugin_author.hpp"

namespace projtour::openni2 {
namespace {

constexpr const char* kKind = "openni2";

class OpenNi2Camera : public DepthCameraDriver {
 public:
  OpenNi2Camera(const Params& params, const RunContext&)
      : fallback_hfov_rad_(deg_to_rad(params.number("fallback_hfov_deg"))),
        fallback_vfov_rad_(deg_to_rad(params.number("fallback_vfov_deg"))),
        stream_(SharedDevice::acquire(params.string("uri"), kKind), openni::SENSOR_DEPTH, kKind,
                "depth", choose_millimetre_mode) {
    mode_ = stream_.stream().getVideoMode();
    intrinsics_ = intrinsics_from_fov();
  }

  void update(double t_s) override { now_s_ = t_s; }
  void safe_stop() override {}  // a camera has nothing to bring to rest

  // The newest frame, so the caller never works on a stale one.
  std::optional<DepthFrame> grab() override {
    openni::VideoFrameRef frame;
    if (!stream_.newest(frame)) return std::nullopt;
    return convert(frame);
  }

 private:
  static void choose_millimetre_mode(openni::VideoStream& stream) {
    const auto& modes = stream.getSensorInfo().getSupportedVideoModes();
    for (int i = 0; i < modes.getSize(); ++i) {
      if (modes[i].getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_1_MM &&
          modes[i].getResolutionX() == 640) {
        stream.setVideoMode(modes[i]);
        return;
      }
    }
  }

  // A device that reports no field of view (the Dummy device reports 0) gets the Kinect v1's.
  PinholeModel intrinsics_from_fov() {
    PinholeModel k;
    k.width = mode_.getResolutionX();
    k.height = mode_.getResolutionY();
    double hfov = stream_.stream().getHorizontalFieldOfView();
    double vfov = stream_.stream().getVerticalFieldOfView();
    if (!(hfov > 0.0 && hfov < kPi)) hfov = fallback_hfov_rad_;
    if (!(vfov > 0.0 && vfov < kPi)) vfov = fallback_vfov_rad_;
    k.fx = k.width / (2.0 * std::tan(hfov / 2.0));
    k.fy = k.height / (2.0 * std::tan(vfov / 2.0));
    k.cx = (k.width - 1) / 2.0;
    k.cy = (k.height - 1) / 2.0;
    return k;
  }

  DepthFrame convert(const openni::VideoFrameRef& frame) {
    stream_.check_layout(frame, sizeof(openni::DepthPixel));
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
    out.t_s = stream_.device().mission_time_s(frame.getTimestamp(), now_s_);
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

  double fallback_hfov_rad_, fallback_vfov_rad_;
  SensorStream stream_;
  openni::VideoMode mode_;
  PinholeModel intrinsics_;
  double now_s_ = 0.0;
};

const projtour_param_desc kParams[] = {
    {"uri", "string", "",
     "device URI, .oni recording, or Dummy; empty = the first device (shared with "
     "openni2_colour of the same uri)"},
    {"fallback_hfov_deg", "number", "58.5",
     "horizontal field of view when the device reports none"},
    {"fallback_vfov_deg", "number", "45.6", "vertical field of view when the device reports none"},
};

}  // namespace

projtour_kind_desc depth_kind() {
  return driver_kind<OpenNi2Camera>(
      "openni2", "depth_camera", "depth frames from OpenNI2 (device, .oni file or Dummy)", kParams);
}

}  // namespace projtour::openni2
