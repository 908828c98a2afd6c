#pragma once
// What the openni2 kinds share: OpenNI itself, the device behind a URI and the streams of its
// sensors. OpenNI2 expects a device to be opened once per process, so the depth and the colour
// kind of one URI hold the same SharedDevice, which closes when the last of them is gone.
#include <OpenNI.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "projtour/contract/plugin_abi.h"

namespace projtour::openni2 {

// OpenNI's last error, trimmed of the padding OpenNI puts around it.
std::string extended_error();

class SharedDevice {
 public:
  // The device of `uri` (a device URI, an .oni recording or "Dummy"; "" = the first device),
  // opened now unless a driver of this process holds it already. `kind` names the caller in
  // error messages.
  static std::shared_ptr<SharedDevice> acquire(const std::string& uri, const std::string& kind);

  SharedDevice(const SharedDevice&) = delete;
  SharedDevice& operator=(const SharedDevice&) = delete;
  ~SharedDevice();

  openni::Device& device() { return device_; }
  // "\"Dummy\"" or "any device", for messages.
  const std::string& name() const { return name_; }
  // OpenNI2's Dummy device, whose streams need time to stop (see ~SensorStream).
  bool is_dummy() const { return dummy_; }

  // Device time (microseconds) anchored to mission time at the first frame any stream of the
  // device delivers, so frames keep the device's spacing however late the executor polls, and
  // depth and colour frames of one device share one clock.
  double mission_time_s(std::uint64_t device_us, double now_s);

 private:
  SharedDevice(const std::string& uri, const std::string& kind);

  openni::Device device_;
  std::string name_;
  bool dummy_;
  std::mutex anchor_mutex_;
  bool anchored_ = false;
  double anchor_mission_s_ = 0.0;
};

// One started stream of a device's sensor: created, configured by the caller (video mode) and
// started on construction; stopped and destroyed before the device is let go.
class SensorStream {
 public:
  // `what` names the stream in messages ("depth", "colour"); `configure` runs between create
  // and start, where OpenNI allows the video mode to change.
  SensorStream(std::shared_ptr<SharedDevice> device, openni::SensorType sensor,
               const std::string& kind, const std::string& what,
               const std::function<void(openni::VideoStream&)>& configure);
  SensorStream(const SensorStream&) = delete;
  SensorStream& operator=(const SensorStream&) = delete;
  ~SensorStream();

  // The newest frame queued, false when none is (so the caller converts only that one).
  // Throws DriverError when the device is gone.
  bool newest(openni::VideoFrameRef& frame);
  // Throws DriverError unless the frame's rows of `bytes_per_pixel` pixels lie inside its data,
  // so a malformed frame is a device failure rather than a read past its buffer.
  void check_layout(const openni::VideoFrameRef& frame, int bytes_per_pixel) const;

  openni::VideoStream& stream() { return stream_; }
  SharedDevice& device() { return *device_; }

 private:
  std::shared_ptr<SharedDevice> device_;
  std::string kind_;
  std::string what_;
  openni::SensorType sensor_;
  openni::VideoStream stream_;
};

// The plugin's kinds, each defined beside its driver.
projtour_kind_desc depth_kind();
projtour_kind_desc colour_kind();

}  // namespace projtour::openni2
