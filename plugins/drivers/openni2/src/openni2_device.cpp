#include "openni2_device.hpp"

#include <chrono>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <thread>

#include "projtour/contract/drivers.hpp"

namespace projtour::openni2 {

std::string extended_error() {
  std::string e = openni::OpenNI::getExtendedError();
  while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
  while (!e.empty() && (e.front() == '\t' || e.front() == ' ')) e.erase(e.begin());
  return e;
}

namespace {

// OpenNI is initialized once per process and never shut down: shutting down right after a
// device closes unloads its driver while the driver's thread still runs (the Dummy device
// crashes that way), and the process exit reclaims everything anyway.
void ensure_initialized(const std::string& kind) {
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [] {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) failure = extended_error();
  });
  if (!failure.empty()) throw std::runtime_error(kind + ": cannot initialize OpenNI: " + failure);
}

// What identifies one device, so two spellings of it share it: "" becomes the URI of the
// device OpenNI would pick (the first it enumerates), a recording its canonical path.
std::string device_key(const std::string& uri) {
  if (uri.empty()) {
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    return devices.getSize() > 0 ? devices[0].getUri() : uri;
  }
  std::error_code ec;
  if (std::filesystem::is_regular_file(uri, ec)) {
    const auto canonical = std::filesystem::weakly_canonical(uri, ec);
    if (!ec) return canonical.string();
  }
  return uri;
}

}  // namespace

std::shared_ptr<SharedDevice> SharedDevice::acquire(const std::string& uri,
                                                    const std::string& kind) {
  ensure_initialized(kind);
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<SharedDevice>> open_devices;
  std::lock_guard<std::mutex> lock(mutex);
  const std::string key = device_key(uri);
  if (auto held = open_devices[key].lock()) return held;
  // Opened by its key: for "" that is the device enumeration chose, the one the map names.
  std::shared_ptr<SharedDevice> device(new SharedDevice(key, kind));
  open_devices[key] = device;
  return device;
}

SharedDevice::SharedDevice(const std::string& uri, const std::string& kind)
    : name_(uri.empty() ? "any device" : "\"" + uri + "\""),
      dummy_(uri == "Dummy" || uri == "Oz" || uri == "PingPong") {
  const char* which = uri.empty() ? openni::ANY_DEVICE : uri.c_str();
  if (device_.open(which) != openni::STATUS_OK) {
    throw std::runtime_error(kind + ": cannot open " + name_ + ": " + extended_error());
  }
}

SharedDevice::~SharedDevice() {
  device_.close();
}

double SharedDevice::mission_time_s(std::uint64_t device_us, double now_s) {
  const double device_s = static_cast<double>(device_us) * 1e-6;
  std::lock_guard<std::mutex> lock(anchor_mutex_);
  if (!anchored_) {
    anchor_mission_s_ = now_s - device_s;
    anchored_ = true;
  }
  return anchor_mission_s_ + device_s;
}

SensorStream::SensorStream(std::shared_ptr<SharedDevice> device, openni::SensorType sensor,
                           const std::string& kind, const std::string& what,
                           const std::function<void(openni::VideoStream&)>& configure)
    : device_(std::move(device)), kind_(kind), what_(what), sensor_(sensor) {
  const std::string& name = device_->name();
  if (stream_.create(device_->device(), sensor) != openni::STATUS_OK) {
    throw std::runtime_error(kind_ + ": " + name + " has no " + what_ +
                             " stream: " + extended_error());
  }
  try {
    configure(stream_);
  } catch (...) {
    stream_.destroy();
    throw;
  }
  if (stream_.start() != openni::STATUS_OK) {
    const std::string why = extended_error();
    stream_.destroy();
    throw std::runtime_error(kind_ + ": cannot start the " + what_ + " stream of " + name + ": " +
                             why);
  }
}

SensorStream::~SensorStream() {
  stream_.stop();
  // The Dummy's stop() only clears the flag its frame thread polls once per 33 ms frame, and
  // destroy() frees the stream under that thread: destroyed at once, the thread runs on in
  // freed memory, feeding its frames to later streams or crashing the process (at its exit
  // often). Given a few frame periods, it sees the flag and ends.
  if (device_->is_dummy()) std::this_thread::sleep_for(std::chrono::milliseconds(150));
  stream_.destroy();
}

bool SensorStream::newest(openni::VideoFrameRef& frame) {
  bool any = false;
  for (;;) {
    openni::VideoStream* streams[] = {&stream_};
    int ready = -1;
    const openni::Status status = openni::OpenNI::waitForAnyStream(streams, 1, &ready, 0);
    if (status == openni::STATUS_TIME_OUT) break;
    if (status != openni::STATUS_OK) {
      throw DriverError(kind_ + ": waiting for a " + what_ + " frame failed: " + extended_error());
    }
    openni::VideoFrameRef next;
    if (stream_.readFrame(&next) != openni::STATUS_OK || !next.isValid()) {
      throw DriverError(kind_ + ": reading a " + what_ + " frame failed: " + extended_error());
    }
    // A Dummy stream destroyed too early (see ~SensorStream) lives on and feeds its frames, of
    // other sensors too, to the streams created after it.
    if (next.getSensorType() != sensor_) continue;
    frame = next;
    any = true;
  }
  return any;
}

void SensorStream::check_layout(const openni::VideoFrameRef& frame, int bytes_per_pixel) const {
  const long long width = frame.getWidth(), height = frame.getHeight();
  const long long stride = frame.getStrideInBytes(), row = width * bytes_per_pixel;
  const bool fits = width > 0 && height > 0 && stride >= row &&
                    frame.getDataSize() >= stride * (height - 1) + row;
  if (!fits) {
    throw DriverError(kind_ + ": a " + what_ + " frame of " + std::to_string(width) + "x" +
                      std::to_string(height) + " pixels (rows of " + std::to_string(stride) +
                      " bytes) does not fit its " + std::to_string(frame.getDataSize()) + " bytes");
  }
}

}  // namespace projtour::openni2
