#pragma once
// tour.png: the map cropped to the toured area with the planned paths, the estimated (and, in a
// dry run, the true) trajectory, the start pose and every target with its id and outcome.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "projtour/contract/geometry.hpp"
#include "projtour/navigation/occupancy_map.hpp"

namespace projtour {

struct TourPictureTarget {
  std::string id;
  Pose2D pose;          // the model frame on the floor (from T_map_model); its +x is the front
  std::string outcome;  // projected | skipped | failed; anything else (not visited) is grey
};

struct TourPictureInput {
  std::shared_ptr<const mrpt::maps::COccupancyGridMap2D> map;
  Pose2D start;
  std::vector<TourPictureTarget> targets;
  std::vector<std::vector<Pose2D>> planned_paths;  // one polyline per target visit
  std::vector<Pose2D> estimated_trajectory;
  std::vector<Pose2D> true_trajectory;  // empty unless a dry run
  // Where the simulated people were, sampled every half second (dry run): their tracks.
  std::vector<Eigen::Vector2d> people_samples;
  std::string title;  // e.g. the mission name; drawn above the legend
};

struct RgbColour {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;
};

// The picture's palette, shared with summary.html so both speak the same colours.
inline constexpr RgbColour kPlannedPathColour{30, 120, 255};
inline constexpr RgbColour kEstimatedTrajectoryColour{170, 30, 200};
inline constexpr RgbColour kTrueTrajectoryColour{0, 160, 160};
inline constexpr RgbColour kStartColour{20, 20, 20};
inline constexpr RgbColour kPeopleColour{255, 150, 40};
RgbColour outcome_colour(const std::string& outcome);

// The polyline without the vertices that lie within `tolerance_m` of the segment between the
// vertices kept around them (Douglas-Peucker); the ends are always kept. A tour's trace kept
// this way grows with the corners driven, not with the time spent standing or going straight,
// which is what lets a long day keep it all for the picture.
std::vector<Pose2D> simplify_polyline(const std::vector<Pose2D>& points, double tolerance_m);

// The picture as an 8-bit BGR image: y up in the map is up in the picture, at least 4 px per
// cell unless that would make the long side exceed ~1600 px; a legend strip below the map.
// Throws std::invalid_argument without a map.
cv::Mat render_tour_picture(const TourPictureInput& input);

// render_tour_picture() written as PNG. Throws std::runtime_error naming the file when it
// cannot be written.
void write_tour_picture(const TourPictureInput& input, const std::filesystem::path& png);

}  // namespace projtour
