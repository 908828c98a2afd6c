#include "alignment_image.hpp"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "projtour/contract/run_image.hpp"

namespace projtour::align {
namespace {

const cv::Vec3b kRed(40, 40, 230), kBlue(230, 90, 30), kGreen(40, 200, 40);

// Maps camera-frame points into one panel.
struct View {
  virtual ~View() = default;
  virtual bool pixel(const Eigen::Vector3f& p_camera, int& u, int& v) const = 0;
};

// Through the depth camera, at half size around the crop window.
struct CameraView : View {
  const PinholeModel* k = nullptr;
  Eigen::Vector3f depth_to_color;
  double scale = 1.0, u_off = 0.0, v_off = 0.0;
  int width = 0, height = 0;
  bool pixel(const Eigen::Vector3f& p_camera, int& u, int& v) const override {
    const auto px = k->project((p_camera - depth_to_color).cast<double>());
    if (!px) return false;
    u = static_cast<int>((px->x() - u_off) * scale),
    v = static_cast<int>((px->y() - v_off) * scale);
    return u >= 0 && v >= 0 && u < width && v < height;
  }
};

// From the side: depth (camera z) to the right, camera y down, around the guess.
struct SideView : View {
  Eigen::Vector3f centre;
  double px_per_m = 1.0;
  int x_off = 0, width = 0, height = 0;
  bool pixel(const Eigen::Vector3f& p, int& u, int& v) const override {
    u = x_off + static_cast<int>(width / 2 + (p.z() - centre.z()) * px_per_m);
    v = static_cast<int>(height / 2 + (p.y() - centre.y()) * px_per_m);
    return u >= x_off && v >= 0 && u < x_off + width && v < height;
  }
};

void splat(cv::Mat& img, const View& view, const Eigen::Vector3f& p, const cv::Vec3b& colour) {
  int u, v;
  if (view.pixel(p, u, v)) img.at<cv::Vec3b>(v, u) = colour;
}

void draw_model(cv::Mat& img, const View& view, const perception::IcpModel& model,
                const Eigen::Isometry3d& T, const cv::Vec3b& colour) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (const auto& m : model.points()) splat(img, view, R * m + t, colour);
}

}  // namespace

void write_alignment_image(const std::filesystem::path& file, const DepthFrame& frame,
                           const perception::OrganizedCloud& scene,
                           const perception::IcpModel& model,
                           const Eigen::Isometry3d& T_camera_model_guess,
                           const Eigen::Isometry3d* T_camera_model_aligned) {
  constexpr int kPanel = 480;
  cv::Mat img(kPanel, 2 * kPanel, CV_8UC3, cv::Scalar(24, 24, 24));

  // Left panel: the crop window (or the whole frame) scaled to fit.
  CameraView camera;
  camera.k = &frame.intrinsics;
  camera.depth_to_color = scene.depth_to_color_m;
  const int win_w = scene.width > 0 ? scene.width : frame.width;
  const int win_h = scene.height > 0 ? scene.height : frame.height;
  camera.u_off = scene.width > 0 ? scene.u0 : 0;
  camera.v_off = scene.height > 0 ? scene.v0 : 0;
  camera.scale = std::min(static_cast<double>(kPanel) / win_w, static_cast<double>(kPanel) / win_h);
  camera.width = camera.height = kPanel;
  // The raw depth in grey, behind everything, so what the crop left out is still visible.
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      if (frame.at(u, v) == 0) continue;
      const int x = static_cast<int>((u - camera.u_off) * camera.scale);
      const int y = static_cast<int>((v - camera.v_off) * camera.scale);
      if (x < 0 || y < 0 || x >= kPanel || y >= kPanel) continue;
      const int grey = 40 + std::clamp(frame.at(u, v) / 40, 0, 60);
      img.at<cv::Vec3b>(y, x) = cv::Vec3b(grey, grey, grey);
    }
  }
  SideView side;
  side.centre = T_camera_model_guess.translation().cast<float>();
  side.px_per_m = kPanel / (4.0 * std::max(0.05f, model.bounding_radius_m()));
  side.x_off = kPanel;
  side.width = side.height = kPanel;

  for (const View* view : {static_cast<const View*>(&camera), static_cast<const View*>(&side)}) {
    for (const auto& p : scene.points) {
      if (perception::OrganizedCloud::valid(p)) splat(img, *view, p, kRed);
    }
    draw_model(img, *view, model, T_camera_model_guess, kBlue);
    if (T_camera_model_aligned) draw_model(img, *view, model, *T_camera_model_aligned, kGreen);
  }
  cv::line(img, {kPanel, 0}, {kPanel, kPanel - 1}, cv::Scalar(90, 90, 90));
  const auto label = [&](const std::string& text, int y, const cv::Vec3b& c) {
    cv::putText(img, text, {8, y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(c[0], c[1], c[2]), 1,
                cv::LINE_AA);
  };
  label("scene", 20, kRed);
  label("model at the initial guess", 40, kBlue);
  label(T_camera_model_aligned ? "model aligned" : "not aligned", 60, kGreen);
  cv::putText(img, "side view (depth to the right)", {kPanel + 8, 20}, cv::FONT_HERSHEY_SIMPLEX,
              0.5, cv::Scalar(200, 200, 200), 1, cv::LINE_AA);
  write_run_image(file, img);
}

}  // namespace projtour::align
