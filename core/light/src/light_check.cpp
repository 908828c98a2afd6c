// The verify step's measurements: the four dots, the model's depth in the colour image, and
// where the added light lands.
#include "projtour/light/light_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace projtour::light {

namespace {

// Grey levels of a frame's region by cv::cvtColor, as decode() takes them, so a threshold in
// grey levels means the same in both (OpenCV's vectorised rounding differs from the textbook
// fixed-point formula on a few pixels).
cv::Mat grey_of(const ColourFrame& f, const cv::Rect& region) {
  const cv::Mat bgr(f.height, f.width, CV_8UC3, const_cast<std::uint8_t*>(f.bgr.data()));
  cv::Mat grey;
  cv::cvtColor(bgr(region), grey, cv::COLOR_BGR2GRAY);
  return grey;
}

void check_pair(const ColourFrame& dark, const ColourFrame& lit, const char* who) {
  const std::size_t n = static_cast<std::size_t>(dark.width) * dark.height * 3;
  if (dark.width <= 0 || dark.height <= 0 || dark.width != lit.width || dark.height != lit.height ||
      dark.bgr.size() != n || lit.bgr.size() != n) {
    throw std::invalid_argument(std::string(who) + ": dark and lit frames differ or are empty");
  }
}

// Added light in a window: weights are the light above the threshold, so the noise floor at the
// dot's rim neither pulls the centroid nor counts as the dot.
struct Centroid {
  Eigen::Vector2d px = Eigen::Vector2d::Zero();
  double weight = 0.0;
  int pixels = 0;
};

Centroid added_centroid(const ColourFrame& dark, const ColourFrame& lit, const Eigen::Vector2d& at,
                        double radius, int min_added_level) {
  Centroid c;
  const int u0 = std::max(0, static_cast<int>(std::floor(at.x() - radius)));
  const int u1 = std::min(dark.width - 1, static_cast<int>(std::ceil(at.x() + radius)));
  const int v0 = std::max(0, static_cast<int>(std::floor(at.y() - radius)));
  const int v1 = std::min(dark.height - 1, static_cast<int>(std::ceil(at.y() + radius)));
  if (u0 > u1 || v0 > v1) return c;
  const cv::Rect window(u0, v0, u1 - u0 + 1, v1 - v0 + 1);
  const cv::Mat dark_grey = grey_of(dark, window), lit_grey = grey_of(lit, window);
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (int y = 0; y < window.height; ++y) {
    const std::uint8_t* d = dark_grey.ptr<std::uint8_t>(y);
    const std::uint8_t* l = lit_grey.ptr<std::uint8_t>(y);
    for (int x = 0; x < window.width; ++x) {
      const int added = l[x] - d[x];
      if (added <= min_added_level) continue;
      const double w = added - min_added_level;
      sum += w * Eigen::Vector2d(u0 + x, v0 + y);
      c.weight += w;
      ++c.pixels;
    }
  }
  if (c.weight > 0.0) c.px = sum / c.weight;
  return c;
}

}  // namespace

cv::Mat dots_frame(const PinholeModel& projector, const std::array<Eigen::Vector2d, 4>& pixels,
                   int radius_px) {
  cv::Mat frame = cv::Mat::zeros(projector.height, projector.width, CV_8UC3);
  // Coverage by 4x4 samples per pixel: an anti-aliased disc whose centroid is its centre to a
  // small fraction of a pixel, which an integer raster would not be.
  constexpr int kSamples = 4;
  const double r = std::max(radius_px, 1);
  for (const Eigen::Vector2d& c : pixels) {
    const int u0 = std::max(0, static_cast<int>(std::floor(c.x() - r - 1)));
    const int u1 = std::min(projector.width - 1, static_cast<int>(std::ceil(c.x() + r + 1)));
    const int v0 = std::max(0, static_cast<int>(std::floor(c.y() - r - 1)));
    const int v1 = std::min(projector.height - 1, static_cast<int>(std::ceil(c.y() + r + 1)));
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        int inside = 0;
        for (int sv = 0; sv < kSamples; ++sv) {
          for (int su = 0; su < kSamples; ++su) {
            const double x = u - 0.5 + (su + 0.5) / kSamples - c.x();
            const double y = v - 0.5 + (sv + 0.5) / kSamples - c.y();
            inside += x * x + y * y <= r * r;
          }
        }
        if (inside == 0) continue;
        const int level = (255 * inside + kSamples * kSamples / 2) / (kSamples * kSamples);
        cv::Vec3b& px = frame.at<cv::Vec3b>(v, u);
        const auto value = static_cast<std::uint8_t>(std::max<int>(px[0], level));
        px = cv::Vec3b(value, value, value);
      }
    }
  }
  return frame;
}

std::array<std::optional<Eigen::Vector2d>, 4> find_dots(
    const ColourFrame& dark, const ColourFrame& lit,
    const std::array<Eigen::Vector2d, 4>& expected_colour_px, double search_px,
    int min_added_level) {
  check_pair(dark, lit, "find_dots");
  std::array<std::optional<Eigen::Vector2d>, 4> found;
  constexpr int kMinPixels = 4;  // a dot is a spot, not one hot pixel
  for (std::size_t i = 0; i < found.size(); ++i) {
    const Centroid coarse =
        added_centroid(dark, lit, expected_colour_px[i], search_px, min_added_level);
    if (coarse.pixels < kMinPixels) continue;
    // Again around the spot, on a window just larger than it: the search window may cut the
    // spot off on one side or hold stray light, both of which pull the first centroid.
    const double spot_radius = std::sqrt(coarse.pixels / 3.14159265358979) * 1.5 + 2.0;
    const Centroid fine = added_centroid(dark, lit, coarse.px, spot_radius, min_added_level);
    if (fine.pixels < kMinPixels) continue;
    found[i] = fine.px;
  }
  return found;
}

std::vector<float> model_depth(const ModelCloud& model, const Eigen::Isometry3d& T_camera_model,
                               const PinholeModel& colour) {
  const int w = colour.width, h = colour.height;
  std::vector<float> depth(static_cast<std::size_t>(w) * h, 0.0f);
  const bool with_normals = model.normals.size() == model.points.size();
  const Eigen::Matrix3d R = T_camera_model.linear();
  constexpr int kSplat = 1;  // pixels around each point's: closes the gaps between samples
  for (std::size_t i = 0; i < model.points.size(); ++i) {
    const Eigen::Vector3d p = T_camera_model * model.points[i].cast<double>();
    // The far side's points would show through the gaps of the near side's splats.
    if (with_normals && (R * model.normals[i].cast<double>()).dot(p) > 0.0) continue;
    const auto px = colour.project(p);
    if (!px) continue;
    const int cu = static_cast<int>(std::lround(px->x()));
    const int cv = static_cast<int>(std::lround(px->y()));
    const float z = static_cast<float>(p.z());
    for (int v = std::max(cv - kSplat, 0); v <= std::min(cv + kSplat, h - 1); ++v) {
      for (int u = std::max(cu - kSplat, 0); u <= std::min(cu + kSplat, w - 1); ++u) {
        float& d = depth[static_cast<std::size_t>(v) * w + u];
        if (d == 0.0f || z < d) d = z;
      }
    }
  }
  // The splats leave pinholes where a sample's normal was culled or the samples thin out: a pixel
  // whose 5x5 neighbourhood is mostly model is model, at its neighbours' nearest depth. Holes
  // are filled from the splatted image only, so the silhouette does not grow.
  std::vector<float> filled = depth;
  constexpr int kReach = 2;
  constexpr int kMostly = 13;  // of the 24 neighbours
  for (int v = kReach; v < h - kReach; ++v) {
    for (int u = kReach; u < w - kReach; ++u) {
      if (depth[static_cast<std::size_t>(v) * w + u] != 0.0f) continue;
      int count = 0;
      float nearest = 0.0f;
      for (int dv = -kReach; dv <= kReach; ++dv) {
        for (int du = -kReach; du <= kReach; ++du) {
          const float z = depth[static_cast<std::size_t>(v + dv) * w + (u + du)];
          if (z == 0.0f) continue;
          ++count;
          if (nearest == 0.0f || z < nearest) nearest = z;
        }
      }
      if (count >= kMostly) filled[static_cast<std::size_t>(v) * w + u] = nearest;
    }
  }
  return filled;
}

LightOnTarget light_on_target(const ColourFrame& dark, const ColourFrame& lit,
                              const RegisteredDepth& depth, const std::vector<float>& model_depth,
                              double tolerance_m, int min_added_level) {
  check_pair(dark, lit, "light_on_target");
  const std::size_t n = static_cast<std::size_t>(dark.width) * dark.height;
  if (depth.colour.width != dark.width || depth.colour.height != dark.height ||
      depth.z_m.size() != n || model_depth.size() != n) {
    throw std::invalid_argument("light_on_target: depth images do not match the colour frames");
  }
  // Beside the model's silhouette "in front" means nearer than the nearest of the model: light
  // caught by an occluder there was still meant for the target.
  float nearest_model = 0.0f;
  for (float z : model_depth) {
    if (z > 0.0f && (nearest_model == 0.0f || z < nearest_model)) nearest_model = z;
  }
  const float tolerance = static_cast<float>(tolerance_m);
  const cv::Rect whole(0, 0, dark.width, dark.height);
  const cv::Mat dark_grey = grey_of(dark, whole), lit_grey = grey_of(lit, whole);
  const std::uint8_t* dark_level = dark_grey.ptr<std::uint8_t>();
  const std::uint8_t* lit_level = lit_grey.ptr<std::uint8_t>();
  LightOnTarget out;
  double total = 0.0, on = 0.0, in_front = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const int added = lit_level[i] - dark_level[i];
    if (added <= min_added_level) continue;
    ++out.lit_pixels;
    const double w = added;
    const float z = depth.z_m[i], z_model = model_depth[i];
    // No reading (the Kinect's shadow beside edges, a grazing surface): neither on nor off the
    // target, so the Kinect's holes at a small target's rim do not count as spilled light.
    if (z == 0.0f) continue;
    total += w;
    if (z_model > 0.0f) {
      if (std::abs(z - z_model) <= tolerance) {
        on += w;
      } else if (z < z_model - tolerance) {
        in_front += w;
      }
    } else if (nearest_model > 0.0f && z < nearest_model - tolerance) {
      in_front += w;
    }
  }
  if (total > 0.0) {
    out.on_target_fraction = on / total;
    out.in_front_fraction = in_front / total;
  } else {
    out.on_target_fraction = 0.0;  // nothing seen lit: nothing shown to be on the target
  }
  return out;
}

}  // namespace projtour::light
