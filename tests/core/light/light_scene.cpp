#include "light_scene.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>

#include "projtour/contract/geometry.hpp"
#include "projtour/contract/robot.hpp"

namespace projtour::test {

LightRig default_rig() {
  LightRig rig;
  rig.projector = PinholeModel{1280, 800, 1920.0, 1920.0, 640.0, 400.0, {0.01, -0.005, 0, 0, 0}};
  rig.colour = ColourCameraSpec{}.intrinsics;
  rig.depth = PinholeModel{640, 480, 525.0, 525.0, 319.5, 239.5, {0, 0, 0, 0, 0}};
  rig.T_camera_projector.translation() = Eigen::Vector3d(0.12, -0.07, 0.0);
  rig.T_camera_projector.linear() =
      (Eigen::AngleAxisd(-std::atan2(0.12, 1.4), Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(-std::atan2(0.07, 1.4), Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(deg_to_rad(0.5), Eigen::Vector3d::UnitZ()))
          .toRotationMatrix();
  return rig;
}

Surface facing_rectangle(const Eigen::Vector3d& centre, double width_m, double height_m,
                         double yaw_rad, const Eigen::Vector3f& albedo_bgr) {
  Surface s;
  s.kind = Surface::Kind::rectangle;
  s.centre = centre;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  s.u = R.col(0);
  s.v = R.col(1);
  s.half_u_m = 0.5 * width_m;
  s.half_v_m = 0.5 * height_m;
  s.albedo_bgr = albedo_bgr;
  return s;
}

Surface upright_cylinder(const Eigen::Vector3d& centre, double radius_m, double height_m,
                         const Eigen::Vector3f& albedo_bgr) {
  Surface s;
  s.kind = Surface::Kind::cylinder;
  s.centre = centre;
  s.axis = Eigen::Vector3d::UnitY();
  s.radius_m = radius_m;
  s.half_height_m = 0.5 * height_m;
  s.albedo_bgr = albedo_bgr;
  return s;
}

namespace {

constexpr double kMinT = 1e-9;

std::optional<Hit> intersect_rectangle(const Surface& s, const Eigen::Vector3d& o,
                                       const Eigen::Vector3d& d) {
  const Eigen::Vector3d n = s.u.cross(s.v);
  const double denominator = n.dot(d);
  if (std::abs(denominator) < 1e-12) return std::nullopt;
  const double t = n.dot(s.centre - o) / denominator;
  if (t <= kMinT) return std::nullopt;
  const Eigen::Vector3d r = o + t * d - s.centre;
  if (std::abs(r.dot(s.u)) > s.half_u_m || std::abs(r.dot(s.v)) > s.half_v_m) return std::nullopt;
  return Hit{t, -1, denominator < 0.0 ? n : Eigen::Vector3d(-n)};
}

std::optional<Hit> intersect_cylinder(const Surface& s, const Eigen::Vector3d& o,
                                      const Eigen::Vector3d& d) {
  const Eigen::Vector3d oc = o - s.centre;
  const Eigen::Vector3d d_perp = d - d.dot(s.axis) * s.axis;
  const Eigen::Vector3d oc_perp = oc - oc.dot(s.axis) * s.axis;
  const double a = d_perp.squaredNorm();
  if (a < 1e-15) return std::nullopt;
  const double b = 2.0 * oc_perp.dot(d_perp);
  const double c = oc_perp.squaredNorm() - s.radius_m * s.radius_m;
  const double discriminant = b * b - 4.0 * a * c;
  if (discriminant < 0.0) return std::nullopt;
  const double root = std::sqrt(discriminant);
  for (const double t : {(-b - root) / (2.0 * a), (-b + root) / (2.0 * a)}) {
    if (t <= kMinT) continue;
    const Eigen::Vector3d r = oc + t * d;
    if (std::abs(r.dot(s.axis)) > s.half_height_m) continue;
    Eigen::Vector3d n = (r - r.dot(s.axis) * s.axis).normalized();
    if (n.dot(d) > 0.0) n = -n;
    return Hit{t, -1, n};
  }
  return std::nullopt;
}

std::optional<Hit> intersect_sphere(const Surface& s, const Eigen::Vector3d& o,
                                    const Eigen::Vector3d& d) {
  const Eigen::Vector3d oc = o - s.centre;
  const double b = oc.dot(d), c = oc.squaredNorm() - s.radius_m * s.radius_m;
  const double discriminant = b * b - c;  // d is a unit vector
  if (discriminant < 0.0) return std::nullopt;
  const double root = std::sqrt(discriminant);
  for (const double t : {-b - root, -b + root}) {
    if (t <= kMinT) continue;
    Eigen::Vector3d n = (oc + t * d) / s.radius_m;
    if (n.dot(d) > 0.0) n = -n;
    return Hit{t, -1, n};
  }
  return std::nullopt;
}

}  // namespace

std::optional<Hit> Scene::intersect(const Eigen::Vector3d& origin,
                                    const Eigen::Vector3d& direction) const {
  std::optional<Hit> best;
  for (std::size_t i = 0; i < surfaces.size(); ++i) {
    const Surface& s = surfaces[i];
    std::optional<Hit> hit;
    switch (s.kind) {
      case Surface::Kind::rectangle:
        hit = intersect_rectangle(s, origin, direction);
        break;
      case Surface::Kind::cylinder:
        hit = intersect_cylinder(s, origin, direction);
        break;
      case Surface::Kind::sphere:
        hit = intersect_sphere(s, origin, direction);
        break;
    }
    if (hit && (!best || hit->t < best->t)) {
      hit->surface = static_cast<int>(i);
      best = hit;
    }
  }
  return best;
}

namespace {
Surface wall() {
  return facing_rectangle(Eigen::Vector3d(0.0, 0.0, 2.6), 5.0, 4.0, 0.0, {0.45f, 0.5f, 0.5f});
}
}  // namespace

Scene sign_scene() {
  Scene scene;
  scene.surfaces.push_back(facing_rectangle(Eigen::Vector3d(0.0, 0.02, 1.4), 0.46, 0.36,
                                            deg_to_rad(10.0), {0.7f, 0.78f, 0.85f}));
  scene.surfaces.push_back(wall());
  return scene;
}

Scene pillar_scene() {
  Scene scene;
  scene.surfaces.push_back(
      upright_cylinder(Eigen::Vector3d(0.0, 0.0, 1.46), 0.16, 3.0, {0.8f, 0.8f, 0.75f}));
  scene.surfaces.push_back(wall());
  return scene;
}

Scene ball_scene() {
  Scene scene;
  Surface ball;
  ball.kind = Surface::Kind::sphere;
  ball.centre = Eigen::Vector3d(0.02, 0.03, 1.075);
  ball.radius_m = 0.075;
  ball.albedo_bgr = {0.75f, 0.75f, 0.7f};
  scene.surfaces.push_back(ball);
  scene.surfaces.push_back(wall());
  return scene;
}

void add_pole(Scene& scene, double x_m, double z_m) {
  // Before the wall, so the wall stays last.
  scene.surfaces.insert(
      scene.surfaces.end() - 1,
      facing_rectangle(Eigen::Vector3d(x_m, 0.0, z_m), 0.06, 3.0, 0.0, {0.35f, 0.4f, 0.45f}));
}

ColourRenderer::ColourRenderer(const LightRig& rig, const Scene& scene,
                               const ColourSettings& settings)
    : rig_(rig), scene_(scene), settings_(settings) {
  const int S = std::max(settings.supersample, 1);
  samples_ = S * S;
  const PinholeModel& k = rig.colour;
  const std::size_t pixels = static_cast<std::size_t>(k.width) * k.height;
  projector_index_.assign(pixels * samples_, -1);
  light_.assign(pixels * samples_, 0.0f);
  surface_.assign(pixels * samples_, -1);
  centre_surface_.assign(pixels, -1);
  lit_fraction_.assign(pixels, 0.0f);
  const Eigen::Isometry3d T_projector_camera = rig.T_projector_camera();
  const Eigen::Vector3d C = rig.T_camera_projector.translation();
  const PinholeModel& p = rig.projector;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const std::size_t pixel = static_cast<std::size_t>(v) * k.width + u;
      if (const auto hit = scene.intersect(Eigen::Vector3d::Zero(),
                                           k.unproject(Eigen::Vector2d(u, v)).normalized())) {
        centre_surface_[pixel] = static_cast<std::int8_t>(hit->surface);
      }
      int lit = 0;
      for (int sv = 0; sv < S; ++sv) {
        for (int su = 0; su < S; ++su) {
          const std::size_t i = pixel * samples_ + static_cast<std::size_t>(sv * S + su);
          const Eigen::Vector2d px(u - 0.5 + (su + 0.5) / S, v - 0.5 + (sv + 0.5) / S);
          const Eigen::Vector3d ray = k.unproject(px).normalized();
          const auto hit = scene.intersect(Eigen::Vector3d::Zero(), ray);
          if (!hit) continue;
          surface_[i] = static_cast<std::int8_t>(hit->surface);
          const Eigen::Vector3d P = hit->t * ray;
          const auto q = p.project(T_projector_camera * P);
          if (!q) continue;
          const long qu = std::lround(q->x()), qv = std::lround(q->y());
          if (qu < 0 || qv < 0 || qu >= p.width || qv >= p.height) continue;
          const Eigen::Vector3d to = P - C;
          const double distance = to.norm();
          const auto first = scene.intersect(C, to / distance);
          if (!first || std::abs(first->t - distance) > 1e-6) continue;  // in a shadow
          const double incidence = std::abs(hit->normal.dot(to / distance));
          projector_index_[i] = static_cast<std::int32_t>(qv * p.width + qu);
          light_[i] = static_cast<float>(settings.projector_gain * incidence * (1.4 * 1.4) /
                                         (distance * distance));
          ++lit;
        }
      }
      lit_fraction_[pixel] = static_cast<float>(lit) / samples_;
    }
  }
}

ColourFrame ColourRenderer::render(const cv::Mat& projector_bgr, std::uint64_t seed) const {
  const PinholeModel& k = rig_.colour;
  if (projector_bgr.type() != CV_8UC3 || projector_bgr.cols != rig_.projector.width ||
      projector_bgr.rows != rig_.projector.height || !projector_bgr.isContinuous()) {
    throw std::invalid_argument("ColourRenderer::render: not a BGR frame of the projector's size");
  }
  const std::uint8_t* frame = projector_bgr.ptr<std::uint8_t>();
  cv::Mat image(k.height, k.width, CV_32FC3);
  const float ambient = static_cast<float>(settings_.ambient);
  const float per_sample = 1.0f / samples_;
  for (int v = 0; v < k.height; ++v) {
    cv::Vec3f* row = image.ptr<cv::Vec3f>(v);
    for (int u = 0; u < k.width; ++u) {
      const std::size_t first = (static_cast<std::size_t>(v) * k.width + u) * samples_;
      cv::Vec3f sum(0.0f, 0.0f, 0.0f);
      for (std::size_t i = first; i < first + static_cast<std::size_t>(samples_); ++i) {
        if (surface_[i] < 0) continue;
        const Eigen::Vector3f& albedo = scene_.surfaces[surface_[i]].albedo_bgr;
        const std::int32_t q = projector_index_[i];
        for (int c = 0; c < 3; ++c) {
          const float projected = q < 0 ? 0.0f : light_[i] * frame[3 * q + c] * (1.0f / 255.0f);
          sum[c] += albedo[c] * (ambient + projected);
        }
      }
      row[u] = sum * per_sample;
    }
  }
  if (settings_.blur_sigma_px > 0.0) {
    cv::GaussianBlur(image, image, cv::Size(0, 0), settings_.blur_sigma_px);
  }
  if (settings_.noise_sigma > 0.0) {
    cv::RNG rng(seed * 0x9e3779b97f4a7c15ULL + 1);
    cv::Mat noise(image.size(), CV_32FC3);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, settings_.noise_sigma);
    image += noise;
  }
  cv::Mat bgr;
  image.convertTo(bgr, CV_8UC3);
  ColourFrame out;
  out.sequence = seed;
  out.intrinsics = k;
  out.width = k.width;
  out.height = k.height;
  out.exposure_ms = 20.0;
  out.bgr.assign(bgr.datastart, bgr.dataend);
  return out;
}

double ColourRenderer::lit_fraction(int u, int v) const {
  return lit_fraction_[static_cast<std::size_t>(v) * rig_.colour.width + u];
}

int ColourRenderer::surface_at(int u, int v) const {
  return centre_surface_[static_cast<std::size_t>(v) * rig_.colour.width + u];
}

std::optional<Eigen::Vector3d> ColourRenderer::point_at(const Eigen::Vector2d& colour_px) const {
  const Eigen::Vector3d ray = rig_.colour.unproject(colour_px).normalized();
  const auto hit = scene_.intersect(Eigen::Vector3d::Zero(), ray);
  if (!hit) return std::nullopt;
  return Eigen::Vector3d(hit->t * ray);
}

std::optional<Eigen::Vector2d> ColourRenderer::projector_px_at(
    const Eigen::Vector2d& colour_px) const {
  const auto P = point_at(colour_px);
  if (!P) return std::nullopt;
  return rig_.projector.project(rig_.T_projector_camera() * *P);
}

std::optional<Eigen::Vector2d> ColourRenderer::colour_px_of(
    const Eigen::Vector2d& projector_px) const {
  const Eigen::Vector3d C = rig_.T_camera_projector.translation();
  const Eigen::Vector3d ray =
      (rig_.T_camera_projector.linear() * rig_.projector.unproject(projector_px)).normalized();
  const auto hit = scene_.intersect(C, ray);
  if (!hit) return std::nullopt;
  const Eigen::Vector3d P = C + hit->t * ray;
  const auto seen = scene_.intersect(Eigen::Vector3d::Zero(), P.normalized());
  if (!seen || std::abs(seen->t - P.norm()) > 1e-6) return std::nullopt;
  return rig_.colour.project(P);
}

std::vector<ColourFrame> render_sequence(const ColourRenderer& renderer,
                                         const light::GrayCodeSequence& sequence,
                                         const cv::Mat& mask, std::uint64_t seed) {
  std::vector<ColourFrame> frames;
  frames.reserve(static_cast<std::size_t>(sequence.size()));
  for (int i = 0; i < sequence.size(); ++i) {
    frames.push_back(
        renderer.render(sequence.frame(i, mask), seed + static_cast<std::uint64_t>(i)));
  }
  return frames;
}

Correspondences lift_blocks(const light::DecodeResult& decoded,
                            const light::RegisteredDepth& depth) {
  Correspondences c;
  c.points_camera.reserve(decoded.blocks.size());
  c.projector_px.reserve(decoded.blocks.size());
  for (const light::BlockCorrespondence& b : decoded.blocks) {
    const auto p = light::lift(depth, b.colour_px);
    if (!p) continue;
    c.points_camera.push_back(*p);
    c.projector_px.push_back(b.projector_px);
  }
  return c;
}

DepthFrame render_depth(const LightRig& rig, const Scene& scene, std::uint64_t seed, bool noise) {
  // Kinect v1: disparity in 1/8 pixel steps over a 7.5 cm baseline at f = 580 px, so inverse
  // depth comes in steps of 1 / (8 * 580 * 0.075) = 1 / 348 per metre; sigma 1.4e-3 z^2 in
  // depth is a constant 0.49 steps in disparity.
  constexpr double kSteps = 348.0;
  constexpr double kSigmaSteps = kSteps * 1.4e-3;
  const PinholeModel& k = rig.depth;
  DepthFrame frame;
  frame.sequence = seed;
  frame.intrinsics = k;
  frame.width = k.width;
  frame.height = k.height;
  frame.depth_mm.assign(static_cast<std::size_t>(k.width) * k.height, 0);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, kSigmaSteps);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d ray =
          Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0).normalized();
      const auto hit = scene.intersect(rig.depth_to_color_m, ray);
      if (!hit) continue;
      double z = hit->t * ray.z();
      if (noise) z = kSteps / std::round(kSteps / z + gauss(rng));
      if (!(z >= 0.4 && z <= 4.0)) continue;
      frame.depth_mm[static_cast<std::size_t>(v) * k.width + u] =
          static_cast<std::uint16_t>(std::lround(z * 1000.0));
    }
  }
  return frame;
}

cv::Rect colour_roi(const PinholeModel& colour, const std::vector<Eigen::Vector3d>& points_camera,
                    int margin_px) {
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (const Eigen::Vector3d& p : points_camera) {
    const auto px = colour.project(p);
    if (!px) continue;
    u0 = std::min(u0, px->x()), u1 = std::max(u1, px->x());
    v0 = std::min(v0, px->y()), v1 = std::max(v1, px->y());
  }
  if (u0 > u1) return cv::Rect();
  const cv::Rect box(cv::Point(static_cast<int>(std::floor(u0)) - margin_px,
                               static_cast<int>(std::floor(v0)) - margin_px),
                     cv::Point(static_cast<int>(std::ceil(u1)) + margin_px + 1,
                               static_cast<int>(std::ceil(v1)) + margin_px + 1));
  return box & cv::Rect(0, 0, colour.width, colour.height);
}

cv::Mat projector_mask(const LightRig& rig, const Scene& scene, int surface) {
  const PinholeModel& p = rig.projector;
  cv::Mat mask = cv::Mat::zeros(p.height, p.width, CV_8U);
  const Eigen::Vector3d C = rig.T_camera_projector.translation();
  const Eigen::Matrix3d R = rig.T_camera_projector.linear();
  for (int v = 0; v < p.height; ++v) {
    for (int u = 0; u < p.width; ++u) {
      const auto hit = scene.intersect(C, (R * p.unproject(Eigen::Vector2d(u, v))).normalized());
      if (hit && hit->surface == surface) mask.at<std::uint8_t>(v, u) = 255;
    }
  }
  return mask;
}

std::vector<Eigen::Vector3d> rectangle_corners(const Surface& r) {
  std::vector<Eigen::Vector3d> corners;
  for (double a : {-1.0, 1.0}) {
    for (double b : {-1.0, 1.0}) {
      corners.push_back(r.centre + a * r.half_u_m * r.u + b * r.half_v_m * r.v);
    }
  }
  return corners;
}

ModelCloud rectangle_model(const Surface& r, double spacing_m, Eigen::Isometry3d& T_camera_model) {
  T_camera_model = Eigen::Isometry3d::Identity();
  T_camera_model.linear().col(0) = r.u;
  T_camera_model.linear().col(1) = r.v;
  T_camera_model.linear().col(2) = r.u.cross(r.v);
  T_camera_model.translation() = r.centre;
  ModelCloud model;
  const int nu = static_cast<int>(std::floor(2.0 * r.half_u_m / spacing_m));
  const int nv = static_cast<int>(std::floor(2.0 * r.half_v_m / spacing_m));
  for (int j = 0; j <= nv; ++j) {
    for (int i = 0; i <= nu; ++i) {
      model.points.emplace_back(static_cast<float>(-r.half_u_m + i * spacing_m),
                                static_cast<float>(-r.half_v_m + j * spacing_m), 0.0f);
      // Toward the camera's side (model z points away from the camera).
      model.normals.emplace_back(0.0f, 0.0f, -1.0f);
    }
  }
  model.bounding_radius_m = static_cast<float>(std::hypot(r.half_u_m, r.half_v_m));
  return model;
}

Eigen::Isometry3d perturb(const Eigen::Isometry3d& T, double trans_m, double rot_rad,
                          std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
  Eigen::Isometry3d out = T * Eigen::AngleAxisd(rot_rad, axis);
  out.translation() += trans_m * dir;
  return out;
}

}  // namespace projtour::test
