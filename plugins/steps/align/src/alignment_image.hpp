#pragma once
// alignment.png, as the paper's fig. 10: the scene red, the model at the initial guess blue,
// the aligned model green; seen through the depth camera and from the side.
#include <Eigen/Geometry>
#include <filesystem>

#include "projtour/contract/depth_frame.hpp"
#include "projtour/perception/registration.hpp"

namespace projtour::align {

// `T_camera_model_aligned` null: no alignment to show (no target). Throws std::runtime_error
// when the file cannot be written.
void write_alignment_image(const std::filesystem::path& file, const DepthFrame& frame,
                           const perception::OrganizedCloud& scene,
                           const perception::IcpModel& model,
                           const Eigen::Isometry3d& T_camera_model_guess,
                           const Eigen::Isometry3d* T_camera_model_aligned);

}  // namespace projtour::align
