#pragma once
// project's outcomes and parameter names in one place: the descriptor (project_plugin.cpp) lists
// them, and every return site and every read of a setting (tracker.cpp too) uses them.
namespace projtour::project::names {

// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kOffScreen = "off_screen";
inline constexpr const char* kBlockedBeam = "blocked_beam";
}  // namespace outcome
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kDwellS = "dwell_s";
inline constexpr const char* kTrack = "track";
inline constexpr const char* kTrackThresholdMm = "track_threshold_mm";
inline constexpr const char* kTrackThresholdDeg = "track_threshold_deg";
inline constexpr const char* kTrackMinInlierFraction = "track_min_inlier_fraction";
inline constexpr const char* kTrackCropMarginM = "track_crop_margin_m";
inline constexpr const char* kPlanarityWarnMm = "planarity_warn_mm";
inline constexpr const char* kMinAreaPx2 = "min_area_px2";
inline constexpr const char* kBeamGuard = "beam_guard";
inline constexpr const char* kBeamMarginM = "beam_margin_m";
inline constexpr const char* kBeamGuardM = "beam_guard_m";
inline constexpr const char* kBeamMinPoints = "beam_min_points";
inline constexpr const char* kBeamClearS = "beam_clear_s";
inline constexpr const char* kBeamMaxBlockedS = "beam_max_blocked_s";
}  // namespace param

}  // namespace projtour::project::names
