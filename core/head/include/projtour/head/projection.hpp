#pragma once
// Content onto the Model Points: Model Points -> projector pixels, the quad checks, and the warp
// of a content image into a projector frame (homography on the ideal pinhole image, then the
// projector's lens distortion by inverse mapping).
#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "projtour/contract/pinhole.hpp"

namespace projtour::head {

using Quad2d = std::array<Eigen::Vector2d, 4>;
using Quad3d = std::array<Eigen::Vector3d, 4>;

struct ProjectedQuad {
  Quad2d pixels{};        // distorted projector pixels (what to light up)
  Quad2d ideal_pixels{};  // the same on the ideal pinhole image (distortion removed)
  bool in_front = true;   // every point in front of the projector
  bool on_screen = true;  // ... and inside the projector image
  std::string problem;    // first reason it is not usable ("Model Point 3 behind ..."), or ""
};

// Model Points (model frame) -> projector pixels through T_projector_model.
ProjectedQuad project_model_points(const Quad3d& model_points,
                                   const Eigen::Isometry3d& T_projector_model,
                                   const PinholeModel& projector);

// Why the quad does not fit the projector image with edge_margin_px to spare on every side (the
// quad's own problem when it is off screen or behind), or "" when it does.
std::string edge_problem(const ProjectedQuad& quad, const PinholeModel& projector,
                         double edge_margin_px);

// Why a quad cannot carry a homography of a rectangle: "zero area" (below min_area_px2),
// "self-crossing" or "not convex"; empty when it can. Corners in the content order
// (top-left, top-right, bottom-right, bottom-left).
std::string quad_problem(const Quad2d& quad, double min_area_px2 = 1.0);
double quad_area_px2(const Quad2d& quad);  // signed (shoelace)

// Largest distance of the four points from their least-squares plane (m).
double planarity_residual_m(const Quad3d& points);

// The content image's corner pixel centres in the content order: (0,0), (w-1,0), (w-1,h-1),
// (0,h-1). These are what land on the Model Points.
Quad2d content_corners(const cv::Size& content_size);

// Homography taking `from` to `to` exactly (four point pairs).
cv::Matx33d homography(const Quad2d& from, const Quad2d& to);

// Warps content into a projector frame: for each projector pixel, remove the lens distortion
// (ideal pinhole pixel), then apply the inverse homography to find the content pixel. The
// undistortion map is computed once per projector model; the content map once per pose.
class ContentWarper {
 public:
  explicit ContentWarper(const PinholeModel& projector);

  // Sets the pose: content of `content_size` with its corners going to `quad.ideal_pixels`.
  void set_target(const cv::Size& content_size, const ProjectedQuad& quad);
  bool has_target() const { return !map_x_.empty(); }

  // Any cv::remap-able image of content_size; outside the content the frame is black (zero).
  cv::Mat warp(const cv::Mat& content) const;
  // The same into `frame`, whose buffer is reused when it has the projector's size and the
  // content's type and nothing else holds it: a fresh 1280x800 frame costs its first touch, which
  // was 9-11 ms on a virtual machine, against 0.1 ms for the warp itself.
  void warp(const cv::Mat& content, cv::Mat& frame) const;
  // Where projector pixel `pixel` samples the content (bilinear over the maps the warp uses).
  Eigen::Vector2d content_at(const Eigen::Vector2d& pixel) const;

  const cv::Matx33d& H_ideal_content() const { return H_ideal_content_; }
  const cv::Size& projector_size() const { return projector_size_; }
  // The projector pixels the content can light (its maps' extent); black everywhere else.
  const cv::Rect& reach() const { return reach_; }

 private:
  PinholeModel projector_;
  cv::Size projector_size_;
  cv::Size content_size_;
  cv::Mat ideal_x_, ideal_y_;  // CV_64F ideal pinhole coordinates of each projector pixel
  cv::Rect reach_;             // the projector pixels the maps cover
  cv::Mat map_x_, map_y_;      // CV_32F content coordinates of each projector pixel of reach_
  cv::Matx33d H_ideal_content_ = cv::Matx33d::eye();
  cv::Matx33d H_content_ideal_ = cv::Matx33d::eye();

  cv::Rect content_reach() const;
};

}  // namespace projtour::head
