// The Gray-code sequence over projector blocks and its decoding. The patterns come from OpenCV's
// GrayCodePattern on the block grid; the decoding is done here on bit planes over the region of
// interest, which is GrayCodePattern::getProjPixel's test per pixel (pattern brighter than its
// inverse = 1, most significant bit first) without its per-pixel allocations.
#include "projtour/gray_code.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <opencv2/structured_light/graycodepattern.hpp>
#include <stdexcept>

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

// A block's camera pixels (u, v) -> its correspondence, or false when they are too few or do
// not form one compact spot. The median is robust to a minority decoded far away (a wrong bit);
// the kept radius is twice that of a disc of the block's pixel count, so a spot stretched by an
// oblique surface still passes while pixels strewn over the image do not.
bool block_centroid(std::vector<Eigen::Vector2f>& pixels, int min_pixels, Eigen::Vector2d& centroid,
                    int& kept) {
  const std::size_t n = pixels.size();
  std::vector<float> coordinate(n);
  const auto median_of = [&](int axis) {
    for (std::size_t i = 0; i < n; ++i) coordinate[i] = pixels[i][axis];
    std::nth_element(coordinate.begin(), coordinate.begin() + n / 2, coordinate.end());
    return coordinate[n / 2];
  };
  const Eigen::Vector2f median(median_of(0), median_of(1));
  const float radius = 2.0f * std::sqrt(static_cast<float>(n) / 3.14159265f) + 1.5f;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  kept = 0;
  for (const Eigen::Vector2f& p : pixels) {
    if ((p - median).squaredNorm() > radius * radius) continue;
    sum += p.cast<double>();
    ++kept;
  }
  // Without a majority in one spot the median itself is meaningless.
  if (kept < min_pixels || 2 * kept <= static_cast<int>(n)) return false;
  centroid = sum / kept;
  return true;
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

  const GrayCodeSettings& settings = sequence.settings();
  const std::vector<cv::Mat> grey = grey_planes(frames, roi);
  const std::size_t count = static_cast<std::size_t>(roi.area());

  // Per region pixel, row-major: still decodable, and the Gray codes built up bit by bit.
  std::vector<std::uint8_t> ok(count);
  std::vector<std::uint32_t> column_code(count, 0), row_code(count, 0);
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
    std::uint32_t* code = bit < column_bits ? column_code.data() : row_code.data();
    for (std::size_t i = 0; i < count; ++i) {
      const int difference = pattern[i] - inverse[i];
      code[i] = (code[i] << 1) | static_cast<std::uint32_t>(difference > 0);
      ok[i] &= std::abs(difference) >= settings.min_bit_contrast;
    }
  }

  // Each decoded pixel's block (-1 = none), then the pixels grouped by block (counting sort, so
  // each block's pixels are contiguous and in raster order).
  const int columns = sequence.block_columns(), rows = sequence.block_rows();
  const std::size_t blocks = static_cast<std::size_t>(columns) * rows;
  std::vector<std::int32_t> block_of(count, -1);
  std::vector<std::int32_t> first(blocks + 1, 0);
  for (std::size_t i = 0; i < count; ++i) {
    if (!ok[i]) continue;
    const std::uint32_t c = gray_to_binary(column_code[i]), r = gray_to_binary(row_code[i]);
    if (c >= static_cast<std::uint32_t>(columns) || r >= static_cast<std::uint32_t>(rows)) continue;
    block_of[i] = static_cast<std::int32_t>(r * columns + c);
    ++first[static_cast<std::size_t>(block_of[i]) + 1];
    ++result.decoded_pixels;
  }
  for (std::size_t b = 0; b < blocks; ++b) first[b + 1] += first[b];
  std::vector<Eigen::Vector2f> grouped(static_cast<std::size_t>(result.decoded_pixels));
  {
    std::vector<std::int32_t> next(first.begin(), first.end() - 1);
    for (std::size_t i = 0; i < count; ++i) {
      if (block_of[i] < 0) continue;
      const int u = roi.x + static_cast<int>(i % roi.width);
      const int v = roi.y + static_cast<int>(i / roi.width);
      grouped[static_cast<std::size_t>(next[static_cast<std::size_t>(block_of[i])]++)] =
          Eigen::Vector2f(static_cast<float>(u), static_cast<float>(v));
    }
  }

  std::vector<Eigen::Vector2f> pixels;
  const int min_pixels = std::max(1, settings.min_pixels_per_block);
  for (std::size_t b = 0; b < blocks; ++b) {
    const int n = first[b + 1] - first[b];
    if (n < min_pixels) continue;
    pixels.assign(grouped.begin() + first[b], grouped.begin() + first[b + 1]);
    BlockCorrespondence block;
    if (!block_centroid(pixels, min_pixels, block.colour_px, block.pixels)) continue;
    block.column = static_cast<int>(b % columns);
    block.row = static_cast<int>(b / columns);
    block.projector_px = sequence.block_centre_px(block.column, block.row);
    result.blocks.push_back(block);
  }
  return result;
}

}  // namespace projtour::light
