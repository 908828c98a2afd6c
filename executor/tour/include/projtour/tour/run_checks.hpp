#pragma once
// What a run will touch, opened and checked before anything moves: every target's model (a mesh
// the simulator can render and align can sample), its content (decoded, a video's first frame),
// the Model Points against the model's surface and front, the stand-off against the robot's
// footprint and the aim point against the head's reach. `projtour validate` and every run call
// it through prepare_run, so what validate accepts is what a run starts with.
#include <cstddef>

#include "projtour/host/diagnostics.hpp"
#include "projtour/host/mission_loader.hpp"

namespace projtour {

// A Model Point farther than this from the model's surface is a typo or a point measured in
// another model's frame: the targets' own points sit within 1 mm of their meshes, and align
// brings the real target to within the visit's tolerance_mm (default 3), far below it.
inline constexpr double kModelPointSurfaceToleranceM = 0.010;
// Room kept between the robot's footprint and the front of the model at the stand-off pose.
inline constexpr double kStandoffMarginM = 0.10;
// A target a projector head lights from a metre or two away: a vertex farther than this from
// the model's origin is a model in millimetres (×1000) or far from its origin.
inline constexpr double kMaxModelReachM = 20.0;
// The rabbit has 35,947 vertices; a scanned statue at sub-millimetre resolution a few million.
// Beyond these the simulator's BVH and align's sampling take minutes and gigabytes.
inline constexpr std::size_t kMaxModelVertices = 5'000'000;
inline constexpr std::size_t kMaxModelTriangles = 10'000'000;

// Every problem as a diagnostic at the mission field it concerns (targets[i].model, .content,
// .model_points, .standoff_m).
void check_run_assets(const host::LoadedMission& mission, host::Diagnostics& diag);

}  // namespace projtour
