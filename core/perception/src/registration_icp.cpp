// Point-to-plane ICP with projective data association through the organized depth image.
#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <numeric>
#include <random>

#include <stdexcept>

#include "projtour/geometry.hpp"
#include "projtour/registration.hpp"

namespace projtour {

std::vector<IcpStage> IcpOptions::default_stages() {
  // Coarse levels see the whole target in few pixels, and their window lets a model point find
  // its surface several centimetres away; the fine levels then settle on the noise floor.
  return {
      {3, 250, 2, 0.15, 6, true}, {3, 250, 2, 0.10, 6},  {2, 500, 1, 0.04, 5},
      {1, 1000, 0, 0.02, 4},      {0, 6000, 0, 0.01, 2},
  };
}

IcpModel::IcpModel(const ModelCloud& cloud, unsigned seed)
    : bounding_radius_m_(cloud.bounding_radius_m) {
  if (cloud.points.size() != cloud.normals.size()) {
    throw std::invalid_argument("IcpModel: points and normals differ in number");
  }
  std::vector<std::size_t> order(cloud.points.size());
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(seed);
  // Fisher-Yates with our own draw: std::shuffle's sequence differs between standard libraries.
  for (std::size_t i = order.size(); i > 1; --i) {
    std::swap(order[i - 1], order[rng() % i]);
  }
  points_.reserve(order.size());
  normals_.reserve(order.size());
  for (std::size_t i : order) {
    points_.push_back(cloud.points[i]);
    normals_.push_back(cloud.normals[i].normalized());
  }
  if (bounding_radius_m_ <= 0.0f) {
    for (const auto& p : points_) bounding_radius_m_ = std::max(bounding_radius_m_, p.norm());
  }
}

namespace {

using Clock = std::chrono::steady_clock;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// One level of the scene pyramid: a window of the image at 1 / 2^level resolution.
// Level 0 borrows the scene's points; coarser levels own theirs.
struct Level {
  int u0 = 0, v0 = 0, width = 0, height = 0;
  int scale = 1;
  std::vector<Eigen::Vector3f> storage;
  const Eigen::Vector3f* points = nullptr;
  const Eigen::Vector3f& at(int i, int j) const {
    return points[static_cast<std::size_t>(j) * width + i];
  }
};

Level borrow(const OrganizedCloud& scene) {
  Level level;
  level.u0 = scene.u0;
  level.v0 = scene.v0;
  level.width = scene.width;
  level.height = scene.height;
  level.points = scene.points.data();
  return level;
}

// Each coarser pixel averages the finer 2x2 block's points near its nearest one, so silhouette
// edges stay sharp instead of blending foreground and background. `fine_valid` (optional)
// receives the number of valid fine points.
Level downsample(const Level& fine, std::size_t* fine_valid = nullptr) {
  Level coarse;
  coarse.scale = fine.scale * 2;
  coarse.u0 = fine.u0 >> 1;
  coarse.v0 = fine.v0 >> 1;
  coarse.width = std::max(0, ((fine.u0 + fine.width + 1) >> 1) - coarse.u0);
  coarse.height = std::max(0, ((fine.v0 + fine.height + 1) >> 1) - coarse.v0);
  coarse.storage.resize(static_cast<std::size_t>(coarse.width) * coarse.height);
  coarse.points = coarse.storage.data();
  // Fine pixel of the block's top-left child, relative to the fine window (may be -1 when the
  // fine window starts on an odd pixel).
  const int fi0 = 2 * coarse.u0 - fine.u0, fj0 = 2 * coarse.v0 - fine.v0;
  std::size_t valid = 0;
  for (int j = 0; j < coarse.height; ++j) {
    const int fj = fj0 + 2 * j;
    const Eigen::Vector3f* rows[2] = {
        fj >= 0 && fj < fine.height ? fine.points + static_cast<std::size_t>(fj) * fine.width
                                    : nullptr,
        fj + 1 >= 0 && fj + 1 < fine.height
            ? fine.points + static_cast<std::size_t>(fj + 1) * fine.width
            : nullptr};
    Eigen::Vector3f* out = coarse.storage.data() + static_cast<std::size_t>(j) * coarse.width;
    for (int i = 0; i < coarse.width; ++i) {
      const int fi = fi0 + 2 * i;
      // Most of a crop's window lies outside its sphere: a block of four empty pixels is the
      // common case, told from four depths.
      if (rows[0] != nullptr && rows[1] != nullptr && fi >= 0 && fi + 1 < fine.width &&
          !OrganizedCloud::valid(rows[0][fi]) && !OrganizedCloud::valid(rows[0][fi + 1]) &&
          !OrganizedCloud::valid(rows[1][fi]) && !OrganizedCloud::valid(rows[1][fi + 1])) {
        out[i] = Eigen::Vector3f::Constant(kNaN);
        continue;
      }
      const Eigen::Vector3f* block[4];
      int n = 0;
      for (const Eigen::Vector3f* row : rows) {
        if (row == nullptr) continue;
        if (fi >= 0 && OrganizedCloud::valid(row[fi])) block[n++] = &row[fi];
        if (fi + 1 < fine.width && OrganizedCloud::valid(row[fi + 1])) block[n++] = &row[fi + 1];
      }
      valid += n;
      if (n == 0) {
        out[i] = Eigen::Vector3f::Constant(kNaN);
        continue;
      }
      float z_min = block[0]->z();
      for (int k = 1; k < n; ++k) z_min = std::min(z_min, block[k]->z());
      const float z_max = z_min * 1.02f;
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      int count = 0;
      for (int k = 0; k < n; ++k) {
        if (block[k]->z() <= z_max) sum += *block[k], ++count;
      }
      out[i] = sum / static_cast<float>(count);
    }
  }
  if (fine_valid != nullptr) *fine_valid = valid;
  return coarse;
}

// Projects camera-frame points into the depth image at some pyramid level.
class Projector {
 public:
  explicit Projector(const OrganizedCloud& scene)
      : k_(scene.intrinsics),
        distorted_(scene.intrinsics.has_distortion()),
        origin_(scene.depth_to_color_m),
        fx_(static_cast<float>(k_.fx)),
        fy_(static_cast<float>(k_.fy)),
        cx_(static_cast<float>(k_.cx + 0.5)),
        cy_(static_cast<float>(k_.cy + 0.5)) {}
  // The depth camera's centre in the camera frame: where view rays start.
  const Eigen::Vector3f& origin() const { return origin_; }
  // Integer pixel at `level` (full-resolution pixel centres map to 2^-level of themselves).
  bool pixel(const Eigen::Vector3f& p_camera, const Level& level, int& i, int& j) const {
    const Eigen::Vector3f p = p_camera - origin_;
    if (p.z() <= 1e-3f) return false;
    float u, v;  // shifted by half a pixel, so truncation is the pixel index
    if (distorted_) {
      const auto px = k_.project(p.cast<double>());
      u = static_cast<float>(px->x() + 0.5), v = static_cast<float>(px->y() + 0.5);
    } else {
      const float inv_z = 1.0f / p.z();
      u = fx_ * p.x() * inv_z + cx_;
      v = fy_ * p.y() * inv_z + cy_;
    }
    if (!(u >= 0.0f && v >= 0.0f)) return false;  // also rejects NaN
    const float inv_s = 1.0f / static_cast<float>(level.scale);
    i = static_cast<int>(u * inv_s) - level.u0;
    j = static_cast<int>(v * inv_s) - level.v0;
    return i >= 0 && j >= 0 && i < level.width && j < level.height;
  }

 private:
  const PinholeModel& k_;
  bool distorted_;
  Eigen::Vector3f origin_;
  float fx_, fy_, cx_, cy_;
};

// Scene normal at a pixel from its neighbours `step` pixels away, facing the camera; zero
// when the neighbourhood has too few points.
Eigen::Vector3f scene_normal(const Level& level, int i, int j, int step,
                             const Eigen::Vector3f& view_origin) {
  auto valid_at = [&](int a, int b) -> const Eigen::Vector3f* {
    if (a < 0 || b < 0 || a >= level.width || b >= level.height) return nullptr;
    const Eigen::Vector3f& p = level.at(a, b);
    return OrganizedCloud::valid(p) ? &p : nullptr;
  };
  const Eigen::Vector3f* c = valid_at(i, j);
  const Eigen::Vector3f* r = valid_at(i + step, j);
  const Eigen::Vector3f* l = valid_at(i - step, j);
  const Eigen::Vector3f* d = valid_at(i, j + step);
  const Eigen::Vector3f* u = valid_at(i, j - step);
  const Eigen::Vector3f* h0 = l ? l : c;
  const Eigen::Vector3f* h1 = r ? r : c;
  const Eigen::Vector3f* v0 = u ? u : c;
  const Eigen::Vector3f* v1 = d ? d : c;
  if (h0 == h1 || v0 == v1) return Eigen::Vector3f::Zero();
  Eigen::Vector3f n = (*h1 - *h0).cross(*v1 - *v0);
  const float norm = n.norm();
  if (norm <= 0.0f) return Eigen::Vector3f::Zero();
  n /= norm;
  if (n.dot(*c - view_origin) > 0.0f) n = -n;
  return n;
}

// scene_normal per pixel of one pyramid level, each solved on first use.
class SceneNormals {
 public:
  bool empty() const { return solved_.empty(); }
  void reset(const Level& level) {
    const std::size_t n = static_cast<std::size_t>(level.width) * level.height;
    solved_.assign(n, 0);
    normals_.resize(n);
  }
  const Eigen::Vector3f& at(const Level& level, int i, int j, int step,
                            const Eigen::Vector3f& view_origin) {
    const std::size_t k = static_cast<std::size_t>(j) * level.width + i;
    if (!solved_[k]) {
      normals_[k] = scene_normal(level, i, j, step, view_origin);
      solved_[k] = 1;
    }
    return normals_[k];
  }

 private:
  std::vector<unsigned char> solved_;
  std::vector<Eigen::Vector3f> normals_;
};

// The scene point for a model point: at its pixel, or the nearest within +-radius pixels.
bool associate(const Level& level, const Projector& projector, const Eigen::Vector3f& p,
               int radius_px, Eigen::Vector3f& q, int& qi, int& qj) {
  int i, j;
  if (!projector.pixel(p, level, i, j)) return false;
  float best = std::numeric_limits<float>::max();
  const int i_lo = std::max(0, i - radius_px), i_hi = std::min(level.width - 1, i + radius_px);
  const int j_lo = std::max(0, j - radius_px), j_hi = std::min(level.height - 1, j + radius_px);
  for (int b = j_lo; b <= j_hi; ++b) {
    for (int a = i_lo; a <= i_hi; ++a) {
      const Eigen::Vector3f& s = level.at(a, b);
      if (!OrganizedCloud::valid(s)) continue;
      const float d2 = (s - p).squaredNorm();
      if (d2 < best) best = d2, qi = a, qj = b;
    }
  }
  if (best == std::numeric_limits<float>::max()) return false;
  q = level.at(qi, qj);
  return true;
}

Eigen::Isometry3d apply_twist(const Eigen::Matrix<double, 6, 1>& xi, const Eigen::Isometry3d& T) {
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = xi.head<3>();
  const double angle = w.norm();
  if (angle > 0.0) delta.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  delta.translation() = xi.tail<3>();
  Eigen::Isometry3d out = delta * T;
  // Re-orthonormalize so thousands of small updates never drift off SO(3).
  out.linear() = Eigen::Quaterniond(out.linear()).normalized().toRotationMatrix();
  return out;
}

// Scene normals from neighbours this far apart: wide enough at full resolution to see through
// the sensor noise, adjacent at the coarse levels where averaging already smoothed it.
int normal_step(const Level& level) {
  return level.scale == 1 ? 2 : 1;
}

// The model's own depth image at 1/4 resolution (every model point facing the camera splatted
// into its cell), so points hidden behind another part of the model (the ears, the far flank)
// count neither for nor against a pose.
std::vector<float> model_depth_buffer(const IcpModel& model, const Level& grid,
                                      const Projector& projector, const Eigen::Matrix3f& R,
                                      const Eigen::Vector3f& t) {
  std::vector<float> z_buffer(static_cast<std::size_t>(grid.width) * grid.height,
                              std::numeric_limits<float>::infinity());
  // A prefix dense enough to cover every cell of a target at working distance.
  const std::size_t n = std::min<std::size_t>(model.points().size(), 8000);
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3f p = R * model.points()[k] + t;
    if ((R * model.normals()[k]).dot(p - projector.origin()) >= 0.0f) continue;
    int i, j;
    if (!projector.pixel(p, grid, i, j)) continue;
    float& z = z_buffer[static_cast<std::size_t>(j) * grid.width + i];
    z = std::min(z, p.z() - projector.origin().z());
  }
  return z_buffer;
}

// The model points align's quality judges by: facing the camera, not hidden behind the model's
// own parts, in the scene window, with a scene point within inlier_distance_m. `visit(k, p, n,
// q)` gets each (model index, model point and normal in the camera frame, scene point);
// returns the candidates' count.
template <typename Visit>
std::size_t visit_inliers(const IcpModel& model, const Level& level, const Projector& projector,
                          const Eigen::Isometry3d& T, const IcpOptions& options,
                          std::size_t max_model_points, Visit&& visit) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  Level grid;  // geometry only
  grid.scale = level.scale * 4;
  grid.u0 = level.u0 >> 2;
  grid.v0 = level.v0 >> 2;
  grid.width = ((level.u0 + level.width + 3) >> 2) - grid.u0;
  grid.height = ((level.v0 + level.height + 3) >> 2) - grid.v0;
  const std::vector<float> z_buffer = model_depth_buffer(model, grid, projector, R, t);
  const std::size_t n_model = std::min<std::size_t>(model.points().size(), max_model_points);
  const float inlier_m = static_cast<float>(options.inlier_distance_m);
  const float hidden_m = std::max(0.01f, 2.0f * inlier_m);
  std::size_t candidates = 0;
  for (std::size_t k = 0; k < n_model; ++k) {
    const Eigen::Vector3f p = R * model.points()[k] + t;
    const Eigen::Vector3f n = R * model.normals()[k];
    if (n.dot(p - projector.origin()) >= 0.0f) continue;
    int i, j, gi, gj;
    if (!projector.pixel(p, level, i, j) || !projector.pixel(p, grid, gi, gj)) continue;
    const float z_front = z_buffer[static_cast<std::size_t>(gj) * grid.width + gi];
    if (p.z() - projector.origin().z() > z_front + hidden_m) continue;
    ++candidates;
    const Eigen::Vector3f& q = level.at(i, j);
    if (!OrganizedCloud::valid(q) || (q - p).norm() > inlier_m) continue;
    visit(k, p, n, q);
  }
  return candidates;
}

void measure_quality(const IcpModel& model, const Level& level, const Projector& projector,
                     const Eigen::Isometry3d& T, const IcpOptions& options,
                     RegistrationResult& result) {
  // A few thousand points pin a fraction down to about a percent; more only cost time.
  std::size_t inliers = 0;
  double sum_sq = 0.0;
  const std::size_t candidates =
      visit_inliers(model, level, projector, T, options, 3000,
                    [&](std::size_t, const Eigen::Vector3f& p, const Eigen::Vector3f& n,
                        const Eigen::Vector3f& q) {
                      ++inliers;
                      const double r = n.dot(p - q);
                      sum_sq += r * r;
                    });
  result.inliers = inliers;
  result.inlier_fraction = candidates > 0 ? static_cast<double>(inliers) / candidates : 0.0;
  result.rmse_mm = inliers > 0 ? 1000.0 * std::sqrt(sum_sq / inliers) : 0.0;
}

// Also counts the scene's valid points, on the way through level 0.
std::vector<Level> build_pyramid(const OrganizedCloud& scene, int levels, std::size_t& valid) {
  std::vector<Level> pyramid;
  pyramid.reserve(levels);
  pyramid.push_back(borrow(scene));
  valid = 0;
  if (levels == 1) valid = scene.valid_count();
  for (int l = 1; l < levels; ++l) {
    pyramid.push_back(downsample(pyramid.back(), l == 1 ? &valid : nullptr));
  }
  return pyramid;
}

RegistrationResult run_schedule(const IcpModel& model, const std::vector<Level>& pyramid,
                                const Projector& projector, const Eigen::Isometry3d& guess,
                                const IcpOptions& options) {
  RegistrationResult result;
  const float cos_max_angle =
      static_cast<float>(std::cos(options.max_normal_angle_deg * kPi / 180.0));

  Eigen::Isometry3d T = guess;
  bool every_stage_matched = true;
  // Scene normals are solved for a pixel the first time a match lands there and kept for the
  // frame's later iterations, which land mostly on the same pixels.
  std::vector<SceneNormals> normals(pyramid.size());
  for (const IcpStage& stage : options.stages) {
    const Level& level = pyramid[stage.pyramid_level];
    SceneNormals& level_normals = normals[stage.pyramid_level];
    if (level_normals.empty()) level_normals.reset(level);
    const std::size_t n_model = std::min<std::size_t>(
        model.points().size(), static_cast<std::size_t>(stage.max_model_points));
    const float max_d2 = static_cast<float>(stage.max_distance_m * stage.max_distance_m);
    const double tukey_c = options.tukey_scale * stage.max_distance_m;
    const int step = normal_step(level);
    for (int it = 0; it < stage.iterations; ++it) {
      const Eigen::Matrix3f R = T.linear().cast<float>();
      const Eigen::Vector3f t = T.translation().cast<float>();
      // One pass: each match is weighed and summed into the 6x6 system as it is found, in the
      // model's order (the sums, and so the pose, are the same on every run).
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      std::size_t matched = 0;
      for (std::size_t k = 0; k < n_model; ++k) {
        const Eigen::Vector3f p = R * model.points()[k] + t;
        const Eigen::Vector3f n = R * model.normals()[k];
        // Only the side facing the camera can be seen; the back side would otherwise match
        // the support plane or the far surface of the target itself.
        if (n.dot(p - projector.origin()) >= 0.0f) continue;
        Eigen::Vector3f q;
        int qi, qj;
        if (!associate(level, projector, p, stage.search_radius_px, q, qi, qj)) continue;
        if ((q - p).squaredNorm() > max_d2) continue;
        const Eigen::Vector3f& ns = level_normals.at(level, qi, qj, step, projector.origin());
        if (ns.isZero() || ns.dot(n) < cos_max_angle) continue;
        ++matched;
        const double r = n.dot(p - q);
        double w = 1.0;
        if (tukey_c > 0.0) {
          const double u = r / tukey_c;
          if (std::abs(u) >= 1.0) continue;
          w = (1.0 - u * u) * (1.0 - u * u);
        }
        Eigen::Matrix<double, 6, 1> J;
        J.head<3>() = p.cross(n).cast<double>();
        J.tail<3>() = n.cast<double>();
        for (int a = 0; a < 6; ++a) {
          for (int b = 0; b <= a; ++b) H(a, b) += w * J[a] * J[b];
        }
        g += (w * r) * J;
      }
      ++result.iterations;
      if (matched < 12) {
        every_stage_matched = false;
        break;
      }
      H = H.selfadjointView<Eigen::Lower>();
      // A touch of damping keeps a flat or symmetric patch from making the solve singular.
      H.diagonal().array() += 1e-9 + 1e-6 * H.diagonal().maxCoeff();
      Eigen::Matrix<double, 6, 1> xi = Eigen::Matrix<double, 6, 1>::Zero();
      if (stage.translation_only) {
        xi.tail<3>() = H.bottomRightCorner<3, 3>().ldlt().solve(-g.tail<3>());
      } else {
        xi = H.ldlt().solve(-g);
      }
      if (!xi.allFinite()) {
        every_stage_matched = false;
        break;
      }
      T = apply_twist(xi, T);
      if (xi.tail<3>().norm() < options.min_update_m * level.scale &&
          xi.head<3>().norm() < options.min_update_rad * level.scale)
        break;
    }
  }
  result.T_camera_model = T;
  result.converged = every_stage_matched;
  measure_quality(model, pyramid[0], projector, T, options, result);
  return result;
}

bool better(const RegistrationResult& a, const RegistrationResult& b) {
  if (a.converged != b.converged) return a.converged;
  return a.inlier_fraction > b.inlier_fraction;
}

RegistrationResult align_impl(const IcpModel& model, const OrganizedCloud& scene,
                              const Eigen::Isometry3d& guess, const IcpOptions& options,
                              Clock::time_point started) {
  int levels = 1;
  for (const IcpStage& s : options.stages) levels = std::max(levels, s.pyramid_level + 1);
  std::size_t scene_points = 0;
  const std::vector<Level> pyramid = build_pyramid(scene, levels, scene_points);
  const Projector projector(scene);
  RegistrationResult best = run_schedule(model, pyramid, projector, guess, options);
  int iterations = best.iterations, hypotheses = 1;
  if (best.inlier_fraction < options.retry_below_inlier_fraction) {
    for (int axis = 0; axis < 6; ++axis) {
      Eigen::Isometry3d hypothesis = guess;
      hypothesis.translation()[axis / 2] += (axis % 2 ? -1.0 : 1.0) * options.hypothesis_offset_m;
      RegistrationResult r = run_schedule(model, pyramid, projector, hypothesis, options);
      iterations += r.iterations;
      ++hypotheses;
      if (better(r, best)) best = r;
      if (best.inlier_fraction >= options.retry_below_inlier_fraction) break;
    }
  }
  best.iterations = iterations;
  best.hypotheses = hypotheses;
  best.scene_points = scene_points;
  best.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
  return best;
}

}  // namespace

RegistrationResult align_projective_icp(const IcpModel& model, const OrganizedCloud& scene,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        const IcpOptions& options) {
  return align_impl(model, scene, T_camera_model_guess, options, Clock::now());
}

RegistrationResult align_projective_icp(const IcpModel& model, const DepthFrame& frame,
                                        const Eigen::Vector3d& depth_to_color_m,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        double crop_margin_m, const IcpOptions& options) {
  const auto started = Clock::now();
  const OrganizedCloud scene =
      crop_sphere(frame, depth_to_color_m, T_camera_model_guess.translation(),
                  model.bounding_radius_m() + crop_margin_m);
  return align_impl(model, scene, T_camera_model_guess, options, started);
}

RegistrationResult evaluate_alignment(const IcpModel& model, const OrganizedCloud& scene,
                                      const Eigen::Isometry3d& T_camera_model,
                                      const IcpOptions& options) {
  const auto started = Clock::now();
  RegistrationResult result;
  result.T_camera_model = T_camera_model;
  result.scene_points = scene.valid_count();
  const Projector projector(scene);
  measure_quality(model, borrow(scene), projector, T_camera_model, options, result);
  result.converged = true;
  result.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
  return result;
}

PoseSpread pose_spread(const IcpModel& model, const OrganizedCloud& scene,
                       const Eigen::Isometry3d& T_camera_model,
                       const std::vector<Eigen::Vector3d>& points_model, double block_m,
                       const IcpOptions& options) {
  if (!(block_m > 0.0)) throw std::invalid_argument("pose_spread: block_m must be > 0");
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  struct Block {
    Matrix6 H = Matrix6::Zero();
    Vector6 g = Vector6::Zero();
    std::size_t matches = 0;
  };
  // The linearised point-to-plane problem at the pose, per block of the model: a residual r
  // moves by (p x n) . w + n . t under a small turn w and shift t.
  std::map<std::array<int, 3>, Block> blocks;
  Block all;
  const Projector projector(scene);
  visit_inliers(model, borrow(scene), projector, T_camera_model, options, model.points().size(),
                [&](std::size_t k, const Eigen::Vector3f& p, const Eigen::Vector3f& n,
                    const Eigen::Vector3f& q) {
                  Vector6 J;
                  J.head<3>() = p.cast<double>().cross(n.cast<double>());
                  J.tail<3>() = n.cast<double>();
                  const double r = n.cast<double>().dot((p - q).cast<double>());
                  const Eigen::Vector3f& m = model.points()[k];
                  const std::array<int, 3> key = {static_cast<int>(std::floor(m.x() / block_m)),
                                                  static_cast<int>(std::floor(m.y() / block_m)),
                                                  static_cast<int>(std::floor(m.z() / block_m))};
                  for (Block* b : {&blocks[key], &all}) {
                    b->H += J * J.transpose();
                    b->g += J * r;
                    ++b->matches;
                  }
                });
  PoseSpread out;
  out.matches = all.matches;
  // Blocks with a handful of points say little and their leave-one-out fits are nearly the full
  // one's: they stay in the sums but are not left out on their own.
  constexpr std::size_t kMinBlockMatches = 20;
  std::vector<const Block*> counted;
  for (const auto& [key, b] : blocks) {
    if (b.matches >= kMinBlockMatches) counted.push_back(&b);
  }
  out.blocks = static_cast<int>(counted.size());
  if (counted.size() < 4) return out;
  // Directions the whole fit hardly constrains (a flat face's slide along itself) are left to
  // other checks: every solve is regularised by a small share of the largest curvature.
  const double damping = 1e-6 * all.H.trace();
  std::vector<std::vector<Eigen::Vector3d>> moved(points_model.size());
  for (const Block* b : counted) {
    const Matrix6 H = all.H - b->H + damping * Matrix6::Identity();
    const Vector6 step = -H.ldlt().solve(all.g - b->g);
    const Eigen::Vector3d w = step.head<3>(), t = step.tail<3>();
    for (std::size_t i = 0; i < points_model.size(); ++i) {
      const Eigen::Vector3d m = T_camera_model * points_model[i];
      moved[i].push_back(w.cross(m) + t);
    }
  }
  const double K = static_cast<double>(counted.size());
  for (const auto& d : moved) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& v : d) mean += v / K;
    double sum_sq = 0.0;
    for (const auto& v : d) sum_sq += (v - mean).squaredNorm();
    out.model_point_mm = std::max(out.model_point_mm, 1e3 * std::sqrt((K - 1.0) / K * sum_sq));
  }
  return out;
}

}  // namespace projtour
