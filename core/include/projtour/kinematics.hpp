#pragma once
// The kinematic chain map -> base -> pan -> tilt -> camera / projector, from the robot file.
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "projtour/drivers.hpp"
#include "projtour/robot.hpp"

namespace projtour {

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
  std::optional<JointAngles> aim_projector_at(const Eigen::Vector3d& p_base,
                                              std::string* why = nullptr) const;

  bool within_limits(const JointAngles& q) const;

 private:
  PanTiltSpec pan_tilt_;
  MountSpec camera_mount_;
  MountSpec projector_mount_;
};

}  // namespace projtour
