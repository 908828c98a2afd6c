// Out-of-line anchors for core's interfaces: their vtables and typeinfo live in the core
// library only, so dynamic_cast works across plugin boundaries.
#include <algorithm>
#include <iostream>
#include <numeric>
#include <stdexcept>

#include "projtour/contract/behaviour.hpp"
#include "projtour/contract/blackboard.hpp"
#include "projtour/contract/clock.hpp"
#include "projtour/contract/depth_frame.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/ground_truth.hpp"
#include "projtour/contract/logger.hpp"
#include "projtour/contract/mission.hpp"

namespace projtour {

Clock::~Clock() = default;
Logger::~Logger() = default;
Driver::~Driver() = default;
void Driver::update(double) {}
GroundTruth* Driver::ground_truth() {
  return nullptr;
}
GroundTruth::~GroundTruth() = default;
Eigen::Isometry3d GroundTruth::true_T_map_base_as_drawn() const {
  return true_T_map_base();
}
std::optional<BuildingTruth> GroundTruth::building_truth() const {
  return std::nullopt;
}
std::vector<Eigen::Vector2d> GroundTruth::people_positions() const {
  return {};
}
void GroundTruth::follow_true_base(const Pose2D&) {
  throw std::logic_error("this simulator's base cannot follow another simulator's");
}
Behaviour::~Behaviour() = default;
void Behaviour::stop(Context&) {}
void Behaviour::pause(Context&) {}
void Behaviour::resume(Context&) {}
Service::~Service() = default;
void Service::stop(Context&) {}

void StderrLogger::log(LogLevel level, const std::string& message) {
  if (level < threshold_) return;
  static const char* const kNames[] = {"debug", "info", "warning", "error"};
  std::cerr << "projtour: " << kNames[static_cast<int>(level)] << ": " << message << "\n";
}

void Blackboard::clear_visit() {
  for (auto it = entries_.begin(); it != entries_.end();) {
    it = it->second.scope == KeyScope::visit ? entries_.erase(it) : std::next(it);
  }
}

std::size_t DepthFrame::valid_count() const {
  return static_cast<std::size_t>(
      std::count_if(depth_mm.begin(), depth_mm.end(), [](std::uint16_t d) { return d != 0; }));
}

std::vector<std::shared_ptr<Driver>> DriverSet::all() const {
  std::vector<std::shared_ptr<Driver>> out;
  for (std::shared_ptr<Driver> d : std::initializer_list<std::shared_ptr<Driver>>{
           base, laser, pan_tilt, depth_camera, projector, colour_camera}) {
    if (d) out.push_back(std::move(d));
  }
  return out;
}

GroundTruth* DriverSet::ground_truth() const {
  for (const auto& d : all()) {
    if (GroundTruth* truth = d->ground_truth()) return truth;
  }
  return nullptr;
}

double ProjectionTruth::mean_mm() const {
  return std::accumulate(error_mm.begin(), error_mm.end(), 0.0) / 4.0;
}
double ProjectionTruth::mean_px() const {
  return std::accumulate(error_px.begin(), error_px.end(), 0.0) / 4.0;
}

}  // namespace projtour
