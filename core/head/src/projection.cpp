#include "projtour/head/projection.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace projtour::head {

namespace {

Eigen::Vector2d ideal_pixel(const PinholeModel& m, const Eigen::Vector3d& p_optical) {
  return {m.fx * p_optical.x() / p_optical.z() + m.cx, m.fy * p_optical.y() / p_optical.z() + m.cy};
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Proper intersection of segments ab and cd (touching counts: a degenerate quad either way).
bool segments_cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                    const Eigen::Vector2d& d) {
  const double d1 = cross2(b - a, c - a), d2 = cross2(b - a, d - a);
  const double d3 = cross2(d - c, a - c), d4 = cross2(d - c, b - c);
  return ((d1 > 0) != (d2 > 0) || d1 == 0 || d2 == 0) &&
         ((d3 > 0) != (d4 > 0) || d3 == 0 || d4 == 0) && !(d1 == 0 && d2 == 0);
}

}  // namespace

ProjectedQuad project_model_points(const Quad3d& model_points,
                                   const Eigen::Isometry3d& T_projector_model,
                                   const PinholeModel& projector) {
  ProjectedQuad out;
  std::string behind, off_screen;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d p = T_projector_model * model_points[i];
    const auto px = projector.project(p);
    if (!px) {
      out.in_front = out.on_screen = false;
      if (behind.empty()) {
        std::ostringstream s;
        s << "Model Point " << i + 1 << " is behind the projector (z = " << p.z() << " m)";
        behind = s.str();
      }
      continue;
    }
    out.pixels[i] = *px;
    out.ideal_pixels[i] = ideal_pixel(projector, p);
    if (!projector.in_image(*px)) {
      out.on_screen = false;
      if (off_screen.empty()) {
        std::ostringstream s;
        s.precision(1);
        s << std::fixed << "Model Point " << i + 1 << " falls at pixel (" << px->x() << ", "
          << px->y() << "), outside the " << projector.width << "x" << projector.height
          << " projector image";
        off_screen = s.str();
      }
    }
  }
  out.problem = !behind.empty() ? behind : off_screen;
  return out;
}

std::string edge_problem(const ProjectedQuad& quad, const PinholeModel& projector,
                         double edge_margin_px) {
  if (!quad.on_screen) return quad.problem;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d& p = quad.pixels[i];
    const double margin =
        std::min({p.x(), p.y(), projector.width - 1 - p.x(), projector.height - 1 - p.y()});
    if (margin < edge_margin_px) {
      std::ostringstream s;
      s.precision(1);
      s << std::fixed << "Model Point " << i + 1 << " falls " << margin
        << " px from the projector image's edge at (" << p.x() << ", " << p.y() << "), closer than "
        << edge_margin_px << " px";
      return s.str();
    }
  }
  return "";
}

double quad_area_px2(const Quad2d& q) {
  double twice = 0.0;
  for (int i = 0; i < 4; ++i) twice += cross2(q[i], q[(i + 1) % 4]);
  return 0.5 * twice;
}

std::string quad_problem(const Quad2d& q, double min_area_px2) {
  if (segments_cross(q[0], q[1], q[2], q[3]) || segments_cross(q[1], q[2], q[3], q[0])) {
    return "self-crossing";
  }
  const double area = quad_area_px2(q);
  if (std::abs(area) < min_area_px2) {
    std::ostringstream s;
    s << "zero area (" << std::abs(area) << " px^2)";
    return s.str();
  }
  // A homography of a rectangle stays convex; a dent means a corner is folded over.
  for (int i = 0; i < 4; ++i) {
    const double turn = cross2(q[(i + 1) % 4] - q[i], q[(i + 2) % 4] - q[(i + 1) % 4]);
    if (turn * area <= 0.0) return "not convex";
  }
  return "";
}

double planarity_residual_m(const Quad3d& points) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p / 4.0;
  Eigen::Matrix<double, 4, 3> A;
  for (int i = 0; i < 4; ++i) A.row(i) = (points[i] - centroid).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix<double, 4, 3>> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector3d normal = svd.matrixV().col(2);
  double worst_m = 0.0;
  for (int i = 0; i < 4; ++i) worst_m = std::max(worst_m, std::abs(A.row(i).dot(normal)));
  return worst_m;
}

Quad2d content_corners(const cv::Size& s) {
  const double w = s.width - 1.0, h = s.height - 1.0;
  return {Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0), Eigen::Vector2d(w, h),
          Eigen::Vector2d(0, h)};
}

cv::Matx33d homography(const Quad2d& from, const Quad2d& to) {
  std::array<cv::Point2f, 4> a, b;
  for (int i = 0; i < 4; ++i) {
    a[i] = cv::Point2f(static_cast<float>(from[i].x()), static_cast<float>(from[i].y()));
    b[i] = cv::Point2f(static_cast<float>(to[i].x()), static_cast<float>(to[i].y()));
  }
  // Float input costs ~1e-4 px at projector scale, far below what the 0.1 px budget allows.
  return cv::Matx33d(cv::getPerspectiveTransform(a.data(), b.data(), cv::DECOMP_LU));
}

ContentWarper::ContentWarper(const PinholeModel& projector)
    : projector_(projector), projector_size_(projector.width, projector.height) {
  if (projector.width <= 0 || projector.height <= 0) {
    throw std::invalid_argument("projector model has no image size");
  }
  ideal_x_.create(projector_size_, CV_64F);
  ideal_y_.create(projector_size_, CV_64F);
  if (!projector.has_distortion()) {
    for (int v = 0; v < projector.height; ++v) {
      for (int u = 0; u < projector.width; ++u) {
        ideal_x_.at<double>(v, u) = u;
        ideal_y_.at<double>(v, u) = v;
      }
    }
    return;
  }
  // Exact undistortion (PinholeModel::unproject) on a grid every kStep pixels, bilinear in
  // between: the distortion field is smooth, so this costs ~1e-3 px and 1/64 of the solves.
  constexpr int kStep = 8;
  const int nodes_x = (projector.width - 1 + kStep - 1) / kStep + 1;
  const int nodes_y = (projector.height - 1 + kStep - 1) / kStep + 1;
  cv::Mat node_x(nodes_y, nodes_x, CV_64F), node_y(nodes_y, nodes_x, CV_64F);
  for (int j = 0; j < nodes_y; ++j) {
    for (int i = 0; i < nodes_x; ++i) {
      const Eigen::Vector3d ray = projector.unproject(Eigen::Vector2d(i * kStep, j * kStep));
      node_x.at<double>(j, i) = projector.fx * ray.x() + projector.cx;
      node_y.at<double>(j, i) = projector.fy * ray.y() + projector.cy;
    }
  }
  cv::parallel_for_(cv::Range(0, projector.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const int j = std::min(v / kStep, nodes_y - 2);
      const double fv = (v - j * kStep) / static_cast<double>(kStep);
      for (int u = 0; u < projector.width; ++u) {
        const int i = std::min(u / kStep, nodes_x - 2);
        const double fu = (u - i * kStep) / static_cast<double>(kStep);
        auto lerp = [&](const cv::Mat& n) {
          return (1 - fv) * ((1 - fu) * n.at<double>(j, i) + fu * n.at<double>(j, i + 1)) +
                 fv * ((1 - fu) * n.at<double>(j + 1, i) + fu * n.at<double>(j + 1, i + 1));
        };
        ideal_x_.at<double>(v, u) = lerp(node_x);
        ideal_y_.at<double>(v, u) = lerp(node_y);
      }
    }
  });
}

// The projector pixels the content can reach: the content rectangle grown by the pixel that
// INTER_LINEAR blends with the black border, carried onto the ideal image and through the lens,
// sampled along its edges (the distortion bends them), with two pixels to spare for the
// undistortion map's interpolation. Every pixel outside samples only the border: black. The
// whole frame when part of the rectangle lies beyond the plane's horizon.
cv::Rect ContentWarper::content_reach() const {
  const cv::Rect frame(cv::Point(0, 0), projector_size_);
  const double w = content_size_.width, h = content_size_.height;
  const std::array<Eigen::Vector2d, 4> grown = {Eigen::Vector2d(-1, -1), Eigen::Vector2d(w, -1),
                                                Eigen::Vector2d(w, h), Eigen::Vector2d(-1, h)};
  constexpr int kSamplesPerEdge = 32;
  double u_min = std::numeric_limits<double>::infinity(), v_min = u_min;
  double u_max = -u_min, v_max = -u_min;
  for (int e = 0; e < 4; ++e) {
    for (int k = 0; k < kSamplesPerEdge; ++k) {
      const Eigen::Vector2d c =
          grown[e] + (grown[(e + 1) % 4] - grown[e]) * (k / double(kSamplesPerEdge));
      const cv::Vec3d x = H_ideal_content_ * cv::Vec3d(c.x(), c.y(), 1.0);
      if (x[2] <= 0.0) return frame;
      const Eigen::Vector3d ray((x[0] / x[2] - projector_.cx) / projector_.fx,
                                (x[1] / x[2] - projector_.cy) / projector_.fy, 1.0);
      const std::optional<Eigen::Vector2d> px = projector_.project(ray);
      if (!px || !px->allFinite()) return frame;
      u_min = std::min(u_min, px->x());
      u_max = std::max(u_max, px->x());
      v_min = std::min(v_min, px->y());
      v_max = std::max(v_max, px->y());
    }
  }
  constexpr double kSparePx = 2.0;
  const auto clamp_to = [](double v, int hi) {
    return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(hi)));
  };
  const int u0 = clamp_to(std::floor(u_min - kSparePx), projector_size_.width);
  const int v0 = clamp_to(std::floor(v_min - kSparePx), projector_size_.height);
  const int u1 = clamp_to(std::ceil(u_max + kSparePx) + 1, projector_size_.width);
  const int v1 = clamp_to(std::ceil(v_max + kSparePx) + 1, projector_size_.height);
  return cv::Rect(u0, v0, std::max(0, u1 - u0), std::max(0, v1 - v0));
}

void ContentWarper::set_target(const cv::Size& content_size, const ProjectedQuad& quad) {
  if (content_size.width < 2 || content_size.height < 2) {
    throw std::invalid_argument("content image smaller than 2x2");
  }
  content_size_ = content_size;
  H_ideal_content_ = homography(content_corners(content_size), quad.ideal_pixels);
  H_content_ideal_ = H_ideal_content_.inv();
  reach_ = content_reach();
  // The maps cover the reach only: a small target's are a fraction of the frame's 1M pixels.
  map_x_.create(std::max(1, reach_.height), std::max(1, reach_.width), CV_32F);
  map_y_.create(map_x_.size(), CV_32F);
  cv::parallel_for_(cv::Range(0, reach_.height), [&](const cv::Range& rows) {
    for (int r = rows.start; r < rows.end; ++r) {
      const double* ix = ideal_x_.ptr<double>(reach_.y + r) + reach_.x;
      const double* iy = ideal_y_.ptr<double>(reach_.y + r) + reach_.x;
      float* mx = map_x_.ptr<float>(r);
      float* my = map_y_.ptr<float>(r);
      for (int c = 0; c < reach_.width; ++c) {
        const cv::Vec3d x = H_content_ideal_ * cv::Vec3d(ix[c], iy[c], 1.0);
        if (x[2] <= 0.0) {  // the far side of the plane's horizon: never content
          mx[c] = my[c] = -1e6f;
          continue;
        }
        mx[c] = static_cast<float>(x[0] / x[2]);
        my[c] = static_cast<float>(x[1] / x[2]);
      }
    }
  });
}

cv::Mat ContentWarper::warp(const cv::Mat& content) const {
  cv::Mat out;
  warp(content, out);
  return out;
}

void ContentWarper::warp(const cv::Mat& content, cv::Mat& frame) const {
  if (!has_target()) throw std::logic_error("ContentWarper::warp before set_target");
  if (content.size() != content_size_) {
    throw std::invalid_argument("content frame size differs from the size the warp was set for");
  }
  // A frame another cv::Mat still shares (a copy kept for a file, say) is left to its holder.
  if (frame.u != nullptr && frame.u->refcount > 1) frame.release();
  frame.create(projector_size_, content.type());
  frame.setTo(cv::Scalar::all(0));
  if (reach_.area() == 0) return;
  // Into the reach's view of the frame: remap writes in place when the size and type match.
  cv::Mat reach = frame(reach_);
  cv::remap(content, reach, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar());
}

Eigen::Vector2d ContentWarper::content_at(const Eigen::Vector2d& pixel) const {
  if (!has_target()) throw std::logic_error("ContentWarper::content_at before set_target");
  const int u0 = std::clamp(static_cast<int>(std::floor(pixel.x())), 0, projector_size_.width - 2);
  const int v0 = std::clamp(static_cast<int>(std::floor(pixel.y())), 0, projector_size_.height - 2);
  const double fu = pixel.x() - u0, fv = pixel.y() - v0;
  // Bilinear over the content map at the four pixels, each as the warp computes it.
  const auto content = [&](int u, int v) {
    const cv::Vec3d x =
        H_content_ideal_ * cv::Vec3d(ideal_x_.at<double>(v, u), ideal_y_.at<double>(v, u), 1.0);
    return Eigen::Vector2d(static_cast<float>(x[0] / x[2]), static_cast<float>(x[1] / x[2]));
  };
  return (1 - fv) * ((1 - fu) * content(u0, v0) + fu * content(u0 + 1, v0)) +
         fv * ((1 - fu) * content(u0, v0 + 1) + fu * content(u0 + 1, v0 + 1));
}

}  // namespace projtour::head
