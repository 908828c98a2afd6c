// The targets' true bodies: true poses, true surfaces, and the objects targets share.
#include "bodies/targets.hpp"

#include <array>
#include <cmath>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "bodies/body_ids.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/perception/model.hpp"
#include "world/random_streams.hpp"

namespace projtour::sim {

perception::TriangleMesh perturbed_mesh(const perception::TriangleMesh& mesh, double rms_m,
                                        std::mt19937_64& rng) {
  if (rms_m <= 0.0) return mesh;
  std::vector<Eigen::Vector3f> normals(mesh.vertices.size(), Eigen::Vector3f::Zero());
  for (const Eigen::Vector3i& f : mesh.triangles) {
    const Eigen::Vector3f n = (mesh.vertices[f[1]] - mesh.vertices[f[0]])
                                  .cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]);
    for (int k = 0; k < 3; ++k) normals[f[k]] += n;  // area-weighted
  }
  constexpr int kWaves = 12;
  std::array<Eigen::Vector3d, kWaves> k_vec;
  std::array<double, kWaves> phase;
  for (int w = 0; w < kWaves; ++w) {
    k_vec[w] = random_unit(rng) * (2.0 * kPi / uniform(rng, 0.04, 0.15));
    phase[w] = uniform(rng, 0.0, 2.0 * kPi);
  }
  std::vector<double> field(mesh.vertices.size());
  double sum2 = 0.0;
  for (std::size_t i = 0; i < field.size(); ++i) {
    double f = 0.0;
    for (int w = 0; w < kWaves; ++w)
      f += std::sin(k_vec[w].dot(mesh.vertices[i].cast<double>()) + phase[w]);
    field[i] = f;
    sum2 += f * f;
  }
  const double scale = sum2 > 0.0 ? rms_m / std::sqrt(sum2 / field.size()) : 0.0;
  perception::TriangleMesh out = mesh;
  for (std::size_t i = 0; i < field.size(); ++i) {
    const float len = normals[i].norm();
    if (len > 0.0f) out.vertices[i] += static_cast<float>(field[i] * scale) * (normals[i] / len);
  }
  return out;
}

void TrueTargets::build(const MissionSpec& mission, const host::WorldSpec& world,
                        std::mt19937_64& setup,
                        const std::function<TargetFaultFlags(const std::string&)>& flags) {
  // By model file: targets may share one.
  std::map<std::string, std::shared_ptr<const perception::TriangleMesh>> meshes;
  for (const TargetSpec& spec : mission.targets) {
    TrueTarget t;
    t.spec = &spec;
    t.standoff = navigation::standoff_pose(spec);
    Eigen::Isometry3d T_map_model = Eigen::Isometry3d::Identity();
    const auto listed = world.T_map_model_true.find(spec.id);
    // Offsets are drawn for every target, listed or not, so listing one does not move another.
    const double r = world.target_offset_max_m * std::sqrt(uniform(setup, 0, 1));
    const double a = uniform(setup, 0, 2 * kPi);
    const double yaw = deg_to_rad(world.target_offset_max_deg) * uniform(setup, -1, 1);
    if (listed != world.T_map_model_true.end()) {
      T_map_model = listed->second;
    } else {
      Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
      shift.translation() = Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0.0);
      T_map_model = shift * spec.T_map_model * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
    }
    const std::string key = spec.model.string();
    if (!meshes.count(key)) {
      try {
        meshes[key] =
            std::make_shared<const perception::TriangleMesh>(perception::load_mesh(spec.model));
      } catch (const std::exception& e) {
        throw std::runtime_error(std::string("simulated world: target '") + spec.id +
                                 "': the simulator renders meshes: " + e.what());
      }
    }
    const TargetFaultFlags faulted = flags(spec.id);
    t.object = objects.size();
    for (std::size_t k = 0; faulted.shareable && k < objects.size(); ++k) {
      const TrueObject& o = objects[k];
      if (o.shared && o.model_key == key && o.T_map_model.matrix() == T_map_model.matrix()) {
        t.object = k;
        break;
      }
    }
    if (t.object == objects.size()) {
      TrueObject o;
      o.mesh = world.model_error ? std::make_shared<const perception::TriangleMesh>(perturbed_mesh(
                                       *meshes[key], world.model_error_noise_mm * 1e-3, setup))
                                 : meshes[key];
      o.T_map_model = T_map_model;
      o.object_id = kFirstTargetId + static_cast<int>(objects.size());
      o.model_key = key;
      o.missing = faulted.missing;
      o.shared = faulted.shareable;
      objects.push_back(std::move(o));
    }
    targets.push_back(std::move(t));
  }
}

TrueTarget* TrueTargets::find(const std::string& id) {
  for (auto& t : targets) {
    if (t.spec->id == id) return &t;
  }
  return nullptr;
}

const TrueTarget* TrueTargets::find(const std::string& id) const {
  return const_cast<TrueTargets*>(this)->find(id);
}

const Scene& TrueTargets::alone(const TrueTarget& t) const {
  if (!alone_cache || alone_cache->first != t.object) {
    const TrueObject& o = object(t);
    SceneBuilder builder;
    builder.add_mesh(*o.mesh, o.T_map_model, o.object_id);
    alone_cache.emplace(t.object, builder.build());
  }
  return alone_cache->second;
}

// Targets at one place (an object visited again) are equally near; the visit under way is the
// one meant.
TrueTarget* TrueTargets::active(const Pose2D& p) {
  TrueTarget* best = nullptr;
  double best_d = 0.0;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    TrueTarget& t = targets[i];
    const Eigen::Vector3d c = object(t).T_map_model.translation();
    const double d = std::hypot(c.x() - p.x_m, c.y() - p.y_m);
    if (d > t.spec->standoff_m + 1.5) continue;
    if (best == nullptr || d < best_d || (d == best_d && visited == i)) {
      best = &t;
      best_d = d;
    }
  }
  return best;
}

cv::Mat TrueTargets::last_frame(const TrueTarget& t) const {
  if (!t.last_frame.empty() || t.last_frame_png.empty()) return t.last_frame;
  return cv::imdecode(t.last_frame_png, cv::IMREAD_COLOR);
}

void TrueTargets::pack_last_frame(TrueTarget& t) {
  if (t.last_frame.empty()) return;
  // Fast, lossless compression: warped content is mostly black.
  cv::imencode(".png", t.last_frame, t.last_frame_png, {cv::IMWRITE_PNG_COMPRESSION, 1});
  t.last_frame.release();
}

}  // namespace projtour::sim
