#include "projtour/head/kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "projtour/contract/geometry.hpp"
#include "projtour/head/projection.hpp"

namespace projtour::head {

namespace {

Eigen::Isometry3d rot_z(double angle_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

Eigen::Isometry3d rot_y(double angle_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return T;
}

// Geometry of a perpendicular pan-tilt axis pair and a projector whose optical axis is
// perpendicular to the tilt axis below this tolerance: the closed form is exact there.
constexpr double kAxisTolerance = 1e-9;
// A pan-link projector has one degree of freedom: accept a point this close to its axis.
constexpr double kPanOnlyTolerance_m = 1e-5;
// A measured mount (the calibrate step's) leaves the optical axis a fraction of a degree off
// perpendicular to the tilt axis; up to about 3 degrees the nearest exact geometry's closed form
// is a starting point Newton's method finishes from.
constexpr double kMeasuredAxisTolerance = 0.05;

std::string fmt_deg(double rad) {
  std::ostringstream s;
  s.precision(1);
  s << std::fixed << rad_to_deg(rad);
  return s.str();
}

std::string fmt_m(double m) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << m;
  return s.str();
}

// Pan angles (within (-2pi, 2pi) and the limits) equal to `angle` modulo 2pi.
std::vector<double> pan_representatives(double angle_rad, double min_rad, double max_rad) {
  std::vector<double> out;
  const double base = wrap_angle_rad(angle_rad);
  for (double candidate : {base - 2.0 * kPi, base, base + 2.0 * kPi}) {
    if (candidate >= min_rad - 1e-12 && candidate <= max_rad + 1e-12) out.push_back(candidate);
  }
  if (out.empty()) out.push_back(base);  // outside the limits: kept so the reason names it
  return out;
}

}  // namespace

HeadKinematics::HeadKinematics(const PanTiltSpec& pan_tilt, const MountSpec& camera_mount,
                               const MountSpec& projector_mount)
    : pan_tilt_(pan_tilt), camera_mount_(camera_mount), projector_mount_(projector_mount) {}

HeadKinematics::HeadKinematics(const RobotSpec& robot)
    : HeadKinematics(robot.pan_tilt, robot.camera.mount, robot.projector.mount) {}

Eigen::Isometry3d HeadKinematics::T_base_pan(const JointAngles& q) const {
  return pan_tilt_.T_base_pan0 * rot_z(q.pan_rad);
}

Eigen::Isometry3d HeadKinematics::T_base_tilt(const JointAngles& q) const {
  return T_base_pan(q) * pan_tilt_.T_pan_tilt0 * rot_y(q.tilt_rad);
}

namespace {
Eigen::Isometry3d T_base_optical(const HeadKinematics& k, const MountSpec& mount,
                                 const JointAngles& q) {
  const Eigen::Isometry3d T_base_link =
      mount.link == Link::pan ? k.T_base_pan(q) : k.T_base_tilt(q);
  return T_base_link * mount.T_link_body * T_body_optical();
}
}  // namespace

Eigen::Isometry3d HeadKinematics::T_base_camera(const JointAngles& q) const {
  return T_base_optical(*this, camera_mount_, q);
}

Eigen::Isometry3d HeadKinematics::T_base_projector(const JointAngles& q) const {
  return T_base_optical(*this, projector_mount_, q);
}

Eigen::Isometry3d HeadKinematics::T_projector_camera(const JointAngles& q) const {
  return T_base_projector(q).inverse() * T_base_camera(q);
}

MountSpec HeadKinematics::projector_mount_for(const JointAngles& q,
                                              const Eigen::Isometry3d& T_projector_camera) const {
  MountSpec mount = projector_mount_;
  const Eigen::Isometry3d T_base_link = mount.link == Link::pan ? T_base_pan(q) : T_base_tilt(q);
  const Eigen::Isometry3d T_base_projector = T_base_camera(q) * T_projector_camera.inverse();
  mount.T_link_body = T_base_link.inverse() * T_base_projector * T_body_optical().inverse();
  return mount;
}

HeadKinematics believed_kinematics(const RobotSpec& robot,
                                   const ProjectorCalibration* calibration) {
  return HeadKinematics(
      robot.pan_tilt, robot.camera.mount,
      calibration != nullptr ? calibration->projector_mount : robot.projector.mount);
}

std::string content_fit_problem(const HeadKinematics& kinematics, const PinholeModel& projector,
                                const std::array<Eigen::Vector3d, 4>& model_points,
                                const Eigen::Vector3d& p_model_aim,
                                const Eigen::Isometry3d& T_base_model, double edge_margin_px) {
  std::string why;
  const auto q = kinematics.aim_projector_at(T_base_model * p_model_aim, &why);
  if (!q) return "out of the head's reach: " + why;
  const ProjectedQuad quad = project_model_points(
      model_points, kinematics.T_base_projector(*q).inverse() * T_base_model, projector);
  return edge_problem(quad, projector, edge_margin_px);
}

namespace {
// A base that moved less than this since the capture stood still.
constexpr double kStillM = 0.01;
constexpr double kStillRad = 0.5 * kPi / 180.0;

bool fitted_this_capture(const AlignResult* aligned, const CapturedFrame* capture) {
  return aligned != nullptr && aligned->T_camera_model && capture != nullptr &&
         aligned->joints.pan_rad == capture->joints.pan_rad &&
         aligned->joints.tilt_rad == capture->joints.tilt_rad;
}
}  // namespace

std::optional<Eigen::Isometry3d> aligned_T_map_model(const RobotSpec& robot,
                                                     const AlignResult* aligned,
                                                     const CapturedFrame* capture) {
  if (!fitted_this_capture(aligned, capture)) return std::nullopt;
  const HeadKinematics head(robot);
  return isometry_from_pose2d(capture->base_estimate.mean) * head.T_base_camera(aligned->joints) *
         *aligned->T_camera_model;
}

std::optional<Eigen::Isometry3d> aligned_T_base_model(const RobotSpec& robot,
                                                      const AlignResult* aligned,
                                                      const CapturedFrame* capture,
                                                      const Pose2D& T_map_base_now) {
  if (!fitted_this_capture(aligned, capture)) return std::nullopt;
  const Pose2D& then = capture->base_estimate.mean;
  const double turned = std::remainder(T_map_base_now.yaw_rad - then.yaw_rad, 2.0 * kPi);
  if (std::hypot(T_map_base_now.x_m - then.x_m, T_map_base_now.y_m - then.y_m) < kStillM &&
      std::abs(turned) < kStillRad) {
    return HeadKinematics(robot).T_base_camera(aligned->joints) * *aligned->T_camera_model;
  }
  return isometry_from_pose2d(T_map_base_now).inverse() *
         *aligned_T_map_model(robot, aligned, capture);
}

// The closed form for the mount turned the least to make its optical axis perpendicular to the
// tilt axis, then Newton on the real mount: the point's ideal projector coordinates (x/z, y/z)
// driven to zero over (pan, tilt), numeric Jacobian.
std::optional<JointAngles> HeadKinematics::aim_measured_mount(const Eigen::Vector3d& p_base,
                                                              std::string* why) const {
  MountSpec exact = projector_mount_;
  const Eigen::Vector3d d = exact.T_link_body.linear().col(0).normalized();
  const Eigen::Vector3d d_exact = Eigen::Vector3d(d.x(), 0.0, d.z()).normalized();
  exact.T_link_body.linear() = Eigen::Quaterniond::FromTwoVectors(d, d_exact).toRotationMatrix() *
                               exact.T_link_body.linear();
  const HeadKinematics nearest(pan_tilt_, camera_mount_, exact);
  std::optional<JointAngles> q = nearest.aim_projector_at(p_base, why);
  if (!q) return q;
  const auto miss = [&](const JointAngles& a) {
    const Eigen::Vector3d p = T_base_projector(a).inverse() * p_base;
    return Eigen::Vector2d(p.x() / p.z(), p.y() / p.z());
  };
  constexpr double kStep_rad = 1e-6;
  for (int iteration = 0; iteration < 8; ++iteration) {
    const Eigen::Vector2d f = miss(*q);
    if (f.norm() < 1e-10) break;
    Eigen::Matrix2d J;
    J.col(0) = (miss({q->pan_rad + kStep_rad, q->tilt_rad}) - f) / kStep_rad;
    J.col(1) = (miss({q->pan_rad, q->tilt_rad + kStep_rad}) - f) / kStep_rad;
    const Eigen::Vector2d step = J.fullPivLu().solve(-f);
    q->pan_rad += step.x();
    q->tilt_rad += step.y();
  }
  if (miss(*q).norm() > 1e-6) {
    if (why != nullptr) *why = "the measured projector mount's aim did not converge";
    return std::nullopt;
  }
  if (!within_limits(*q)) {
    if (why != nullptr) {
      *why = "needs pan " + fmt_deg(q->pan_rad) + " deg, tilt " + fmt_deg(q->tilt_rad) +
             " deg: outside the joint limits";
    }
    return std::nullopt;
  }
  return q;
}

bool HeadKinematics::within_limits(const JointAngles& q) const {
  constexpr double eps_rad = 1e-9;
  return q.pan_rad >= deg_to_rad(pan_tilt_.pan_min_deg) - eps_rad &&
         q.pan_rad <= deg_to_rad(pan_tilt_.pan_max_deg) + eps_rad &&
         q.tilt_rad >= deg_to_rad(pan_tilt_.tilt_min_deg) - eps_rad &&
         q.tilt_rad <= deg_to_rad(pan_tilt_.tilt_max_deg) + eps_rad;
}

namespace {

// The point to aim at and the projector's optical axis, as aim_projector_at's closed forms read
// them: the point in the pan joint frame (p0, at r from the pan axis and azimuth phi), the
// axis' centre c and unit direction d in the projector's link frame, and the joint limits.
struct AimQuery {
  Eigen::Vector3d p0;
  double r, phi;
  Eigen::Vector3d c_link, d_link;
  double pan_min, pan_max, tilt_min, tilt_max;
};

// The joint angles that reach the point, and every rejected candidate's reason, so "out of
// reach" says what each way of reaching would need.
struct AimCandidates {
  std::vector<JointAngles> solutions;
  std::vector<std::string> rejections;
  void reject(const std::string& reason) {
    if (std::find(rejections.begin(), rejections.end(), reason) == rejections.end()) {
      rejections.push_back(reason);
    }
  }
};

// Projector on the pan link: one degree of freedom, the point must lie on the cone the axis
// sweeps. Pan so that the point is in the axis' vertical plane, then check its distance to the
// axis. The reason when the geometry rules out every pan; nullopt once out is filled.
std::optional<std::string> aim_on_pan_link(const AimQuery& in, AimCandidates& out) {
  const Eigen::Vector3d& c_link = in.c_link;
  const Eigen::Vector3d& d_link = in.d_link;
  const Eigen::Vector2d d_h(d_link.x(), d_link.y());
  if (d_h.norm() < kAxisTolerance) return "projector on the pan link looks straight up/down";
  const Eigen::Vector2d n_h = Eigen::Vector2d(-d_h.y(), d_h.x()).normalized();  // left of axis
  const double h = n_h.dot(Eigen::Vector2d(c_link.x(), c_link.y()));
  if (in.r < std::abs(h)) {
    return "point " + fmt_m(in.r) + " m from the pan axis, inside the projector's lateral offset " +
           fmt_m(std::abs(h)) + " m";
  }
  const double alpha = std::atan2(n_h.y(), n_h.x());
  double best_off_m = 1e300;
  for (double sign : {1.0, -1.0}) {
    const double psi = sign * std::acos(std::clamp(h / in.r, -1.0, 1.0));
    for (double pan : pan_representatives(in.phi - alpha - psi, in.pan_min, in.pan_max)) {
      const JointAngles q{pan, 0.0};
      const Eigen::Vector3d p_pan = rot_z(pan).inverse() * in.p0;
      const double s = (p_pan - c_link).dot(d_link);
      const double off_m = ((p_pan - c_link) - s * d_link).norm();
      if (s <= 0.0) continue;
      best_off_m = std::min(best_off_m, off_m);
      if (off_m > kPanOnlyTolerance_m) continue;
      if (q.pan_rad < in.pan_min - 1e-12 || q.pan_rad > in.pan_max + 1e-12) {
        out.reject("needs pan " + fmt_deg(pan) + " deg outside [" + fmt_deg(in.pan_min) + ", " +
                   fmt_deg(in.pan_max) + "] deg");
        continue;
      }
      out.solutions.push_back({pan, std::clamp(0.0, in.tilt_min, in.tilt_max)});
    }
  }
  if (out.solutions.empty() && out.rejections.empty()) {
    out.reject("projector on the pan link: tilt cannot raise or lower its axis, which passes " +
               (best_off_m < 1e299 ? fmt_m(best_off_m) + " m" : std::string("nowhere near")) +
               " from the point");
  }
  return std::nullopt;
}

// Projector on the tilt link, its optical axis perpendicular to the tilt axis a (the caller
// checked): steps 1 and 2 of aim_projector_at's closed form. The reason when the geometry rules
// out every pan; nullopt once out is filled.
std::optional<std::string> aim_on_tilt_link(const AimQuery& in,
                                            const Eigen::Isometry3d& T_pan_tilt0,
                                            AimCandidates& out) {
  const Eigen::Vector3d a = T_pan_tilt0.linear().col(1);  // tilt axis in the pan link
  const Eigen::Vector3d t0 = T_pan_tilt0.translation();
  const double h = a.dot(t0) + in.c_link.y();  // lateral offset of the optical axis' plane
  if (in.r < std::abs(h)) {
    return "point " + fmt_m(in.r) +
           " m from the pan axis, inside the optical axis' lateral offset " + fmt_m(std::abs(h)) +
           " m";
  }
  const double alpha = std::atan2(a.y(), a.x());
  const Eigen::Vector2d c_xz(in.c_link.x(), in.c_link.z());
  const Eigen::Vector2d d_xz = Eigen::Vector2d(in.d_link.x(), in.d_link.z()).normalized();
  for (double sign : {1.0, -1.0}) {
    const double psi = sign * std::acos(std::clamp(h / in.r, -1.0, 1.0));
    for (double pan : pan_representatives(in.phi - alpha - psi, in.pan_min, in.pan_max)) {
      const Eigen::Vector3d q3 = T_pan_tilt0.inverse() * (rot_z(pan).inverse() * in.p0);
      const Eigen::Vector2d q_xz(q3.x(), q3.z());
      // |c_xz + s d_xz|^2 = |q_xz|^2
      const double b = c_xz.dot(d_xz);
      const double disc = b * b - c_xz.squaredNorm() + q_xz.squaredNorm();
      if (disc < 0.0) {
        out.reject("point inside the circle the optical axis keeps clear of the tilt axis");
        continue;
      }
      const double s = -b + std::sqrt(disc);  // the larger root: the point in front
      if (s <= 0.0) {
        out.reject("point behind the projector for every tilt");
        continue;
      }
      const Eigen::Vector2d v_xz = c_xz + s * d_xz;
      // Ry(t) turns (z, x) counter-clockwise by t: angle from v to q in (z, x) coordinates.
      const double cross = v_xz.y() * q_xz.x() - v_xz.x() * q_xz.y();
      const double dot = v_xz.y() * q_xz.y() + v_xz.x() * q_xz.x();
      const double tilt = std::atan2(cross, dot);
      if (pan < in.pan_min - 1e-12 || pan > in.pan_max + 1e-12) {
        out.reject("needs pan " + fmt_deg(pan) + " deg outside [" + fmt_deg(in.pan_min) + ", " +
                   fmt_deg(in.pan_max) + "] deg");
        continue;
      }
      if (tilt < in.tilt_min - 1e-12 || tilt > in.tilt_max + 1e-12) {
        out.reject("needs tilt " + fmt_deg(tilt) + " deg (positive looks down) outside [" +
                   fmt_deg(in.tilt_min) + ", " + fmt_deg(in.tilt_max) + "] deg");
        continue;
      }
      out.solutions.push_back({pan, tilt});
    }
  }
  return std::nullopt;
}

}  // namespace

// Closed form, in the pan joint frame (pan0: pan about z) and the tilt joint frame (tilt0 on the
// pan link: tilt about y). With the tilt axis horizontal in the pan link and the optical axis
// perpendicular to it, the optical axis always lies in the plane {y_tilt0 = h_c}; so
//  1. pan: the point's component along the tilt axis must equal the axis' lateral offset from
//     the pan axis: r cos(phi - alpha - pan) = a.t0 + c_y  ->  two pan angles;
//  2. tilt: rotating about y preserves the distance from the tilt axis; along the optical
//     axis c + s d that distance is |c_xz + s d_xz| = |q_xz|, a quadratic in s (take s > 0), and
//     tilt is the angle turning c_xz + s d_xz onto q_xz in the (z, x) plane.
std::optional<JointAngles> HeadKinematics::aim_projector_at(const Eigen::Vector3d& p_base,
                                                            std::string* why) const {
  auto fail = [&](const std::string& reason) -> std::optional<JointAngles> {
    if (why != nullptr) *why = reason;
    return std::nullopt;
  };
  AimQuery query;
  query.pan_min = deg_to_rad(pan_tilt_.pan_min_deg);
  query.pan_max = deg_to_rad(pan_tilt_.pan_max_deg);
  query.tilt_min = deg_to_rad(pan_tilt_.tilt_min_deg);
  query.tilt_max = deg_to_rad(pan_tilt_.tilt_max_deg);

  query.p0 = pan_tilt_.T_base_pan0.inverse() * p_base;
  query.r = std::hypot(query.p0.x(), query.p0.y());
  query.phi = std::atan2(query.p0.y(), query.p0.x());

  // Optical axis (centre c, unit direction d) in the projector's link frame.
  query.c_link = projector_mount_.T_link_body.translation();
  query.d_link = projector_mount_.T_link_body.linear().col(0).normalized();

  AimCandidates candidates;
  if (projector_mount_.link == Link::pan) {
    if (auto failure = aim_on_pan_link(query, candidates)) return fail(*failure);
  } else {
    const Eigen::Vector3d a = pan_tilt_.T_pan_tilt0.linear().col(1);  // tilt axis in the pan link
    if (std::abs(a.z()) > kAxisTolerance) {
      return fail("tilt axis not perpendicular to the pan axis (closed form needs them so)");
    }
    if (std::abs(query.d_link.y()) > kAxisTolerance) {
      if (std::abs(query.d_link.y()) <= kMeasuredAxisTolerance) {
        return aim_measured_mount(p_base, why);
      }
      return fail(
          "projector optical axis not perpendicular to the tilt axis (closed form needs it)");
    }
    if (auto failure = aim_on_tilt_link(query, pan_tilt_.T_pan_tilt0, candidates)) {
      return fail(*failure);
    }
  }

  const std::vector<JointAngles>& solutions = candidates.solutions;
  if (solutions.empty()) {
    std::string reason;
    for (const std::string& r2 : candidates.rejections) {
      reason += (reason.empty() ? "" : "; or ") + r2;
    }
    return fail(reason.empty() ? "no solution" : reason);
  }
  // The least head motion from straight ahead.
  return *std::min_element(solutions.begin(), solutions.end(), [](const auto& l, const auto& r2) {
    return std::abs(l.pan_rad) + std::abs(l.tilt_rad) <
           std::abs(r2.pan_rad) + std::abs(r2.tilt_rad);
  });
}

}  // namespace projtour::head
