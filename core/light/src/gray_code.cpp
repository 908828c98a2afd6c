// The Gray-code sequence over projector blocks and its decoding. The patterns come from OpenCV's
// GrayCodePattern on the block grid; the decoding is done here on bit planes over the region of
// interest, which is GrayCodePattern::getProjPixel's test per pixel (pattern brighter than its
// inverse = 1, most significant bit first) without its per-pixel allocations.
#include "projtour/light/gray_code.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <opencv2/structured_light/graycodepattern.hpp>
#include <stdexcept>
#include <vector>

namespace projtour::light {

namespace {

// Bits OpenCV's GrayCodePattern spends on `n` stripes: ceil(log2(n)).
int bits_for(int n) {
  int bits = 0;
  while ((1 << bits) < n) ++bits;
  return bits;
}

// Gray code to binary: each bit is the XOR of itself and every more significant Gray bit.
std::uint32_t gray_to_binary(std::uint32_t g) {
  for (std::uint32_t shift = 1; shift < 32; shift <<= 1) g ^= g >> shift;
  return g;
}

}  // namespace

struct GrayCodeSequence::Impl {
  PinholeModel projector;
  GrayCodeSettings settings;
  int columns = 0, rows = 0;
  int column_bits = 0, row_bits = 0;
  // On the block grid (rows x columns, CV_8U), in frame order from frame 2 on.
  std::vector<cv::Mat> patterns;
};

GrayCodeSequence::GrayCodeSequence(const PinholeModel& projector, const GrayCodeSettings& settings)
    : impl_(std::make_unique<Impl>()) {
  if (projector.width <= 0 || projector.height <= 0) {
    throw std::invalid_argument("GrayCodeSequence: the projector has no size");
  }
  if (settings.block_px <= 0) throw std::invalid_argument("GrayCodeSequence: block_px <= 0");
  Impl& s = *impl_;
  s.projector = projector;
  s.settings = settings;
  s.columns = (projector.width + settings.block_px - 1) / settings.block_px;
  s.rows = (projector.height + settings.block_px - 1) / settings.block_px;
  s.column_bits = bits_for(s.columns);
  s.row_bits = bits_for(s.rows);
  cv::structured_light::GrayCodePattern::Params params;
  params.width = s.columns;
  params.height = s.rows;
  const cv::Ptr<cv::structured_light::GrayCodePattern> pattern =
      cv::structured_light::GrayCodePattern::create(params);
  pattern->generate(s.patterns);
  if (static_cast<int>(s.patterns.size()) != 2 * (s.column_bits + s.row_bits)) {
    throw std::logic_error("GrayCodeSequence: OpenCV generated an unexpected number of patterns");
  }
}

GrayCodeSequence::~GrayCodeSequence() = default;
GrayCodeSequence::GrayCodeSequence(GrayCodeSequence&&) noexcept = default;
GrayCodeSequence& GrayCodeSequence::operator=(GrayCodeSequence&&) noexcept = default;

int GrayCodeSequence::size() const {
  return 2 + static_cast<int>(impl_->patterns.size());
}
int GrayCodeSequence::block_columns() const {
  return impl_->columns;
}
int GrayCodeSequence::block_rows() const {
  return impl_->rows;
}
int GrayCodeSequence::column_bits() const {
  return impl_->column_bits;
}
int GrayCodeSequence::row_bits() const {
  return impl_->row_bits;
}
const GrayCodeSettings& GrayCodeSequence::settings() const {
  return impl_->settings;
}
const PinholeModel& GrayCodeSequence::projector() const {
  return impl_->projector;
}

cv::Mat GrayCodeSequence::frame(int i, const cv::Mat& mask) const {
  const Impl& s = *impl_;
  if (i < 0 || i >= size()) throw std::out_of_range("GrayCodeSequence::frame: no such frame");
  const cv::Size size(s.projector.width, s.projector.height);
  if (!mask.empty() && (mask.size() != size || mask.type() != CV_8U)) {
    throw std::invalid_argument("GrayCodeSequence::frame: mask is not CV_8U of projector size");
  }
  cv::Mat grey;
  if (i < 2) {
    grey = cv::Mat(size, CV_8U, cv::Scalar(i == 0 ? 255 : 0));
  } else {
    // The grid may overhang the projector by part of a block; crop after the exact upscale.
    const int block = s.settings.block_px;
    cv::Mat full;
    cv::resize(s.patterns[static_cast<std::size_t>(i - 2)], full,
               cv::Size(s.columns * block, s.rows * block), 0, 0, cv::INTER_NEAREST);
    grey = full(cv::Rect(0, 0, size.width, size.height)).clone();
  }
  if (!mask.empty()) grey.setTo(0, mask == 0);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

Eigen::Vector2d GrayCodeSequence::block_centre_px(int column, int row) const {
  const Impl& s = *impl_;
  const int block = s.settings.block_px;
  // The centre of the block's pixels that the projector has (the last ones may be cut).
  const auto centre = [block](int index, int limit) {
    const int first = index * block;
    const int last = std::min(first + block, limit) - 1;
    return 0.5 * (first + last);
  };
  return {centre(column, s.projector.width), centre(row, s.projector.height)};
}

namespace {

// The region's grey levels, one contiguous plane per frame.
std::vector<cv::Mat> grey_planes(const std::vector<ColourFrame>& frames, const cv::Rect& roi) {
  std::vector<cv::Mat> planes(frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const ColourFrame& f = frames[i];
    // A header on the frame's bytes, read only.
    const cv::Mat bgr(f.height, f.width, CV_8UC3, const_cast<std::uint8_t*>(f.bgr.data()));
    cv::cvtColor(bgr(roi), planes[i], cv::COLOR_BGR2GRAY);
  }
  return planes;
}

std::string check_frames(const GrayCodeSequence& sequence, const std::vector<ColourFrame>& frames) {
  if (static_cast<int>(frames.size()) != sequence.size()) {
    return "decode: " + std::to_string(frames.size()) + " frames for a sequence of " +
           std::to_string(sequence.size());
  }
  const int w = frames.front().width, h = frames.front().height;
  if (w <= 0 || h <= 0) return "decode: empty colour frames";
  for (const ColourFrame& f : frames) {
    if (f.width != w || f.height != h) return "decode: the frames differ in size";
    if (f.bgr.size() != static_cast<std::size_t>(w) * h * 3) {
      return "decode: a frame's pixels do not match its size";
    }
  }
  return "";
}

// A block is kept with a footprint at least this fraction of its neighbours' median.
constexpr double kMinFootprint = 0.85;

// Where a block's pixels are: the median of those that decoded to it, robust to a minority
// decoded far away (a wrong bit), and how far from it they may lie -- twice the radius of a disc
// of the block's pixel count, so a spot stretched by an oblique surface still passes while
// pixels strewn over the image do not.
struct Spot {
  Eigen::Vector2f median = Eigen::Vector2f::Zero();
  float radius_sq = 0.0f;
  int kept = 0;
  bool found = false;
  bool holds(const Eigen::Vector2f& p) const { return (p - median).squaredNorm() <= radius_sq; }
};

Spot find_spot(const Eigen::Vector2f* pixels, int n, int min_pixels, std::vector<float>& scratch) {
  Spot spot;
  if (n < min_pixels) return spot;
  scratch.resize(static_cast<std::size_t>(n));
  const auto median_of = [&](int axis) {
    for (int i = 0; i < n; ++i) scratch[static_cast<std::size_t>(i)] = pixels[i][axis];
    std::nth_element(scratch.begin(), scratch.begin() + n / 2, scratch.end());
    return scratch[static_cast<std::size_t>(n / 2)];
  };
  spot.median = Eigen::Vector2f(median_of(0), median_of(1));
  const float radius = 2.0f * std::sqrt(static_cast<float>(n) / 3.14159265f) + 1.5f;
  spot.radius_sq = radius * radius;
  for (int i = 0; i < n; ++i) spot.kept += spot.holds(pixels[i]);
  // Without a majority in one spot the median itself is meaningless.
  spot.found = spot.kept >= min_pixels && 2 * spot.kept > n;
  return spot;
}

// Along one axis of the block grid, for each block index: the frame pair whose bit flips at the
// boundary with the block before (the after) it, and whether this block's bit there is 1. A
// camera pixel across that boundary sees the pattern minus its inverse at a fraction of the full
// contrast, which tells how much of it lies on each side.
struct BoundaryBits {
  std::vector<std::int16_t> frame_before, frame_after;  // -1: the grid's edge
  std::vector<std::int8_t> sign_before, sign_after;     // +1: this block's bit is 1 there
};

BoundaryBits boundary_bits(int blocks, int bits, int first_frame) {
  BoundaryBits b;
  b.frame_before.assign(static_cast<std::size_t>(blocks), -1);
  b.frame_after.assign(static_cast<std::size_t>(blocks), -1);
  b.sign_before.assign(static_cast<std::size_t>(blocks), 0);
  b.sign_after.assign(static_cast<std::size_t>(blocks), 0);
  const auto gray = [](std::uint32_t x) { return x ^ (x >> 1); };
  for (int c = 0; c + 1 < blocks; ++c) {
    // Adjacent Gray codes differ in exactly one bit; frames hold the most significant first.
    const std::uint32_t flip = gray(c) ^ gray(c + 1);
    int position = 0;
    while (!((flip >> position) & 1u)) ++position;
    const auto frame = static_cast<std::int16_t>(first_frame + 2 * (bits - 1 - position));
    const auto i = static_cast<std::size_t>(c);
    b.frame_after[i] = frame;
    b.sign_after[i] = (gray(c) >> position) & 1u ? 1 : -1;
    b.frame_before[i + 1] = frame;
    b.sign_before[i + 1] = static_cast<std::int8_t>(-b.sign_after[i]);
  }
  return b;
}

// Per region pixel, row-major: still decodable (bright enough lit, every bit's pattern and
// inverse far enough apart), and the Gray codes built up bit by bit.
struct PixelCodes {
  std::vector<std::uint8_t> ok;
  std::vector<std::uint32_t> column_code, row_code;
};

PixelCodes read_codes(const GrayCodeSequence& sequence, const std::vector<cv::Mat>& grey,
                      std::size_t count, DecodeResult& result) {
  const GrayCodeSettings& settings = sequence.settings();
  PixelCodes codes{std::vector<std::uint8_t>(count), std::vector<std::uint32_t>(count, 0),
                   std::vector<std::uint32_t>(count, 0)};
  std::vector<std::uint8_t>& ok = codes.ok;
  {
    const std::uint8_t* white = grey[0].ptr<std::uint8_t>();
    const std::uint8_t* black = grey[1].ptr<std::uint8_t>();
    for (std::size_t i = 0; i < count; ++i) {
      ok[i] = white[i] - black[i] > settings.min_contrast;
      result.lit_pixels += ok[i];
    }
  }
  const int column_bits = sequence.column_bits();
  const int bits = column_bits + sequence.row_bits();
  for (int bit = 0; bit < bits; ++bit) {
    const std::uint8_t* pattern = grey[static_cast<std::size_t>(2 + 2 * bit)].ptr<std::uint8_t>();
    const std::uint8_t* inverse = grey[static_cast<std::size_t>(3 + 2 * bit)].ptr<std::uint8_t>();
    std::uint32_t* code = bit < column_bits ? codes.column_code.data() : codes.row_code.data();
    for (std::size_t i = 0; i < count; ++i) {
      const int difference = pattern[i] - inverse[i];
      code[i] = (code[i] << 1) | static_cast<std::uint32_t>(difference > 0);
      ok[i] &= std::abs(difference) >= settings.min_bit_contrast;
    }
  }
  return codes;
}

// Each decoded pixel's block (-1 = none), then the pixels grouped by block (counting sort, so
// each block's pixels are contiguous and in raster order): block b's are grouped[first[b],
// first[b + 1]), at region pixels grouped_index[...].
struct BlockPixels {
  std::vector<std::int32_t> block_of;
  std::vector<std::int32_t> first;
  std::vector<Eigen::Vector2f> grouped;  // in image pixels
  std::vector<std::int32_t> grouped_index;
};

BlockPixels group_by_block(const GrayCodeSequence& sequence, const PixelCodes& codes,
                           const cv::Rect& roi, std::size_t count, DecodeResult& result) {
  const int columns = sequence.block_columns(), rows = sequence.block_rows();
  const std::size_t blocks = static_cast<std::size_t>(columns) * rows;
  BlockPixels out;
  std::vector<std::int32_t>& block_of = out.block_of;
  std::vector<std::int32_t>& first = out.first;
  block_of.assign(count, -1);
  first.assign(blocks + 1, 0);
  for (std::size_t i = 0; i < count; ++i) {
    if (!codes.ok[i]) continue;
    const std::uint32_t c = gray_to_binary(codes.column_code[i]);
    const std::uint32_t r = gray_to_binary(codes.row_code[i]);
    if (c >= static_cast<std::uint32_t>(columns) || r >= static_cast<std::uint32_t>(rows)) continue;
    block_of[i] = static_cast<std::int32_t>(r * columns + c);
    ++first[static_cast<std::size_t>(block_of[i]) + 1];
    ++result.decoded_pixels;
  }
  for (std::size_t b = 0; b < blocks; ++b) first[b + 1] += first[b];
  const auto pixel_of = [&roi](std::size_t i) {
    return Eigen::Vector2f(static_cast<float>(roi.x + static_cast<int>(i % roi.width)),
                           static_cast<float>(roi.y + static_cast<int>(i / roi.width)));
  };
  out.grouped.resize(static_cast<std::size_t>(result.decoded_pixels));
  out.grouped_index.resize(out.grouped.size());
  std::vector<std::int32_t> next(first.begin(), first.end() - 1);
  for (std::size_t i = 0; i < count; ++i) {
    if (block_of[i] < 0) continue;
    const auto slot = static_cast<std::size_t>(next[static_cast<std::size_t>(block_of[i])]++);
    out.grouped[slot] = pixel_of(i);
    out.grouped_index[slot] = static_cast<std::int32_t>(i);
  }
  return out;
}

// What the centroid by coverage reads for one region pixel: the frames' grey planes and the
// inverse of its white-black contrast.
struct Coverage {
  const std::vector<cv::Mat>& grey;
  std::vector<float> inverse_contrast;

  // The share of pixel i on the far side of the boundary held in `frame` (-1: none).
  float across(std::size_t i, int frame, int sign) const {
    if (frame < 0) return 0.0f;
    const int difference = grey[static_cast<std::size_t>(frame)].ptr<std::uint8_t>()[i] -
                           grey[static_cast<std::size_t>(frame) + 1].ptr<std::uint8_t>()[i];
    const float own = 0.5f * (1.0f + static_cast<float>(sign * difference) * inverse_contrast[i]);
    return 1.0f - std::clamp(own, 0.0f, 1.0f);
  }
  // Pixel i's shares on the block before, on the block `index` itself and on the block after.
  std::array<float, 3> shares(std::size_t i, const BoundaryBits& axis, int index) const {
    const auto k = static_cast<std::size_t>(index);
    const float before = across(i, axis.frame_before[k], axis.sign_before[k]);
    const float after = across(i, axis.frame_after[k], axis.sign_after[k]);
    return std::array<float, 3>{before, std::max(0.0f, 1.0f - before - after), after};
  }
};

// The centroid by coverage: a pixel across a block boundary counts for each block by the
// fraction of it on that block's side (from the bit that flips there), so the centroid is that
// of the block's footprint rather than of the whole pixels it won, which would be off by up to
// half a pixel with the phase of the block grid against the pixel grid. Pixels outside a
// block's spot count for it not at all. Per block: weight, weight * (u, v).
std::vector<Eigen::Vector3d> coverage_sums(const GrayCodeSequence& sequence,
                                           const std::vector<cv::Mat>& grey,
                                           const BlockPixels& pixels,
                                           const std::vector<Spot>& spots) {
  const int columns = sequence.block_columns(), rows = sequence.block_rows();
  const int column_bits = sequence.column_bits();
  const std::size_t blocks = spots.size();
  const std::size_t count = pixels.block_of.size();
  const BoundaryBits along_u = boundary_bits(columns, column_bits, 2);
  const BoundaryBits along_v = boundary_bits(rows, sequence.row_bits(), 2 + 2 * column_bits);
  Coverage coverage{grey, std::vector<float>(count, 0.0f)};
  {
    const std::uint8_t* white = grey[0].ptr<std::uint8_t>();
    const std::uint8_t* black = grey[1].ptr<std::uint8_t>();
    for (std::size_t i = 0; i < count; ++i) {
      if (pixels.block_of[i] >= 0) {
        coverage.inverse_contrast[i] = 1.0f / static_cast<float>(white[i] - black[i]);
      }
    }
  }
  std::vector<Eigen::Vector3d> sums(blocks, Eigen::Vector3d::Zero());
  const std::vector<std::int32_t>& first = pixels.first;
  for (std::size_t b = 0; b < blocks; ++b) {
    if (!spots[b].found) continue;
    const int column = static_cast<int>(b % columns), row = static_cast<int>(b / columns);
    for (int slot = first[b]; slot < first[b + 1]; ++slot) {
      const Eigen::Vector2f& p = pixels.grouped[static_cast<std::size_t>(slot)];
      if (!spots[b].holds(p)) continue;
      const auto i = static_cast<std::size_t>(pixels.grouped_index[static_cast<std::size_t>(slot)]);
      const std::array<float, 3> wu = coverage.shares(i, along_u, column);
      const std::array<float, 3> wv = coverage.shares(i, along_v, row);
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const float w =
              wu[static_cast<std::size_t>(du + 1)] * wv[static_cast<std::size_t>(dv + 1)];
          // Zero beyond the grid's edge (no boundary bit there), so target stays on the grid.
          if (w <= 0.0f) continue;
          const std::size_t target = b + static_cast<std::size_t>(dv * columns + du);
          if (!spots[target].found || !spots[target].holds(p)) continue;
          sums[target] += Eigen::Vector3d(w, w * p.x(), w * p.y());
        }
      }
    }
  }
  return sums;
}

// A block cut short -- by the region's border, a shadow, the target's rim or the mask -- has
// the centroid of the part seen, not of the block's centre. Kept are the blocks inside the
// decoded area: clear of the region's border, with all four neighbours decoded beside them in
// the image (the neighbour beyond a target's rim is decoded too, but on the background,
// displaced by the parallax), and with a footprint close to those of the blocks around them,
// which change only slowly with the surface's slant.
void keep_whole_blocks(const GrayCodeSequence& sequence, const cv::Rect& roi,
                       const BlockPixels& pixels, const std::vector<Spot>& spots,
                       const std::vector<Eigen::Vector3d>& sums, DecodeResult& result) {
  const int columns = sequence.block_columns(), rows = sequence.block_rows();
  const std::size_t blocks = spots.size();
  const std::vector<std::int32_t>& first = pixels.first;
  std::vector<std::uint8_t> usable(blocks, 0);
  for (std::size_t b = 0; b < blocks; ++b) {
    usable[b] = spots[b].found && sums[b].x() > 0.0;
    for (int slot = first[b]; slot < first[b + 1] && usable[b]; ++slot) {
      const Eigen::Vector2f& p = pixels.grouped[static_cast<std::size_t>(slot)];
      usable[b] = !(spots[b].holds(p) &&
                    (p.x() <= roi.x || p.y() <= roi.y || p.x() >= roi.x + roi.width - 1 ||
                     p.y() >= roi.y + roi.height - 1));
    }
  }
  const auto centroid = [&sums](std::size_t b) -> Eigen::Vector2d {
    return sums[b].tail<2>() / sums[b].x();
  };
  std::vector<double> around;
  for (std::size_t b = 0; b < blocks; ++b) {
    if (!usable[b]) continue;
    const int column = static_cast<int>(b % columns), row = static_cast<int>(b / columns);
    const Eigen::Vector2d at = centroid(b);
    // Blocks tile the surface, so neighbours lie about one footprint's side apart.
    const double reach = 2.0 * std::sqrt(sums[b].x()) + 1.0;
    around.clear();
    int sides = 0;
    for (int dv = -1; dv <= 1; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        const int c = column + du, r = row + dv;
        if ((du == 0 && dv == 0) || c < 0 || r < 0 || c >= columns || r >= rows) continue;
        const std::size_t n = static_cast<std::size_t>(r) * columns + c;
        if (!spots[n].found || !(sums[n].x() > 0.0)) continue;
        if ((centroid(n) - at).squaredNorm() > reach * reach) continue;
        around.push_back(sums[n].x());
        sides += du == 0 || dv == 0;
      }
    }
    if (sides < 4) continue;
    std::nth_element(around.begin(), around.begin() + around.size() / 2, around.end());
    if (sums[b].x() < kMinFootprint * around[around.size() / 2]) continue;
    BlockCorrespondence block;
    block.column = column;
    block.row = row;
    block.projector_px = sequence.block_centre_px(column, row);
    block.colour_px = at;
    block.pixels = spots[b].kept;
    result.blocks.push_back(block);
  }
}

}  // namespace

DecodeResult decode(const GrayCodeSequence& sequence, const std::vector<ColourFrame>& frames,
                    const cv::Rect& roi_in) {
  DecodeResult result;
  result.problem = check_frames(sequence, frames);
  if (!result.problem.empty()) return result;
  const cv::Rect image(0, 0, frames.front().width, frames.front().height);
  const cv::Rect roi = roi_in.empty() ? image : (roi_in & image);
  if (roi.empty()) {
    result.problem = "decode: the region of interest is outside the image";
    return result;
  }

  const std::vector<cv::Mat> grey = grey_planes(frames, roi);
  const std::size_t count = static_cast<std::size_t>(roi.area());
  const BlockPixels pixels =
      group_by_block(sequence, read_codes(sequence, grey, count, result), roi, count, result);

  const std::size_t blocks = pixels.first.size() - 1;
  const int min_pixels = std::max(1, sequence.settings().min_pixels_per_block);
  std::vector<Spot> spots(blocks);
  {
    std::vector<float> scratch;
    for (std::size_t b = 0; b < blocks; ++b) {
      spots[b] = find_spot(pixels.grouped.data() + pixels.first[b],
                           pixels.first[b + 1] - pixels.first[b], min_pixels, scratch);
    }
  }
  const std::vector<Eigen::Vector3d> sums = coverage_sums(sequence, grey, pixels, spots);
  keep_whole_blocks(sequence, roi, pixels, spots, sums, result);
  return result;
}

}  // namespace projtour::light
