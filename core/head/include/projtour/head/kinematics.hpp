#pragma once
// The kinematic chain map -> base -> pan -> tilt -> camera / projector, from the robot file.
//
// T_base_pan(q)  = T_base_pan0 * Rz(pan)                       (pan about the pan joint's z)
// T_base_tilt(q) = T_base_pan(q) * T_pan_tilt0 * Ry(tilt)      (tilt about the tilt joint's y)
// Tilt sign: a right-handed rotation about +y with x forward, so POSITIVE TILT LOOKS DOWN (the
// robot file's tilt limits -30...+60 deg mean 30 deg up ... 60 deg down). Positive pan turns left.
// Mounts give the device body frame (x along the optical axis, y left, z up) on its link; optical
// frames are T_link_body * T_body_optical().
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "projtour/contract/blackboard_keys.hpp"
#include "projtour/contract/drivers.hpp"
#include "projtour/contract/robot.hpp"

namespace projtour::head {

class HeadKinematics {
 public:
  explicit HeadKinematics(const PanTiltSpec& pan_tilt, const MountSpec& camera_mount,
                          const MountSpec& projector_mount);
  explicit HeadKinematics(const RobotSpec& robot);

  Eigen::Isometry3d T_base_pan(const JointAngles& q) const;
  Eigen::Isometry3d T_base_tilt(const JointAngles& q) const;
  // Optical frames (OpenCV convention: z forward, x right, y down).
  Eigen::Isometry3d T_base_camera(const JointAngles& q) const;
  Eigen::Isometry3d T_base_projector(const JointAngles& q) const;
  // Camera -> projector at the given joint angles (the tilt enters when the mounts differ).
  Eigen::Isometry3d T_projector_camera(const JointAngles& q) const;

  // Closed-form inverse kinematics: joint angles that put `p_base` on the projector's optical
  // axis (in front of it), accounting for the offsets between joint axes and the optical
  // centre. nullopt with `why` filled when no solution lies within the joint limits.
  // Exact for a tilt axis perpendicular to the pan axis and a projector (on the tilt link) whose
  // optical axis is perpendicular to the tilt axis (any offsets, any pitch/roll of the mount);
  // other geometries are refused with the reason. Among several solutions (pan +-2pi, the
  // mirrored pan) the one closest to pan = tilt = 0 is returned. A projector on the pan link is
  // aimed by pan alone and succeeds only when the point lies on the cone its axis sweeps.
  std::optional<JointAngles> aim_projector_at(const Eigen::Vector3d& p_base,
                                              std::string* why = nullptr) const;

  bool within_limits(const JointAngles& q) const;

  // The projector mount that makes T_projector_camera(q) equal the given (measured) transform,
  // on the robot file's link: what the calibrate step adopts and writes for a person to keep.
  MountSpec projector_mount_for(const JointAngles& q,
                                const Eigen::Isometry3d& T_projector_camera) const;

 private:
  std::optional<JointAngles> aim_measured_mount(const Eigen::Vector3d& p_base,
                                                std::string* why) const;

  PanTiltSpec pan_tilt_;
  MountSpec camera_mount_;
  MountSpec projector_mount_;
};

// The head as the robot believes it now: the robot file's, with the projector mount the calibrate
// step measured when there is one (the blackboard's keys::kCalibration).
HeadKinematics believed_kinematics(const RobotSpec& robot, const ProjectorCalibration* calibration);

// Why the content would not fit the projector image, edge_margin_px to spare, with the head
// aimed at `p_model_aim` from a base at `T_base_model` from the target; "" when it would.
std::string content_fit_problem(const HeadKinematics& kinematics, const PinholeModel& projector,
                                const std::array<Eigen::Vector3d, 4>& model_points,
                                const Eigen::Vector3d& p_model_aim,
                                const Eigen::Isometry3d& T_base_model, double edge_margin_px);

// The target where align measured it, in the map: the capture's base estimate, the head at the
// capture's joints (the camera mount is the robot file's: calibration measures only the
// projector's) and the fitted pose. Absent without a fitted pose, or when the capture on the
// blackboard is not the one align fitted (its joints differ). It outlives a move of the base,
// which the camera frame does not: navigate re-approaches and aim re-aims through it.
std::optional<Eigen::Isometry3d> aligned_T_map_model(const RobotSpec& robot,
                                                     const AlignResult* aligned,
                                                     const CapturedFrame* capture);

// The same in the frame of the base at `T_map_base_now`: through the map when the base has moved
// since the capture, else straight from the capture's camera (the estimate's jitter standing
// still, a few millimetres, is not a move and would only blur the re-aim).
std::optional<Eigen::Isometry3d> aligned_T_base_model(const RobotSpec& robot,
                                                      const AlignResult* aligned,
                                                      const CapturedFrame* capture,
                                                      const Pose2D& T_map_base_now);

}  // namespace projtour::head
