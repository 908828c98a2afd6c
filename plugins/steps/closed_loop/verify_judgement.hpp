#pragma once
// verify's judgement: from what the colour camera measured and the step's settings to one of its
// outcomes and the reason, with nothing else read. Kept apart from the measuring (verify.cpp:
// frames, depth, outline, dots) so that each outcome can be reached and tested from figures
// alone, without lighting anything.
#include <array>
#include <cstddef>
#include <optional>
#include <string>

namespace projtour::closed_loop {

// What verify measured, as the judgement reads it.
struct VerifyMeasured {
  // The content area lit white: shares of the added light on the target and in front of it.
  double on_target_fraction = 1.0;
  double in_front_fraction = 0.0;
  // The target's outline in the dark frame: clear (it resolves a millimetre), a gross slide of
  // the aligned pose (beyond gross_slide_tolerances), and what was seen, for the reason.
  bool outline_clear = false;
  bool outline_gross = false;
  std::string outline_text;
  // The four dots: how many were found and lifted onto a surface, and which were not.
  int dots_seen = 0;
  std::string unseen;
  // Mean and per corner error of the dots against where the outline puts the Model Points (set
  // once a dot is seen), and the mean against where the aligned pose puts them.
  std::optional<double> observed_error_mm;
  std::array<std::optional<double>, 4> corner_error_mm{};
  double at_pose_mm = 0.0;
  // The largest move of a Model Point the outline asks for.
  double moves_mm = 0.0;
  // The depth fit against itself at the Model Points (core/perception's pose_spread).
  double spread_model_point_mm = 0.0;
  int spread_blocks = 0;
  std::size_t spread_matches = 0;
};

// The settings the judgement weighs the figures with.
struct VerifyCriteria {
  double tolerance_mm = 3.0;    // the target's, or the step's tolerance_mm
  double min_on_target = 0.95;  // share of the light that must land on the target
  double spread_sigmas = 4.0;   // the fit's spread, in standard deviations, against the tolerance
};

struct VerifyJudgement {
  const char* outcome = nullptr;  // one of verify's outcomes (step_names.hpp)
  std::string reason;             // without the target's prefix
  // misaligned: the aligned pose is to be slid onto where the outline sees the Model Points.
  bool correct_pose = false;
};

VerifyJudgement judge_verify(const VerifyMeasured& m, const VerifyCriteria& c);

// The share of light and what stands in front, as the reasons word it.
std::string light_text(const VerifyMeasured& m);

}  // namespace projtour::closed_loop
