// The referee: where projected pixels really land, and the before/after pictures.
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "projtour/geometry.hpp"
#include "sim_internal.hpp"

namespace projtour::sim {

TrueProjection true_projection(const TargetSpec& target, const Eigen::Isometry3d& T_map_model,
                               const Scene& alone, const Eigen::Isometry3d& T_map_projector,
                               const PinholeModel& projector,
                               const std::array<Eigen::Vector2d, 4>& projector_px) {
  TrueProjection out;
  out.chosen_px = projector_px;
  for (int i = 0; i < 4; ++i) out.model_points_map[i] = T_map_model * target.model_points[i];
  const auto& P = out.model_points_map;
  const Eigen::Vector3d centre = 0.25 * (P[0] + P[1] + P[2] + P[3]);
  Eigen::Vector3d normal = (P[2] - P[0]).cross(P[3] - P[1]);
  normal = normal.norm() > 1e-12 ? normal.normalized() : Eigen::Vector3d::Zero();
  const Eigen::Isometry3d T_projector_map = T_map_projector.inverse();
  const Eigen::Vector3d origin = T_map_projector.translation();
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d dir = T_map_projector.linear() * projector.unproject(projector_px[i]);
    RayHit hit;
    out.on_mesh[i] = alone.intersect(origin.cast<float>(), dir.cast<float>(),
                                     std::numeric_limits<float>::infinity(), hit);
    if (out.on_mesh[i]) {
      // The hit parameter is float (sub-micrometre at these ranges); the point is rebuilt in
      // double.
      out.landed_map[i] = origin + static_cast<double>(hit.t) * dir;
    } else {
      const double denom = normal.dot(dir);
      const double t = std::abs(denom) > 1e-9 ? normal.dot(centre - origin) / denom : -1.0;
      if (t > 0.0) {
        out.landed_map[i] = origin + t * dir;
      } else {
        // Parallel to the plane or pointing away: the ray's closest approach to the point.
        const double s = std::max(0.0, (P[i] - origin).dot(dir) / dir.squaredNorm());
        out.landed_map[i] = origin + s * dir;
      }
    }
    const auto truth_px = projector.project(T_projector_map * P[i]);
    out.error_px[i] =
        truth_px ? (*truth_px - projector_px[i]).norm() : std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

void write_projection_view(const Scene& alone, const Eigen::Isometry3d& T_map_model,
                           const TrueProjection& projection, const std::string& title,
                           const std::filesystem::path& file) {
  PinholeModel k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 600.0;
  k.cx = 319.5;
  k.cy = 239.5;
  // A virtual camera in front of the target (its +x side), looking at the true Model Points'
  // centre from far enough that they fill about half the picture, upright.
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  for (const auto& p : projection.model_points_map) target += p / 4.0;
  double extent_m = 0.0;
  for (const auto& p : projection.model_points_map)
    extent_m = std::max(extent_m, (p - target).norm());
  const double distance_m = std::max(0.25, 2.0 * extent_m * k.fx / (0.5 * k.height));
  const Eigen::Vector3d eye = target + distance_m * T_map_model.linear().col(0);
  const Eigen::Vector3d forward = (target - eye).normalized();
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  if (right.norm() < 1e-6) right = forward.cross(Eigen::Vector3d::UnitY());
  right.normalize();
  Eigen::Isometry3d T_map_view = Eigen::Isometry3d::Identity();
  T_map_view.linear().col(0) = right;
  T_map_view.linear().col(1) = forward.cross(right);
  T_map_view.linear().col(2) = forward;
  T_map_view.translation() = eye;

  const DepthRenderer renderer(k);
  IdealDepth ideal;
  renderer.render(alone, T_map_view, ideal);
  cv::Mat image(k.height, k.width, CV_8UC3, cv::Scalar(40, 40, 40));
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * k.width + u;
      if (ideal.object_id[i] == kNoObject) continue;
      // Lambert under a head light, plus some ambient so dark flanks stay visible.
      const auto g = static_cast<unsigned char>(60.0 + 180.0 * ideal.cos_incidence[i]);
      image.at<cv::Vec3b>(v, u) = cv::Vec3b(g, g, g);
    }
  }
  const Eigen::Isometry3d T_view_map = T_map_view.inverse();
  auto to_image = [&](const Eigen::Vector3d& p_map) -> std::optional<cv::Point> {
    const auto px = k.project(T_view_map * p_map);
    if (!px) return std::nullopt;
    return cv::Point(static_cast<int>(std::lround(px->x())),
                     static_cast<int>(std::lround(px->y())));
  };
  for (int i = 0; i < 4; ++i) {
    const auto a = to_image(projection.landed_map[i]);
    const auto b = to_image(projection.landed_map[(i + 1) % 4]);
    if (a && b) cv::line(image, *a, *b, cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
    if (a) cv::circle(image, *a, 3, cv::Scalar(0, 0, 255), cv::FILLED, cv::LINE_AA);
    if (const auto m = to_image(projection.model_points_map[i])) {
      cv::circle(image, *m, 7, cv::Scalar(0, 220, 0), 2, cv::LINE_AA);
    }
  }
  double mean_mm = 0.0;
  for (int i = 0; i < 4; ++i) {
    mean_mm += 250.0 * (projection.landed_map[i] - projection.model_points_map[i]).norm();
  }
  std::ostringstream caption;
  caption.precision(1);
  caption << std::fixed << title << ": mean corner error " << mean_mm << " mm";
  cv::putText(image, caption.str(), cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.6,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  cv::putText(image, "red: where the content lands   green: true Model Points", cv::Point(10, 465),
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(220, 220, 220), 1, cv::LINE_AA);
  if (!cv::imwrite(file.string(), image)) {
    throw std::runtime_error("cannot write " + file.string());
  }
}

}  // namespace projtour::sim
