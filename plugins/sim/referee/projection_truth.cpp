// The referee: where projected pixels really land, and the before/after pictures.
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/run_image.hpp"
#include "referee/projection_truth.hpp"

namespace projtour::sim {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The plane of the true Model Points: their centre and unit normal (zero when they are in a
// line).
struct ModelPlane {
  Eigen::Vector3d centre;
  Eigen::Vector3d normal;
};

ModelPlane model_plane(const std::array<Eigen::Vector3d, 4>& P) {
  const Eigen::Vector3d centre = 0.25 * (P[0] + P[1] + P[2] + P[3]);
  Eigen::Vector3d normal = (P[2] - P[0]).cross(P[3] - P[1]);
  normal = normal.norm() > 1e-12 ? normal.normalized() : Eigen::Vector3d::Zero();
  return {centre, normal};
}

// Where the ray origin + t * dir meets the target: its true surface, else the Model Points'
// plane, else (parallel to it or pointing away) the ray's closest approach to `near_m`.
Eigen::Vector3d land(const Scene& alone, const ModelPlane& plane, const Eigen::Vector3d& origin,
                     const Eigen::Vector3d& dir, const Eigen::Vector3d& near_m, bool& on_mesh) {
  RayHit hit;
  on_mesh = alone.intersect(origin.cast<float>(), dir.cast<float>(),
                            std::numeric_limits<float>::infinity(), hit);
  if (on_mesh) {
    // The hit parameter is float (sub-micrometre at these ranges); the point is rebuilt in
    // double.
    return origin + static_cast<double>(hit.t) * dir;
  }
  const double denom = plane.normal.dot(dir);
  const double t = std::abs(denom) > 1e-9 ? plane.normal.dot(plane.centre - origin) / denom : -1.0;
  if (t > 0.0) return origin + t * dir;
  const double s = std::max(0.0, (near_m - origin).dot(dir) / dir.squaredNorm());
  return origin + s * dir;
}

// The homography taking `from` exactly to `to`, in double: the referee's figures must read ~0
// for perfect pixels, which float solving (as the robot's warp does) would blur to ~1e-4 px.
std::optional<Eigen::Matrix3d> homography(const std::array<Eigen::Vector2d, 4>& from,
                                          const std::array<Eigen::Vector2d, 4>& to) {
  Eigen::Matrix<double, 8, 8> A;
  Eigen::Matrix<double, 8, 1> b;
  for (int i = 0; i < 4; ++i) {
    const double x = from[i].x(), y = from[i].y(), u = to[i].x(), v = to[i].y();
    A.row(2 * i) << x, y, 1, 0, 0, 0, -u * x, -u * y;
    A.row(2 * i + 1) << 0, 0, 0, x, y, 1, -v * x, -v * y;
    b(2 * i) = u;
    b(2 * i + 1) = v;
  }
  if (!A.allFinite() || !b.allFinite()) return std::nullopt;
  const Eigen::FullPivLU<Eigen::Matrix<double, 8, 8>> lu(A);
  if (!lu.isInvertible()) return std::nullopt;
  const Eigen::Matrix<double, 8, 1> h = lu.solve(b);
  Eigen::Matrix3d H;
  H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  if (!H.allFinite()) return std::nullopt;
  return H;
}

Eigen::Vector2d apply(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = H * Eigen::Vector3d(p.x(), p.y(), 1.0);
  return q.head<2>() / q.z();
}

// Ideal (undistorted) pinhole pixel of a z = 1 ray, and back.
Eigen::Vector2d ideal_pixel(const PinholeModel& k, const Eigen::Vector3d& ray) {
  return {k.fx * ray.x() / ray.z() + k.cx, k.fy * ray.y() / ray.z() + k.cy};
}
Eigen::Vector3d ideal_ray(const PinholeModel& k, const Eigen::Vector2d& ideal) {
  return {(ideal.x() - k.cx) / k.fx, (ideal.y() - k.cy) / k.fy, 1.0};
}

}  // namespace

TrueProjection true_projection(const TargetSpec& target, const Eigen::Isometry3d& T_map_model,
                               const Scene& alone, const Eigen::Isometry3d& T_map_projector,
                               const PinholeModel& projector,
                               const std::array<Eigen::Vector2d, 4>& projector_px) {
  TrueProjection out;
  out.chosen_px = projector_px;
  for (int i = 0; i < 4; ++i) out.model_points_map[i] = T_map_model * target.model_points[i];
  const auto& P = out.model_points_map;
  const ModelPlane plane = model_plane(P);
  const Eigen::Isometry3d T_projector_map = T_map_projector.inverse();
  const Eigen::Vector3d origin = T_map_projector.translation();
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d dir = T_map_projector.linear() * projector.unproject(projector_px[i]);
    out.landed_map[i] = land(alone, plane, origin, dir, P[i], out.on_mesh[i]);
    bool perfect_on_mesh = false;
    out.surface_points_map[i] = land(alone, plane, origin, P[i] - origin, P[i], perfect_on_mesh);
    const auto truth_px = projector.project(T_projector_map * P[i]);
    out.error_px[i] =
        truth_px ? (*truth_px - projector_px[i]).norm() : std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

AreaFigures area_figures(const TargetSpec& target, const Eigen::Isometry3d& T_map_model,
                         const Scene& alone, const Scene& full, int object_id,
                         const Eigen::Isometry3d& T_map_projector, const PinholeModel& projector,
                         const std::array<Eigen::Vector2d, 4>& projector_px) {
  AreaFigures out{kNaN, kNaN, kNaN};
  std::array<Eigen::Vector3d, 4> P;
  for (int i = 0; i < 4; ++i) P[i] = T_map_model * target.model_points[i];
  const ModelPlane plane = model_plane(P);
  const Eigen::Isometry3d T_projector_map = T_map_projector.inverse();
  const Eigen::Vector3d origin = T_map_projector.translation();
  const Eigen::Matrix3d R_map_projector = T_map_projector.linear();
  // The content's corners in the content order, as the unit square.
  const std::array<Eigen::Vector2d, 4> unit = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0),
                                               Eigen::Vector2d(1, 1), Eigen::Vector2d(0, 1)};
  std::array<Eigen::Vector2d, 4> chosen_ideal, true_ideal;
  bool in_front = true;
  for (int i = 0; i < 4; ++i) {
    chosen_ideal[i] = ideal_pixel(projector, projector.unproject(projector_px[i]));
    const Eigen::Vector3d p = T_projector_map * P[i];
    in_front = in_front && p.z() > 0.0;
    true_ideal[i] = ideal_pixel(projector, p);
  }
  const auto robot = homography(unit, chosen_ideal);
  const auto perfect = in_front ? homography(unit, true_ideal) : std::nullopt;
  // A warp puts a content point on an ideal pixel; the projector lights the distorted pixel
  // that has it as its ideal image, and the true projector's ray through that pixel carries it.
  // The robot's model and the true projector share their intrinsics (the world perturbs only
  // the mount), but the two steps are kept apart as the light takes them.
  const auto lit_pixel = [&](const Eigen::Matrix3d& H, const Eigen::Vector2d& content) {
    return projector.project(ideal_ray(projector, apply(H, content)));
  };
  const auto true_ray = [&](const Eigen::Vector2d& pixel) -> Eigen::Vector3d {
    return R_map_projector * projector.unproject(pixel);
  };

  if (robot) {
    // Content the projector's image does not hold is not lit at all: it misses the target too.
    constexpr int kLightGrid = 32;
    int off = 0;
    for (int j = 0; j < kLightGrid; ++j) {
      for (int i = 0; i < kLightGrid; ++i) {
        const Eigen::Vector2d c((i + 0.5) / kLightGrid, (j + 0.5) / kLightGrid);
        const auto px = lit_pixel(*robot, c);
        if (!px || !px->allFinite() || px->x() < -0.5 || px->y() < -0.5 ||
            px->x() > projector.width - 0.5 || px->y() > projector.height - 0.5) {
          ++off;
          continue;
        }
        RayHit hit;
        const bool hits = full.intersect(origin.cast<float>(), true_ray(*px).cast<float>(),
                                         std::numeric_limits<float>::infinity(), hit);
        off += !hits || hit.object_id != object_id;
      }
    }
    out.light_off_target_fraction = static_cast<double>(off) / (kLightGrid * kLightGrid);
  }
  if (robot && perfect) {
    constexpr int kAreaGrid = 9;
    double sum_mm = 0.0, max_mm = 0.0;
    bool finite = true;
    for (int j = 0; j < kAreaGrid; ++j) {
      for (int i = 0; i < kAreaGrid; ++i) {
        const double s = static_cast<double>(i) / (kAreaGrid - 1);
        const double t = static_cast<double>(j) / (kAreaGrid - 1);
        const Eigen::Vector2d c(s, t);
        const auto robot_px = lit_pixel(*robot, c);
        const auto perfect_px = lit_pixel(*perfect, c);
        if (!robot_px || !perfect_px) {
          finite = false;
          continue;
        }
        // Where the content point belongs on the Model Points' quadrilateral, for rays that
        // meet neither the target nor its plane.
        const Eigen::Vector3d on_quad =
            (1 - s) * (1 - t) * P[0] + s * (1 - t) * P[1] + s * t * P[2] + (1 - s) * t * P[3];
        bool on_mesh = false;
        const Eigen::Vector3d want =
            land(alone, plane, origin, true_ray(*perfect_px), on_quad, on_mesh);
        const Eigen::Vector3d got = land(alone, plane, origin, true_ray(*robot_px), want, on_mesh);
        const double e_mm = 1000.0 * (got - want).norm();
        finite = finite && std::isfinite(e_mm);
        sum_mm += e_mm;
        max_mm = std::max(max_mm, e_mm);
      }
    }
    if (finite) {
      out.error_mean_mm = sum_mm / (kAreaGrid * kAreaGrid);
      out.error_max_mm = max_mm;
    }
  }
  return out;
}

void write_projection_view(const Scene& alone, const Eigen::Isometry3d& T_map_model,
                           const TrueProjection& projection, const std::string& title,
                           const cv::Mat& beside, const std::filesystem::path& file) {
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
    mean_mm += 0.25 * projection.error_mm(i);
  }
  std::ostringstream caption;
  caption.precision(1);
  caption << std::fixed << title << ": mean corner error " << mean_mm << " mm";
  cv::putText(image, caption.str(), cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.6,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  cv::putText(image, "red: where the content lands   green: true Model Points", cv::Point(10, 465),
              cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(220, 220, 220), 1, cv::LINE_AA);
  if (!beside.empty()) {
    cv::Mat right = beside;
    if (right.rows != image.rows) {
      const int cols = static_cast<int>(
          std::lround(static_cast<double>(beside.cols) * image.rows / std::max(beside.rows, 1)));
      cv::resize(beside, right, cv::Size(std::max(cols, 1), image.rows), 0, 0, cv::INTER_AREA);
    }
    cv::hconcat(image, right, image);
  }
  write_run_image(file, image);
}

}  // namespace projtour::sim

namespace projtour::sim {

cv::Mat colour_view_panel(const ColourFrame& frame, const Eigen::Isometry3d& T_map_camera,
                          const std::array<Eigen::Vector3d, 4>& model_points_map,
                          const std::optional<std::array<Eigen::Vector2d, 4>>& observed_px,
                          const std::string& caption) {
  cv::Mat image =
      cv::Mat(frame.height, frame.width, CV_8UC3, const_cast<std::uint8_t*>(frame.bgr.data()))
          .clone();
  const auto to_point = [](const Eigen::Vector2d& px) {
    return cv::Point(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y())));
  };
  const Eigen::Isometry3d T_camera_map = T_map_camera.inverse();
  for (const Eigen::Vector3d& p : model_points_map) {
    const auto px = frame.intrinsics.project(T_camera_map * p);
    if (px && px->allFinite()) {
      cv::drawMarker(image, to_point(*px), cv::Scalar(0, 220, 0), cv::MARKER_CROSS, 16, 2,
                     cv::LINE_AA);
    }
  }
  if (observed_px) {
    for (const Eigen::Vector2d& px : *observed_px) {
      if (px.allFinite()) {
        cv::circle(image, to_point(px), 8, cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
      }
    }
  }
  // Outlined text: the camera's picture may be bright or dark behind it.
  const auto text = [&](const std::string& line, cv::Point at, double scale) {
    cv::putText(image, line, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3,
                cv::LINE_AA);
    cv::putText(image, line, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255), 1,
                cv::LINE_AA);
  };
  text(caption, cv::Point(10, 25), 0.6);
  text(observed_px ? "green: true Model Points   red: corners the robot observed"
                   : "green: true Model Points   (no observed corners)",
       cv::Point(10, frame.height - 15), 0.5);
  return image;
}

}  // namespace projtour::sim
