#pragma once
// The target's outline as the colour camera sees it, against where the aligned model puts it:
// a check of the pose that does not come from the depth. ICP on depth cannot see a slide along
// a flat face (a sign settles on its own plane wherever the guess left it) nor the bias a rough
// model leaves; the outline's edges in the colour image can. Oriented chamfer matching of the
// model's rendered outline against the image's edges, over image translations.
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/pinhole.hpp"

namespace projtour::light {

struct OutlineSettings {
  int search_px = 48;          // the largest shift looked for, each axis
  double truncate_px = 6.0;    // an outline pixel farther than this from an edge costs this
  double match_px = 1.5;       // ... and nearer than this counts as matched
  double depth_step_m = 0.03;  // a jump in the model's depth this large is an outline too
  int min_outline_pixels = 40;
};

struct OutlineMatch {
  // Where the camera sees the outline minus where the model has it (colour pixels), in the image
  // directions the outline fixes (zero along the others).
  Eigen::Vector2d shift_px = Eigen::Vector2d::Zero();
  int fixed_directions = 0;       // 2: both; 1: across the outline's sides only (a pillar); 0: none
  double matched_fraction = 0.0;  // of the outline's pixels, at the shift
  double cost_px = 0.0;           // mean truncated distance to an edge, at the shift
  double cost_at_zero_px = 0.0;   // ... and where the model has it
  int outline_pixels = 0;
  // The outline turned in the image about `centre_px` (radians, image x towards image y), after
  // the shift: what a rough model's fit leaves about the face's normal, which the depth cannot
  // see on a flat face and the shift does not hold. Zero unless both directions are fixed and
  // the outline's extent around the centre fixes the turn too.
  double rotation_rad = 0.0;
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
};

// Where the outline match moves an image point `px` of the model: the shift, and the turn about
// the centre.
Eigen::Vector2d outline_moves(const OutlineMatch& match, const Eigen::Vector2d& px);

// `frame`: the colour camera with the projector dark (room light only: the content's own edges
// would be matched otherwise). `model_depth`: light::model_depth's image of the model at the
// pose to check, the frame's size. nullopt when the model has too few outline pixels in view.
std::optional<OutlineMatch> match_outline(const ColourFrame& frame,
                                          const std::vector<float>& model_depth,
                                          const OutlineSettings& settings = {});

// The smallest 3-D move of `point` (camera frame) along the plane with `normal` that moves its
// colour pixel by `shift_px` (pinhole, to first order): the slide of a face along itself that
// the outline saw.
Eigen::Vector3d slide_for_shift(const PinholeModel& colour, const Eigen::Vector3d& point,
                                const Eigen::Vector3d& normal, const Eigen::Vector2d& shift_px);

}  // namespace projtour::light
