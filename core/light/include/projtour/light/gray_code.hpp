#pragma once
// Structured light for the calibrate step: a Gray-code sequence over blocks of projector pixels
// (OpenCV's structured_light GrayCodePattern on a block grid, each pattern shown with its
// inverse), and its decoding into projector-block <-> colour-pixel correspondences.
//
// Order of the frames: 0 = all white, 1 = all black (the shadow mask), then for each column
// bit, most significant first, the pattern and its inverse; then the same for the row bits.
#include <Eigen/Core>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "projtour/contract/colour_frame.hpp"
#include "projtour/contract/pinhole.hpp"

namespace projtour::light {

struct GrayCodeSettings {
  int block_px = 16;  // the finest stripe (projector pixels)
  // A camera pixel decodes when white - black exceeds this (8-bit grey levels) ...
  int min_contrast = 12;
  // ... and every bit's pattern and inverse differ by at least this much.
  int min_bit_contrast = 4;
  // A block's correspondence needs at least this many camera pixels decoding to it.
  int min_pixels_per_block = 3;
};

class GrayCodeSequence {
 public:
  GrayCodeSequence(const PinholeModel& projector, const GrayCodeSettings& settings);
  ~GrayCodeSequence();
  GrayCodeSequence(GrayCodeSequence&&) noexcept;
  GrayCodeSequence& operator=(GrayCodeSequence&&) noexcept;

  int size() const;  // frames in the sequence
  int block_columns() const;
  int block_rows() const;
  int column_bits() const;  // ceil(log2(block_columns())): frames 2 .. 2 + 2 * column_bits - 1
  int row_bits() const;     // ceil(log2(block_rows())): the frames after the column bits
  // Frame i as the projector shows it (BGR, projector size). Outside `mask` (CV_8U, projector
  // size, nonzero = lit; empty = everywhere) the frame is black, so the light stays on the
  // target area.
  cv::Mat frame(int i, const cv::Mat& mask = cv::Mat()) const;
  // The projector pixel at the centre of block (column, row).
  Eigen::Vector2d block_centre_px(int column, int row) const;
  const GrayCodeSettings& settings() const;
  const PinholeModel& projector() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One decoded projector block: the centroid of the colour pixels that decoded to it.
struct BlockCorrespondence {
  int column = 0, row = 0;
  Eigen::Vector2d projector_px = Eigen::Vector2d::Zero();  // the block's centre
  Eigen::Vector2d colour_px = Eigen::Vector2d::Zero();     // distorted colour pixel (centroid)
  int pixels = 0;                                          // that decoded to it, in its spot
};

struct DecodeResult {
  std::vector<BlockCorrespondence> blocks;
  int decoded_pixels = 0;  // camera pixels that decoded
  int lit_pixels = 0;      // camera pixels above min_contrast
  std::string problem;     // "" or why nothing could be decoded (wrong frame count, sizes)
};

// `frames` are the colour frames captured under frames 0..size()-1, in order. Only colour
// pixels inside `roi` (empty = the whole image) are decoded, in grey levels: a pixel decodes
// when white - black exceeds min_contrast and every bit's pattern and inverse differ by at least
// min_bit_contrast, to a block inside the grid. A block needs min_pixels_per_block of them in
// one compact spot (pixels decoded far from the others' median are dropped; a block without a
// majority in one spot is dropped). Its colour_px is the centroid of its footprint: a pixel
// across a block boundary counts for each side by its share there (from the bit that flips at
// that boundary), so the centroid is sub-pixel, not that of whole pixels. Only whole blocks are
// returned -- clear of the roi's border, with all four neighbours decoded next to them in the
// image, and a footprint at least 85% of their neighbours' -- since a block cut by a shadow, the
// target's rim or the roi has the centroid of its visible part. Deterministic.
DecodeResult decode(const GrayCodeSequence& sequence, const std::vector<ColourFrame>& frames,
                    const cv::Rect& roi = cv::Rect());

}  // namespace projtour::light
