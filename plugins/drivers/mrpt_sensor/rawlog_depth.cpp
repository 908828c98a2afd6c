// Depth camera driver `rawlog_depth`: replays the CObservation3DRangeScan frames of an MRPT
// rawlog (recorded at a real site with rawlog-grabber, or any of MRPT's datasets) through the
// same capture path as a live camera, one frame per `period_s` of mission time.
#include "rawlog_depth.hpp"

#include <mrpt/io/lazy_load_path.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>

#include <cmath>
#include <filesystem>
#include <limits>

namespace projtour::mrpt_sensor {

namespace {

// A range image in MRPT's units as the contract's depth frame: millimetres of depth (z), 0 where
// nothing was read. A range that is a distance along the ray becomes the depth along the axis.
DepthFrame to_depth_frame(const mrpt::obs::CObservation3DRangeScan& obs) {
  DepthFrame f;
  const auto& k = obs.cameraParams;
  f.width = static_cast<int>(obs.rangeImage.cols());
  f.height = static_cast<int>(obs.rangeImage.rows());
  f.intrinsics.width = f.width;
  f.intrinsics.height = f.height;
  f.intrinsics.fx = k.fx();
  f.intrinsics.fy = k.fy();
  f.intrinsics.cx = k.cx();
  f.intrinsics.cy = k.cy();
  for (int i = 0; i < 5; ++i) f.intrinsics.distortion[i] = k.dist[i];
  f.depth_mm.assign(static_cast<std::size_t>(f.width) * f.height, 0);
  const double to_mm = 1000.0 * obs.rangeUnits;
  for (int v = 0; v < f.height; ++v) {
    for (int u = 0; u < f.width; ++u) {
      const double range = obs.rangeImage(v, u) * to_mm;
      if (!(range > 0.0)) continue;
      double z = range;
      if (!obs.range_is_depth) {
        const double x = (u - k.cx()) / k.fx(), y = (v - k.cy()) / k.fy();
        z = range / std::sqrt(1.0 + x * x + y * y);
      }
      if (z < 65535.0)
        f.depth_mm[static_cast<std::size_t>(v) * f.width + u] =
            static_cast<std::uint16_t>(std::lround(z));
    }
  }
  return f;
}

}  // namespace

RawlogDepth::RawlogDepth(const Params& params, const RunContext& run)
    : period_s_(params.number("period_s")), loop_(params.boolean("loop")) {
  std::filesystem::path file = params.string("file");
  if (file.is_relative() && run.mission != nullptr && !run.mission->robot.file.empty()) {
    file = run.mission->robot.file.parent_path() / file;
  }
  if (!std::filesystem::exists(file)) {
    throw DriverError("rawlog_depth: rawlog " + file.string() + " not found");
  }
  mrpt::obs::CRawlog rawlog;
  if (!rawlog.loadFromRawLogFile(file.string())) {
    throw DriverError("rawlog_depth: cannot read " + file.string() + " as an MRPT rawlog");
  }
  // Externally stored range images (rawlog-grabber's default for RGB-D) live beside the rawlog
  // in <name>_Images/.
  mrpt::io::setLazyLoadPathBase((file.parent_path() / (file.stem().string() + "_Images")).string());
  const auto take = [&](const mrpt::obs::CObservation::Ptr& o) {
    const auto scan = std::dynamic_pointer_cast<mrpt::obs::CObservation3DRangeScan>(o);
    if (!scan) return;
    scan->load();
    if (scan->hasRangeImage) frames_.push_back(to_depth_frame(*scan));
    scan->unload();
  };
  for (std::size_t i = 0; i < rawlog.size(); ++i) {
    switch (rawlog.getType(i)) {
      case mrpt::obs::CRawlog::etObservation:
        take(rawlog.getAsObservation(i));
        break;
      case mrpt::obs::CRawlog::etSensoryFrame:
        for (const auto& o : *rawlog.getAsObservations(i)) take(o);
        break;
      default:
        break;
    }
  }
  if (frames_.empty()) {
    throw DriverError("rawlog_depth: " + file.string() +
                      " holds no CObservation3DRangeScan with a range image");
  }
  file_ = file.string();
}

void RawlogDepth::update(double t_s) {
  now_s_ = t_s;
}

std::optional<DepthFrame> RawlogDepth::grab() {
  if (next_ >= frames_.size()) {
    if (!loop_) return std::nullopt;
    next_ = 0;
  }
  if (last_s_ && now_s_ - *last_s_ < period_s_ - 1e-9) return std::nullopt;
  DepthFrame f = frames_[next_++];
  f.t_s = now_s_;
  f.sequence = ++sequence_;
  last_s_ = now_s_;
  return f;
}

}  // namespace projtour::mrpt_sensor
