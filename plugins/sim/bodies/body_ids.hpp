#pragma once
// Inside the sim plugin: the object ids of the rendered scene and how the colour camera sees each
// kind of body. Every part that adds to the scene or asks what a ray met uses these.
#include "projtour_sim/colour_renderer.hpp"

namespace projtour::sim {

// Object ids in the rendered scene.
constexpr int kFloorId = 0;
constexpr int kWallId = 1;
constexpr int kObstacleId = 2;
constexpr int kFirstTargetId = 10;
// People after every target (a long day's tour has hundreds of objects).
constexpr int kFirstPersonId = 1000000;

// What the colour camera sees each kind of object as (linear B, G, R reflectance): white-ish
// targets that take the content well, mid-grey walls and obstacles, a dark brownish floor.
constexpr Albedo kTargetAlbedo{0.8f, 0.8f, 0.8f};
constexpr Albedo kWallAlbedo{0.5f, 0.5f, 0.5f};
constexpr Albedo kObstacleAlbedo{0.4f, 0.42f, 0.45f};
constexpr Albedo kFloorAlbedo{0.14f, 0.18f, 0.22f};
constexpr Albedo kPersonAlbedo{0.25f, 0.3f, 0.35f};

}  // namespace projtour::sim
