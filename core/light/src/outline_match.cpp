// The outline check: the model's rendered outline against the colour image's edges.
#include "projtour/light/outline_match.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <vector>

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

// The model's outline: the near side of every depth step, with its normal and orientation bin,
// thinned to kMaxOutlinePixels, and its bounding box.
struct ModelOutline {
  std::vector<OutlinePixel> pixels;
  int lo_u, lo_v, hi_u, hi_v;
};

// nullopt when the model is not in view or its outline is shorter than min_outline_pixels.
std::optional<ModelOutline> model_outline(const std::vector<float>& model_depth, int w, int h,
                                          const OutlineSettings& s) {
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
  ModelOutline outline{{}, w, h, -1, -1};
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
      outline.pixels.push_back({u, v, bin_of(a), Eigen::Vector2d(std::cos(a), std::sin(a))});
      outline.lo_u = std::min(outline.lo_u, u);
      outline.lo_v = std::min(outline.lo_v, v);
      outline.hi_u = std::max(outline.hi_u, u);
      outline.hi_v = std::max(outline.hi_v, v);
    }
  }
  if (static_cast<int>(outline.pixels.size()) < s.min_outline_pixels) return std::nullopt;
  if (static_cast<int>(outline.pixels.size()) > kMaxOutlinePixels) {
    std::vector<OutlinePixel> thinned;
    const double stride = static_cast<double>(outline.pixels.size()) / kMaxOutlinePixels;
    for (int i = 0; i < kMaxOutlinePixels; ++i) {
      thinned.push_back(outline.pixels[static_cast<std::size_t>(i * stride)]);
    }
    outline.pixels = std::move(thinned);
  }
  return outline;
}

// The image's edges around the outline, as far as the search reaches, split by orientation: per
// bin, zero on its edges, and each pixel's distance to the nearest of them. An edge counts for
// the two orientation bins either side of its angle.
struct ImageEdges {
  cv::Rect roi;  // in the image; the maps' pixels are the roi's
  std::array<cv::Mat, kBins> not_edge, distance;
};

ImageEdges image_edges(const ColourFrame& frame, const ModelOutline& outline,
                       const OutlineSettings& s) {
  const int w = frame.width, h = frame.height;
  const int reach = s.search_px + static_cast<int>(std::ceil(s.truncate_px)) + 2;
  ImageEdges out;
  const cv::Rect roi = out.roi = cv::Rect(outline.lo_u - reach, outline.lo_v - reach,
                                          outline.hi_u - outline.lo_u + 1 + 2 * reach,
                                          outline.hi_v - outline.lo_v + 1 + 2 * reach) &
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
  for (auto& m : out.not_edge) m = cv::Mat(roi.size(), CV_8U, cv::Scalar(255));
  for (int v = 0; v < roi.height; ++v) {
    for (int u = 0; u < roi.width; ++u) {
      if (!edges.at<std::uint8_t>(v, u)) continue;
      double a = std::atan2(dy.at<std::int16_t>(v, u), dx.at<std::int16_t>(v, u));
      a = std::fmod(a, kPi);
      if (a < 0) a += kPi;
      const int below = static_cast<int>(std::floor(a / (kPi / kBins))) % kBins;
      out.not_edge[below].at<std::uint8_t>(v, u) = 0;
      out.not_edge[(below + 1) % kBins].at<std::uint8_t>(v, u) = 0;
    }
  }
  for (int b = 0; b < kBins; ++b) {
    cv::distanceTransform(out.not_edge[b], out.distance[b], cv::DIST_L2, cv::DIST_MASK_PRECISE);
  }
  return out;
}

// The outline shifted by (du, dv): its pixels' mean distance to an edge of their orientation,
// each truncated at `truncate`.
double shift_cost(const std::vector<OutlinePixel>& outline, const ImageEdges& edges, float truncate,
                  int du, int dv) {
  const cv::Rect& roi = edges.roi;
  double sum = 0.0;
  for (const OutlinePixel& p : outline) {
    const int u = p.u + du - roi.x, v = p.v + dv - roi.y;
    if (u < 0 || v < 0 || u >= roi.width || v >= roi.height) {
      sum += truncate;
      continue;
    }
    sum += std::min(edges.distance[p.bin].at<float>(v, u), truncate);
  }
  return sum / outline.size();
}

// The whole-pixel shift of least cost: coarse (every second shift), then every shift around the
// best.
struct GridBest {
  double cost = std::numeric_limits<double>::infinity();
  int u = 0, v = 0;
};

GridBest grid_search(const std::vector<OutlinePixel>& outline, const ImageEdges& edges,
                     const OutlineSettings& s) {
  const float truncate = static_cast<float>(s.truncate_px);
  GridBest best;
  for (int dv = -s.search_px; dv <= s.search_px; dv += 2) {
    for (int du = -s.search_px; du <= s.search_px; du += 2) {
      const double c = shift_cost(outline, edges, truncate, du, dv);
      // Ties go to the smaller shift: a featureless stretch must not drag the answer outward.
      if (c < best.cost - 1e-9 || (std::abs(c - best.cost) <= 1e-9 &&
                                   du * du + dv * dv < best.u * best.u + best.v * best.v)) {
        best.cost = c;
        best.u = du;
        best.v = dv;
      }
    }
  }
  const int coarse_u = best.u, coarse_v = best.v;
  for (int dv = coarse_v - 1; dv <= coarse_v + 1; ++dv) {
    for (int du = coarse_u - 1; du <= coarse_u + 1; ++du) {
      const double c = shift_cost(outline, edges, truncate, du, dv);
      if (c < best.cost - 1e-9) {
        best.cost = c;
        best.u = du;
        best.v = dv;
      }
    }
  }
  return best;
}

// How far along its normal from `p` moved by `shift` the nearest edge of its orientation lies.
std::optional<double> edge_along(const OutlinePixel& p, const Eigen::Vector2d& shift,
                                 const ImageEdges& edges) {
  const cv::Rect& roi = edges.roi;
  const Eigen::Vector2d at = Eigen::Vector2d(p.u - roi.x, p.v - roi.y) + shift;
  for (int k = 0; k <= 2 * kNormalReachHalfPx; ++k) {
    // 0, +0.5, -0.5, +1, -1, ...: the nearest edge wins.
    const double t = (k % 2 == 1 ? 1.0 : -1.0) * 0.5 * ((k + 1) / 2);
    const Eigen::Vector2d q = at + t * p.normal;
    const int u = static_cast<int>(std::lround(q.x())), v = static_cast<int>(std::lround(q.y()));
    if (u < 0 || v < 0 || u >= roi.width || v >= roi.height) continue;
    if (edges.not_edge[p.bin].at<std::uint8_t>(v, u) == 0) return t;
  }
  return std::nullopt;
}

// Sub-pixel, and only where the outline says anything: each outline pixel measures the shift
// along its own normal (the nearest edge of its orientation on that line); the normal equations
// show which image directions the outline fixes. A pillar's two upright sides say nothing of
// up and down, and the answer keeps nothing there.
struct SubPixelShift {
  Eigen::Vector2d shift;
  Eigen::Matrix2d projector_onto_fixed = Eigen::Matrix2d::Zero();  // onto the fixed directions
};

SubPixelShift sub_pixel_shift(const std::vector<OutlinePixel>& outline, const ImageEdges& edges,
                              const GridBest& grid, const OutlineSettings& s) {
  SubPixelShift out{Eigen::Vector2d(grid.u, grid.v)};
  Eigen::Vector2d& shift = out.shift;
  Eigen::Matrix2d& projector_onto_fixed = out.projector_onto_fixed;
  for (int iteration = 0; iteration < 3; ++iteration) {
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    int used = 0;
    for (const OutlinePixel& p : outline) {
      const std::optional<double> along = edge_along(p, shift, edges);
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
  return out;
}

// The turn: each outline pixel's distance to its edge at the shift, against a rotation about
// the outline's centroid together with a residual shift (so an outline matched unevenly
// around the centroid does not pass its shift off as a turn). Sets out's rotation and centre
// when the outline says enough of it.
void outline_turn(const std::vector<OutlinePixel>& outline, const ImageEdges& edges,
                  const Eigen::Vector2d& shift, const OutlineSettings& s, OutlineMatch& out) {
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
    const std::optional<double> along = edge_along(p, shift, edges);
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

// The share of the outline's pixels within match_px of an edge of their orientation at the
// whole-pixel shift.
double matched_fraction(const std::vector<OutlinePixel>& outline, const ImageEdges& edges,
                        const GridBest& grid, const OutlineSettings& s) {
  const cv::Rect& roi = edges.roi;
  int matched = 0;
  for (const OutlinePixel& p : outline) {
    const int u = p.u + grid.u - roi.x, v = p.v + grid.v - roi.y;
    if (u < 0 || v < 0 || u >= roi.width || v >= roi.height) continue;
    matched += edges.distance[p.bin].at<float>(v, u) <= s.match_px;
  }
  return static_cast<double>(matched) / outline.size();
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
  const std::optional<ModelOutline> model = model_outline(model_depth, w, h, s);
  if (!model) return std::nullopt;
  const std::vector<OutlinePixel>& outline = model->pixels;
  const ImageEdges edges = image_edges(frame, *model, s);
  // The whole-pixel search, then the sub-pixel shift and the turn from the edges along the
  // outline's normals.
  const GridBest grid = grid_search(outline, edges, s);
  const SubPixelShift fine = sub_pixel_shift(outline, edges, grid, s);
  OutlineMatch out;
  if (std::lround(fine.projector_onto_fixed.trace()) == 2) {
    outline_turn(outline, edges, fine.shift, s, out);
  }
  out.shift_px = fine.projector_onto_fixed * fine.shift;
  out.fixed_directions = static_cast<int>(std::lround(fine.projector_onto_fixed.trace()));
  out.cost_px = grid.cost;
  out.cost_at_zero_px = shift_cost(outline, edges, static_cast<float>(s.truncate_px), 0, 0);
  out.outline_pixels = static_cast<int>(outline.size());
  out.matched_fraction = matched_fraction(outline, edges, grid, s);
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
