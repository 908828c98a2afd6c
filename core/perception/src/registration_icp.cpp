// Point-to-plane ICP with projective data association through the organized depth image: the
// schedule of stages, the quality measures and the public entry points. The parts the hot loop
// inlines live in this unit's private headers: the scratch buffers (icp_scratch.hpp), the scene
// pyramid (icp_scene_pyramid.hpp), the association (icp_association.hpp) and the normal
// equations (icp_normal_equations.hpp).
#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <random>

#include <stdexcept>
#include <string>

#include "crop_internal.hpp"
#include "icp_association.hpp"
#include "icp_normal_equations.hpp"
#include "icp_scene_pyramid.hpp"
#include "icp_scratch.hpp"
#include "projtour/contract/geometry.hpp"
#include "projtour/perception/registration.hpp"

namespace projtour::perception {

std::vector<IcpStage> IcpOptions::default_stages() {
  // Coarse levels see the whole target in few pixels, and their window lets a model point find
  // its surface several centimetres away; the fine levels then settle on the noise floor.
  return {
      {4, 250, 1, 0.15, 6, true}, {3, 250, 1, 0.10, 6},  {2, 500, 1, 0.04, 5},
      {1, 1000, 0, 0.02, 4},      {0, 4500, 0, 0.01, 2},
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
  const std::size_t n = points_.size();
  columns_.resize(6 * n);
  for (std::size_t k = 0; k < n; ++k) {
    for (int c = 0; c < 3; ++c) {
      columns_[c * n + k] = points_[k][c];
      columns_[(3 + c) * n + k] = normals_[k][c];
    }
  }
}

namespace {

using Clock = std::chrono::steady_clock;

// The model's own depth image at 1/4 resolution (every model point facing the camera splatted
// into its cell), so points hidden behind another part of the model (the ears, the far flank)
// count neither for nor against a pose.
float* model_depth_buffer(MovedModel& moved, const Level& grid, const Projector& projector,
                          Scratch& scratch) {
  const std::size_t cells = static_cast<std::size_t>(grid.width) * grid.height;
  float* z_buffer = scratch.take<float>(cells);
  std::fill(z_buffer, z_buffer + cells, std::numeric_limits<float>::infinity());
  // A prefix dense enough to cover every cell of a target at working distance.
  moved.land(grid, std::min<std::size_t>(moved.n, 8000));
  for (std::size_t h = 0; h < moved.hits; ++h) {
    const int k = moved.hit[h];
    float& z = z_buffer[grid.cell(moved.i[k], moved.j[k])];
    z = std::min(z, moved.pz[k] - projector.origin().z());
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
                          std::size_t max_model_points, Scratch& scratch, Visit&& visit) {
  Level grid;  // geometry only
  grid.scale = level.scale * 4;
  grid.u0 = level.u0 >> 2;
  grid.v0 = level.v0 >> 2;
  grid.width = ((level.u0 + level.width + 3) >> 2) - grid.u0;
  grid.height = ((level.v0 + level.height + 3) >> 2) - grid.v0;
  const std::size_t n_model = std::min<std::size_t>(model.size(), max_model_points);
  const std::size_t n_moved =
      std::max<std::size_t>(n_model, std::min<std::size_t>(model.size(), 8000));
  MovedModel moved(n_moved, scratch);
  projector.move(model, n_moved, T, moved);
  const float* z_buffer = model_depth_buffer(moved, grid, projector, scratch);
  const float inlier_m = static_cast<float>(options.inlier_distance_m);
  const float hidden_m = std::max(0.01f, 2.0f * inlier_m);
  std::size_t candidates = 0;
  moved.land(level, n_model);
  for (std::size_t h = 0; h < moved.hits; ++h) {
    const int k = moved.hit[h], i = moved.i[k], j = moved.j[k];
    // The grid's cells are blocks of 4x4 of the level's pixels, and hold its whole window.
    const float z_front =
        z_buffer[grid.cell(((level.u0 + i) >> 2) - grid.u0, ((level.v0 + j) >> 2) - grid.v0)];
    if (moved.pz[k] - projector.origin().z() > z_front + hidden_m) continue;
    ++candidates;
    level.ensure(i, j);
    if (!level.valid(i, j)) continue;
    const Eigen::Vector3f p = moved.p(k), q = level.at(i, j);
    if ((q - p).norm() > inlier_m) continue;
    visit(k, p, moved.normal(k), q);
  }
  return candidates;
}

void measure_quality(const IcpModel& model, const Level& level, const Projector& projector,
                     const Eigen::Isometry3d& T, const IcpOptions& options, Scratch& scratch,
                     RegistrationResult& result) {
  // A few thousand points pin a fraction down to about a percent; more only cost time.
  std::size_t inliers = 0;
  double sum_sq = 0.0;
  const std::size_t candidates =
      visit_inliers(model, level, projector, T, options, 3000, scratch,
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

RegistrationResult run_schedule(const IcpModel& model, const ScenePyramid& pyramid,
                                const Projector& projector, const Eigen::Isometry3d& guess,
                                const IcpOptions& options, Scratch& scratch) {
  RegistrationResult result;
  const float cos_max_angle =
      static_cast<float>(std::cos(options.max_normal_angle_deg * kPi / 180.0));

  Eigen::Isometry3d T = guess;
  bool every_stage_matched = true;
  // Scene normals are solved for a pixel the first time a match lands there and kept for the
  // frame's later iterations, which land mostly on the same pixels.
  std::vector<std::optional<SceneNormals>> normals(pyramid.levels());
  std::size_t most_points = 0;
  for (const IcpStage& stage : options.stages) {
    most_points = std::max<std::size_t>(most_points, std::max(0, stage.max_model_points));
  }
  most_points = std::min(most_points, model.size());
  NormalEquations equations(most_points, scratch);
  MovedModel moved(most_points, scratch);
  for (const IcpStage& stage : options.stages) {
    const Level& level = pyramid.level(stage.pyramid_level);
    auto& level_normals = normals[stage.pyramid_level];
    if (!level_normals) level_normals.emplace(level, scratch);
    const std::size_t n_model = std::min<std::size_t>(
        model.size(), static_cast<std::size_t>(std::max(0, stage.max_model_points)));
    const float max_d2 = static_cast<float>(stage.max_distance_m * stage.max_distance_m);
    const double tukey_c = options.tukey_scale * stage.max_distance_m;
    for (int it = 0; it < stage.iterations; ++it) {
      projector.move(model, n_model, T, moved);
      equations.clear();
      moved.land(level, n_model);
      for (std::size_t h = 0; h < moved.hits; ++h) {
        const int k = moved.hit[h], i = moved.i[k], j = moved.j[k];
        const Eigen::Vector3f p = moved.p(k);
        Eigen::Vector3f q;
        int qi, qj;
        if (!associate(level, p, i, j, stage.search_radius_px, q, qi, qj)) continue;
        if ((q - p).squaredNorm() > max_d2) continue;
        const Eigen::Vector3f n = moved.normal(k);
        const Eigen::Vector3f ns = level_normals->at(qi, qj, projector.origin());
        if (ns.isZero() || ns.dot(n) < cos_max_angle) continue;
        equations.add(p, n, n.dot(p - q));
      }
      ++result.iterations;
      if (equations.size() < 12) {
        every_stage_matched = false;
        break;
      }
      Eigen::Matrix<double, 6, 6> H;
      Eigen::Matrix<double, 6, 1> g;
      equations.weigh(tukey_c);
      equations.solve_inputs(H, g);
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
  measure_quality(model, pyramid.level(0), projector, T, options, scratch, result);
  return result;
}

bool better(const RegistrationResult& a, const RegistrationResult& b) {
  if (a.converged != b.converged) return a.converged;
  return a.inlier_fraction > b.inlier_fraction;
}

int pyramid_levels(const IcpOptions& options) {
  int levels = 1;
  for (const IcpStage& s : options.stages) {
    if (s.pyramid_level < 0) {
      throw std::invalid_argument("align_projective_icp: pyramid_level < 0");
    }
    levels = std::max(levels, s.pyramid_level + 1);
  }
  return levels;
}

RegistrationResult align_impl(const IcpModel& model, const ScenePyramid& pyramid,
                              const Projector& projector, const Eigen::Isometry3d& guess,
                              const IcpOptions& options, Scratch& scratch) {
  RegistrationResult best = run_schedule(model, pyramid, projector, guess, options, scratch);
  int iterations = best.iterations, hypotheses = 1;
  if (best.inlier_fraction < options.retry_below_inlier_fraction) {
    for (int axis = 0; axis < 6; ++axis) {
      Eigen::Isometry3d hypothesis = guess;
      hypothesis.translation()[axis / 2] += (axis % 2 ? -1.0 : 1.0) * options.hypothesis_offset_m;
      RegistrationResult r = run_schedule(model, pyramid, projector, hypothesis, options, scratch);
      iterations += r.iterations;
      ++hypotheses;
      if (better(r, best)) best = r;
      if (best.inlier_fraction >= options.retry_below_inlier_fraction) break;
    }
  }
  best.iterations = iterations;
  best.hypotheses = hypotheses;
  return best;
}

}  // namespace

RegistrationResult align_projective_icp(const IcpModel& model, const OrganizedCloud& scene,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        const IcpOptions& options) {
  const auto started = Clock::now();
  Scratch::Lease scratch;
  const ScenePyramid pyramid(scene, pyramid_levels(options), *scratch);
  RegistrationResult result =
      align_impl(model, pyramid, Projector(scene), T_camera_model_guess, options, *scratch);
  result.scene_points = scene.valid_count();
  result.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
  return result;
}

RegistrationResult align_projective_icp(const IcpModel& model, const DepthFrame& frame,
                                        const Eigen::Vector3d& depth_to_color_m,
                                        const Eigen::Isometry3d& T_camera_model_guess,
                                        double crop_margin_m, const IcpOptions& options) {
  const auto started = Clock::now();
  detail::check_frame(frame);
  const detail::SphereCrop crop =
      detail::sphere_crop(frame, depth_to_color_m, T_camera_model_guess.translation(),
                          model.bounding_radius_m() + crop_margin_m);
  Scratch::Lease scratch;
  const ScenePyramid pyramid(frame, crop, pyramid_levels(options), *scratch);
  RegistrationResult result =
      align_impl(model, pyramid, Projector(frame.intrinsics, crop.depth_to_color_m),
                 T_camera_model_guess, options, *scratch);
  result.scene_points = pyramid.level0_valid();
  result.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - started).count();
  return result;
}

RegistrationResult evaluate_alignment(const IcpModel& model, const OrganizedCloud& scene,
                                      const Eigen::Isometry3d& T_camera_model,
                                      const IcpOptions& options) {
  const auto started = Clock::now();
  RegistrationResult result;
  result.T_camera_model = T_camera_model;
  result.scene_points = scene.valid_count();
  Scratch::Lease scratch;
  const ScenePyramid pyramid(scene, 1, *scratch);
  measure_quality(model, pyramid.level(0), Projector(scene), T_camera_model, options, *scratch,
                  result);
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
  Scratch::Lease scratch;
  const ScenePyramid pyramid(scene, 1, *scratch);
  visit_inliers(model, pyramid.level(0), projector, T_camera_model, options, model.size(), *scratch,
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

}  // namespace projtour::perception
