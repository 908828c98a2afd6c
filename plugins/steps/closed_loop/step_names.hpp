#pragma once
// The names calibrate, verify and wait answer with and are configured by, in one place: the
// descriptors (closed_loop_plugin.cpp) list them and every return site and parameter read uses
// them. One set for the three steps, as lit_capture and target_view end calibrate and verify
// alike (no_frame, occluded, blocked_beam, off_screen).
namespace projtour::closed_loop {
// Outcomes: the descriptor's outcome lists and every return site name them through these, so a
// misspelt outcome does not compile.
namespace outcome {
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kOffScreen = "off_screen";
inline constexpr const char* kTooFewPoints = "too_few_points";
inline constexpr const char* kPoorFit = "poor_fit";
inline constexpr const char* kNoFrame = "no_frame";
inline constexpr const char* kBlockedBeam = "blocked_beam";
inline constexpr const char* kOccluded = "occluded";
inline constexpr const char* kVerified = "verified";
inline constexpr const char* kOutOfTolerance = "out_of_tolerance";
inline constexpr const char* kMisaligned = "misaligned";
inline constexpr const char* kUncertain = "uncertain";
inline constexpr const char* kNotSeen = "not_seen";
}  // namespace outcome
// Parameters: the descriptor's tables and every read of a value name them through these.
namespace param {
inline constexpr const char* kMaskMarginPx = "mask_margin_px";
inline constexpr const char* kRoiMarginPx = "roi_margin_px";
inline constexpr const char* kFrameTimeoutS = "frame_timeout_s";
inline constexpr const char* kMaxChangeMm = "max_change_mm";
inline constexpr const char* kMaxChangeDeg = "max_change_deg";
inline constexpr const char* kEdgeMarginPx = "edge_margin_px";
inline constexpr const char* kDotRadiusPx = "dot_radius_px";
inline constexpr const char* kSearchPx = "search_px";
inline constexpr const char* kMinOnTarget = "min_on_target";
inline constexpr const char* kToleranceMm = "tolerance_mm";
inline constexpr const char* kOutlineSearchPx = "outline_search_px";
inline constexpr const char* kMinOutlineMatched = "min_outline_matched";
inline constexpr const char* kClearOutlineMatched = "clear_outline_matched";
inline constexpr const char* kSpreadSigmas = "spread_sigmas";
inline constexpr const char* kGrossSlideTolerances = "gross_slide_tolerances";
inline constexpr const char* kDurationS = "duration_s";
}  // namespace param

}  // namespace projtour::closed_loop
