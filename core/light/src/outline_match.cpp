// The outline check: the model's rendered outline against the colour image's edges.
#include "projtour/outline_match.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace projtour::light {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kBins = 4;  // edge orientations, mod 180 degrees: 0, 45, 90, 135
// Canny's hysteresis on the 3x3 Sobel of the blurred grey image (L2), set from the image: its
// median gradient is the camera's noise (most of a view is flat), and an edge starts well above
// it. The floor keeps a noiseless image's faint shading out.
constexpr double kCannyHighOverMedian = 6.0;
constexpr double kCannyHighFloor = 8.0;
constexpr double kCannyLowOverHigh = 0.4;
// More outline pixels than this are thinned to it: the cost is a mean, and the search's time
// grows with the count.
constexpr int kMaxOutlinePixels = 1500;
// How far along its normal an outline pixel looks for its edge, in half pixels, once the grid
// search has put the outline within a pixel or two of it.
constexpr int kNormalReachHalfPx = 6;
// An image direction is fixed by the outline when at least this share of its pixels' normals
// (squared cosine) points along it.
constexpr double kMinFixedShare = 0.1;

struct OutlinePixel {
  int u, v, bin;
  Eigen::Vector2d normal;  // the outline's, in the image (unit)
};

int bin_of(double angle_rad) {
  double a = std::fmod(angle_rad, kPi);
  if (a < 0) a += kPi;
  return static_cast<int>(std::lround(a / (kPi / kBins))) % kBins;
}

}  // namespace

std::optional<OutlineMatch> match_outline(const ColourFrame& frame,
                                          const std::vector<float>& model_depth,
                                          const OutlineSettings& s) {
  const int w = frame.width, h = frame.height;
  if (w <= 2 || h <= 2 || frame.bgr.size() != static_cast<std::size_t>(w) * h * 3 ||
      model_depth.size() != static_cast<std::size_t>(w) * h) {
    throw std::invalid_argument("match_outline: the frame and the model's depth image differ");
  }
  if (s.search_px < 1 || !(s.truncate_px > 0) || !(s.match_px > 0) || !(s.depth_step_m > 0)) {
    throw std::invalid_argument("match_outline: settings out of range");
  }
  // The model's depth with "far" where there is no model, so the silhouette is a depth step like
  // any other and its normal is the depth's gradient.
  float far = 0.0f;
  for (float z : model_depth) far = std::max(far, z);
  if (far == 0.0f) return std::nullopt;
  far += 10.0f;
  cv::Mat depth(h, w, CV_32F);
  for (int v = 0; v < h; ++v) {
    float* row = depth.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      const float z = model_depth[static_cast<std::size_t>(v) * w + u];
      row[u] = z > 0.0f ? z : far;
    }
  }
  cv::Mat gx, gy;
  cv::Sobel(depth, gx, CV_32F, 1, 0, 3);
  cv::Sobel(depth, gy, CV_32F, 0, 1, 3);
  std::vector<OutlinePixel> outline;
  int lo_u = w, lo_v = h, hi_u = -1, hi_v = -1;
  const float step = static_cast<float>(s.depth_step_m);
  for (int v = 1; v < h - 1; ++v) {
    for (int u = 1; u < w - 1; ++u) {
      const float z = depth.at<float>(v, u);
      if (z >= far) continue;
      // The near side of a step: the model's own pixel, where the camera sees its edge.
      const bool edge =
          depth.at<float>(v, u - 1) - z > step || depth.at<float>(v, u + 1) - z > step ||
          depth.at<float>(v - 1, u) - z > step || depth.at<float>(v + 1, u) - z > step;
      if (!edge) continue;
      const double a = std::atan2(gy.at<float>(v, u), gx.at<float>(v, u));
      outline.push_back({u, v, bin_of(a), Eigen::Vector2d(std::cos(a), std::sin(a))});
      lo_u = std::min(lo_u, u);
      lo_v = std::min(lo_v, v);
      hi_u = std::max(hi_u, u);
      hi_v = std::max(hi_v, v);
    }
  }
  if (static_cast<int>(outline.size()) < s.min_outline_pixels) return std::nullopt;
  if (static_cast<int>(outline.size()) > kMaxOutlinePixels) {
    std::vector<OutlinePixel> thinned;
    const double stride = static_cast<double>(outline.size()) / kMaxOutlinePixels;
    for (int i = 0; i < kMaxOutlinePixels; ++i) {
      thinned.push_back(outline[static_cast<std::size_t>(i * stride)]);
    }
    outline = std::move(thinned);
  }

  // The image's edges around the outline, as far as the search reaches, split by orientation;
  // an edge counts for the two orientation bins either side of its angle.
  const int reach = s.search_px + static_cast<int>(std::ceil(s.truncate_px)) + 2;
  const cv::Rect roi = cv::Rect(lo_u - reach, lo_v - reach, hi_u - lo_u + 1 + 2 * reach,
                                hi_v - lo_v + 1 + 2 * reach) &
                       cv::Rect(0, 0, w, h);
  const cv::Mat bgr(h, w, CV_8UC3, const_cast<std::uint8_t*>(frame.bgr.data()));
  cv::Mat grey;
  cv::cvtColor(bgr(roi), grey, cv::COLOR_BGR2GRAY);
  cv::GaussianBlur(grey, grey, cv::Size(5, 5), 1.0);
  cv::Mat dx, dy, edges;
  cv::Sobel(grey, dx, CV_16S, 1, 0, 3);
  cv::Sobel(grey, dy, CV_16S, 0, 1, 3);
  cv::Mat magnitude;
  cv::magnitude(cv::Mat_<float>(dx), cv::Mat_<float>(dy), magnitude);
  std::vector<float> levels(magnitude.begin<float>(), magnitude.end<float>());
  std::nth_element(levels.begin(), levels.begin() + levels.size() / 2, levels.end());
  const double high = std::max(kCannyHighFloor, kCannyHighOverMedian * levels[levels.size() / 2]);
  cv::Canny(dx, dy, edges, kCannyLowOverHigh * high, high, true);
  std::array<cv::Mat, kBins> not_edge;
  for (auto& m : not_edge) m = cv::Mat(roi.size(), CV_8U, cv::Scalar(255));
  for (int v = 0; v < roi.height; ++v) {
    for (int u = 0; u < roi.width; ++u) {
      if (!edges.at<std::uint8_t>(v, u)) continue;
      double a = std::atan2(dy.at<std::int16_t>(v, u), dx.at<std::int16_t>(v, u));
      a = std::fmod(a, kPi);
      if (a < 0) a += kPi;
      const int below = static_cast<int>(std::floor(a / (kPi / kBins))) % kBins;
      not_edge[below].at<std::uint8_t>(v, u) = 0;
      not_edge[(below + 1) % kBins].at<std::uint8_t>(v, u) = 0;
    }
  }
  std::array<cv::Mat, kBins> distance;
  for (int b = 0; b < kBins; ++b) {
    cv::distanceTransform(not_edge[b], distance[b], cv::DIST_L2, cv::DIST_MASK_PRECISE);
  }

  const float truncate = static_cast<float>(s.truncate_px);
  const auto cost = [&](int du, int dv) {
    double sum = 0.0;
    for (const OutlinePixel& p : outline) {
      const int u = p.u + du - roi.x, v = p.v + dv - roi.y;
      if (u < 0 || v < 0 || u >= roi.width || v >= roi.height) {
        sum += truncate;
        continue;
      }
      sum += std::min(distance[p.bin].at<float>(v, u), truncate);
    }
    return sum / outline.size();
  };
  // Coarse (every second shift), then every shift around the best, then a parabola per axis.
  double best = std::numeric_limits<double>::infinity();
  int best_u = 0, best_v = 0;
  for (int dv = -s.search_px; dv <= s.search_px; dv += 2) {
    for (int du = -s.search_px; du <= s.search_px; du += 2) {
      const double c = cost(du, dv);
      // Ties go to the smaller shift: a featureless stretch must not drag the answer outward.
      if (c < best - 1e-9 ||
          (std::abs(c - best) <= 1e-9 && du * du + dv * dv < best_u * best_u + best_v * best_v)) {
        best = c;
        best_u = du;
        best_v = dv;
      }
    }
  }
  const int coarse_u = best_u, coarse_v = best_v;
  for (int dv = coarse_v - 1; dv <= coarse_v + 1; ++dv) {
    for (int du = coarse_u - 1; du <= coarse_u + 1; ++du) {
      const double c = cost(du, dv);
      if (c < best - 1e-9) {
        best = c;
        best_u = du;
        best_v = dv;
      }
    }
  }
  // Sub-pixel, and only where the outline says anything: each outline pixel measures the shift
  // along its own normal (the nearest edge of its orientation on that line); the normal equations
  // show which image directions the outline fixes. A pillar's two upright sides say nothing of
  // up and down, and the answer keeps nothing there.
  // How far along its normal from `p` moved by `shift` the nearest edge of its orientation lies.
  const auto edge_along = [&](const OutlinePixel& p,
                              const Eigen::Vector2d& shift) -> std::optional<double> {
    const Eigen::Vector2d at = Eigen::Vector2d(p.u - roi.x, p.v - roi.y) + shift;
    for (int k = 0; k <= 2 * kNormalReachHalfPx; ++k) {
      // 0, +0.5, -0.5, +1, -1, ...: the nearest edge wins.
      const double t = (k % 2 == 1 ? 1.0 : -1.0) * 0.5 * ((k + 1) / 2);
      const Eigen::Vector2d q = at + t * p.normal;
      const int u = static_cast<int>(std::lround(q.x())), v = static_cast<int>(std::lround(q.y()));
      if (u < 0 || v < 0 || u >= roi.width || v >= roi.height) continue;
      if (not_edge[p.bin].at<std::uint8_t>(v, u) == 0) return t;
    }
    return std::nullopt;
  };
  Eigen::Vector2d shift(best_u, best_v);
  Eigen::Matrix2d projector_onto_fixed = Eigen::Matrix2d::Zero();
  for (int iteration = 0; iteration < 3; ++iteration) {
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    int used = 0;
    for (const OutlinePixel& p : outline) {
      const std::optional<double> along = edge_along(p, shift);
      if (!along) continue;
      A += p.normal * p.normal.transpose();
      b += *along * p.normal;
      ++used;
    }
    if (used < s.min_outline_pixels) break;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(A);
    Eigen::Vector2d step = Eigen::Vector2d::Zero();
    projector_onto_fixed.setZero();
    for (int k = 0; k < 2; ++k) {
      if (eig.eigenvalues()(k) < kMinFixedShare * used) continue;
      const Eigen::Vector2d e = eig.eigenvectors().col(k);
      step += e * (e.dot(b) / eig.eigenvalues()(k));
      projector_onto_fixed += e * e.transpose();
    }
    shift += step;
    if (step.norm() < 0.05) break;
  }
  OutlineMatch out;
  // The turn: each outline pixel's distance to its edge at the shift, against a rotation about
  // the outline's centroid together with a residual shift (so an outline matched unevenly
  // around the centroid does not pass its shift off as a turn).
  if (std::lround(projector_onto_fixed.trace()) == 2) {
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const OutlinePixel& p : outline) centre += Eigen::Vector2d(p.u, p.v);
    centre /= static_cast<double>(outline.size());
    // One step, first order in the turn: looked at again from its answer, the turn wanders by
    // a tenth of a degree with the edges' pixel steps and is no nearer the truth.
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    double extent = 0.0;
    int used = 0;
    for (const OutlinePixel& p : outline) {
      const std::optional<double> along = edge_along(p, shift);
      if (!along) continue;
      const Eigen::Vector2d r = Eigen::Vector2d(p.u, p.v) - centre;
      const Eigen::Vector3d j(p.normal.x(), p.normal.y(),
                              p.normal.dot(Eigen::Vector2d(-r.y(), r.x())));
      A += j * j.transpose();
      b += *along * j;
      extent += r.squaredNorm();
      ++used;
    }
    // The turn's information against what the outline's size would give if every normal were
    // tangent to the circle about the centre: a thin or ragged outline says little of it.
    if (used >= s.min_outline_pixels && A(2, 2) >= kMinFixedShare * extent) {
      const Eigen::Vector3d x = A.ldlt().solve(b);
      if (x.allFinite()) {
        out.rotation_rad = x.z();
        out.centre_px = centre;
      }
    }
  }
  out.shift_px = projector_onto_fixed * shift;
  out.fixed_directions = static_cast<int>(std::lround(projector_onto_fixed.trace()));
  out.cost_px = best;
  out.cost_at_zero_px = cost(0, 0);
  out.outline_pixels = static_cast<int>(outline.size());
  int matched = 0;
  for (const OutlinePixel& p : outline) {
    const int u = p.u + best_u - roi.x, v = p.v + best_v - roi.y;
    if (u < 0 || v < 0 || u >= roi.width || v >= roi.height) continue;
    matched += distance[p.bin].at<float>(v, u) <= s.match_px;
  }
  out.matched_fraction = static_cast<double>(matched) / outline.size();
  return out;
}

Eigen::Vector2d outline_moves(const OutlineMatch& match, const Eigen::Vector2d& px) {
  const Eigen::Vector2d r = px - match.centre_px;
  return match.shift_px + match.rotation_rad * Eigen::Vector2d(-r.y(), r.x());
}

Eigen::Vector3d slide_for_shift(const PinholeModel& colour, const Eigen::Vector3d& point,
                                const Eigen::Vector3d& normal, const Eigen::Vector2d& shift_px) {
  const double x = point.x(), y = point.y(), z = point.z();
  if (!(z > 0.0)) return Eigen::Vector3d::Zero();
  Eigen::Matrix3d A;
  A.row(0) << colour.fx / z, 0.0, -colour.fx * x / (z * z);
  A.row(1) << 0.0, colour.fy / z, -colour.fy * y / (z * z);
  A.row(2) = normal.normalized().transpose();
  const Eigen::Vector3d b(shift_px.x(), shift_px.y(), 0.0);
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
  // A face seen edge-on cannot slide along itself across the image: move across the view then.
  if (!lu.isInvertible() || std::abs(normal.normalized().dot(point.normalized())) < 0.05) {
    A.row(2) << 0.0, 0.0, 1.0;
    return A.fullPivLu().solve(b);
  }
  return lu.solve(b);
}

}  // namespace projtour::light
