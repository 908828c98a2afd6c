// The Gray-code sequence (layout, OpenCV's bit convention, the mask) and its decoding, on the
// projector's own frames and on the sign and the pillar rendered with the colour camera's lens,
// blur and noise, with shadows and a mask.
#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <opencv2/structured_light/graycodepattern.hpp>

#include "light_scene.hpp"
#include "projtour/light/gray_code.hpp"

namespace projtour {
namespace {

using light::BlockCorrespondence;
using light::decode;
using light::DecodeResult;
using light::GrayCodeSequence;
using light::GrayCodeSettings;

// The projector's frames as if a camera saw them pixel for pixel.
ColourFrame as_colour_frame(const cv::Mat& bgr) {
  ColourFrame f;
  f.width = bgr.cols;
  f.height = bgr.rows;
  f.bgr.assign(bgr.datastart, bgr.dataend);
  return f;
}

TEST(GrayCodeSequence, LayoutForTheRobotProjector) {
  const test::LightRig rig = test::default_rig();
  const GrayCodeSequence s(rig.projector, GrayCodeSettings{});
  EXPECT_EQ(s.block_columns(), 80);
  EXPECT_EQ(s.block_rows(), 50);
  EXPECT_EQ(s.column_bits(), 7);
  EXPECT_EQ(s.row_bits(), 6);
  EXPECT_EQ(s.size(), 28);  // StructuredLightSpec's 2 * (7 + 6) + 2
  EXPECT_EQ(s.block_centre_px(0, 0), Eigen::Vector2d(7.5, 7.5));
  EXPECT_EQ(s.block_centre_px(79, 49), Eigen::Vector2d(1271.5, 791.5));

  for (int i = 0; i < s.size(); ++i) {
    const cv::Mat f = s.frame(i);
    ASSERT_EQ(f.type(), CV_8UC3);
    ASSERT_EQ(f.size(), cv::Size(1280, 800));
    cv::Mat grey;
    cv::cvtColor(f, grey, cv::COLOR_BGR2GRAY);
    // Black and white only, constant over each block.
    for (int r = 0; r < s.block_rows(); ++r) {
      for (int c = 0; c < s.block_columns(); ++c) {
        const cv::Mat block = grey(cv::Rect(c * 16, r * 16, 16, 16));
        double lo, hi;
        cv::minMaxLoc(block, &lo, &hi);
        ASSERT_EQ(lo, hi) << "frame " << i << " block " << c << "," << r;
        ASSERT_TRUE(lo == 0.0 || lo == 255.0);
      }
    }
    if (i == 0) {
      EXPECT_EQ(cv::countNonZero(grey), 1280 * 800);
    }
    if (i == 1) {
      EXPECT_EQ(cv::countNonZero(grey), 0);
    }
    if (i >= 2 && i % 2 == 1) {
      // The inverse of the frame before it.
      cv::Mat previous;
      cv::cvtColor(s.frame(i - 1), previous, cv::COLOR_BGR2GRAY);
      EXPECT_EQ(cv::countNonZero(previous + grey != 255), 0) << "frame " << i;
    }
  }
  EXPECT_THROW(s.frame(28), std::out_of_range);
}

TEST(GrayCodeSequence, BlocksCutByTheProjectorEdge) {
  PinholeModel p = test::default_rig().projector;
  p.width = 1000;  // 62.5 blocks
  p.height = 700;  // 43.75 blocks
  const GrayCodeSequence s(p, GrayCodeSettings{});
  EXPECT_EQ(s.block_columns(), 63);
  EXPECT_EQ(s.block_rows(), 44);
  EXPECT_EQ(s.size(), 2 + 2 * (6 + 6));
  EXPECT_EQ(s.block_centre_px(62, 43), Eigen::Vector2d(995.5, 693.5));
  EXPECT_EQ(s.frame(5).size(), cv::Size(1000, 700));
}

TEST(GrayCodeSequence, MaskBlacksOutEveryFrame) {
  const test::LightRig rig = test::default_rig();
  const GrayCodeSequence s(rig.projector, GrayCodeSettings{});
  cv::Mat mask = cv::Mat::zeros(800, 1280, CV_8U);
  cv::circle(mask, cv::Point(600, 380), 200, cv::Scalar(255), cv::FILLED);
  for (int i = 0; i < s.size(); ++i) {
    cv::Mat grey, plain;
    cv::cvtColor(s.frame(i, mask), grey, cv::COLOR_BGR2GRAY);
    cv::cvtColor(s.frame(i), plain, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(cv::countNonZero(grey & ~mask), 0) << "frame " << i;
    EXPECT_EQ(cv::countNonZero((grey != plain) & mask), 0) << "frame " << i;
  }
  EXPECT_THROW(s.frame(0, cv::Mat::zeros(10, 10, CV_8U)), std::invalid_argument);
}

// Seen pixel for pixel, every block decodes to exactly its own 16 x 16 pixels (but those on the
// image's border, which could be cut by it, are left out), and the codes agree with OpenCV's own
// decoder (GrayCodePattern::getProjPixel) on the block grid.
TEST(GrayCodeDecode, ProjectorFramesDecodeToEveryBlock) {
  const test::LightRig rig = test::default_rig();
  const GrayCodeSequence s(rig.projector, GrayCodeSettings{});
  std::vector<ColourFrame> frames;
  for (int i = 0; i < s.size(); ++i) frames.push_back(as_colour_frame(s.frame(i)));
  const DecodeResult r = decode(s, frames);
  ASSERT_EQ(r.problem, "");
  EXPECT_EQ(r.lit_pixels, 1280 * 800);
  EXPECT_EQ(r.decoded_pixels, 1280 * 800);
  ASSERT_EQ(r.blocks.size(), 78u * 48u);
  for (const BlockCorrespondence& b : r.blocks) {
    EXPECT_TRUE(b.column > 0 && b.row > 0 && b.column < 79 && b.row < 49);
    EXPECT_EQ(b.pixels, 256);
    EXPECT_EQ(b.projector_px, s.block_centre_px(b.column, b.row));
    EXPECT_NEAR((b.colour_px - b.projector_px).norm(), 0.0, 1e-9);
  }
  // A region of interest is a border too: of columns 6-16 and rows 6-12, which it cuts, the
  // whole ones are 7-15 and 7-11.
  const DecodeResult part = decode(s, frames, cv::Rect(100, 100, 160, 96));
  EXPECT_EQ(part.blocks.size(), 9u * 5u);

  const auto opencv = cv::structured_light::GrayCodePattern::create(80, 50);
  std::vector<cv::Mat> patterns;
  opencv->generate(patterns);
  opencv->setWhiteThreshold(1);
  std::vector<cv::Mat> ours;
  for (std::size_t k = 0; k < patterns.size(); ++k)
    ours.push_back(s.frame(static_cast<int>(k) + 2));
  for (int row = 0; row < 50; ++row) {
    for (int column = 0; column < 80; ++column) {
      cv::Point decoded;
      ASSERT_FALSE(opencv->getProjPixel(patterns, column, row, decoded));
      ASSERT_EQ(decoded, cv::Point(column, row));
      // Our frame 2 + k is OpenCV's pattern k, upscaled.
      for (std::size_t k = 0; k < patterns.size(); ++k) {
        ASSERT_EQ(ours[k].at<cv::Vec3b>(row * 16 + 5, column * 16 + 9)[1],
                  patterns[k].at<std::uint8_t>(row, column));
      }
    }
  }
}

TEST(GrayCodeDecode, Problems) {
  const test::LightRig rig = test::default_rig();
  const GrayCodeSequence s(rig.projector, GrayCodeSettings{});
  std::vector<ColourFrame> frames(3, as_colour_frame(s.frame(0)));
  EXPECT_EQ(decode(s, frames).problem, "decode: 3 frames for a sequence of 28");
  frames.assign(28, as_colour_frame(s.frame(0)));
  frames[7].width = 10;
  EXPECT_EQ(decode(s, frames).problem, "decode: the frames differ in size");
  frames[7] = frames[0];
  frames[9].bgr.pop_back();
  EXPECT_EQ(decode(s, frames).problem, "decode: a frame's pixels do not match its size");
  frames[9] = frames[0];
  EXPECT_EQ(decode(s, frames, cv::Rect(5000, 0, 10, 10)).problem,
            "decode: the region of interest is outside the image");
  // White then black, then all white: bright, but no bit has contrast.
  frames[1] = as_colour_frame(s.frame(1));
  const DecodeResult r = decode(s, frames);
  EXPECT_EQ(r.problem, "");
  EXPECT_EQ(r.lit_pixels, 1280 * 800);
  EXPECT_EQ(r.decoded_pixels, 0);
  EXPECT_TRUE(r.blocks.empty());
}

// The rendered scenes, each rendered once for the suite.
struct Rendered {
  std::unique_ptr<test::ColourRenderer> renderer;
  std::vector<ColourFrame> frames;
  cv::Rect roi;
};

const GrayCodeSequence& sequence() {
  static const GrayCodeSequence s(test::default_rig().projector, GrayCodeSettings{});
  return s;
}

const Rendered& sign() {
  static const Rendered r = [] {
    Rendered out;
    const test::Scene scene = test::sign_scene();
    out.renderer = std::make_unique<test::ColourRenderer>(test::default_rig(), scene);
    out.frames = test::render_sequence(*out.renderer, sequence());
    out.roi =
        test::colour_roi(out.renderer->rig().colour, test::rectangle_corners(scene.surfaces[0]), 6);
    return out;
  }();
  return r;
}

// Each block's colour centroid, taken back through the scene into the projector, against the
// block's centre.
struct BlockErrors {
  std::vector<double> px;  // projector pixels, per block
  double median() const {
    std::vector<double> e = px;
    std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
    return e[e.size() / 2];
  }
  double fraction_within(double limit) const {
    return static_cast<double>(
               std::count_if(px.begin(), px.end(), [&](double e) { return e <= limit; })) /
           px.size();
  }
};

BlockErrors block_errors(const test::ColourRenderer& renderer, const DecodeResult& r) {
  BlockErrors errors;
  for (const BlockCorrespondence& b : r.blocks) {
    const auto truth = renderer.projector_px_at(b.colour_px);
    errors.px.push_back(truth ? (*truth - b.projector_px).norm() : 1e9);
  }
  return errors;
}

TEST(GrayCodeDecode, RenderedSignGivesBlockCorrespondences) {
  const Rendered& r = sign();
  const DecodeResult d = decode(sequence(), r.frames, r.roi);
  ASSERT_EQ(d.problem, "");
  // The sign is ~36 x 30 blocks, less those at its rim.
  EXPECT_GT(d.blocks.size(), 900u);
  const BlockErrors e = block_errors(*r.renderer, d);
  std::printf(
      "sign: %zu blocks, %d decoded of %d lit pixels, median error %.3f projector px, "
      "%.1f%% within 2 px, %.1f%% within half a block\n",
      d.blocks.size(), d.decoded_pixels, d.lit_pixels, e.median(), 100.0 * e.fraction_within(2.0),
      100.0 * e.fraction_within(8.0));
  EXPECT_GT(e.fraction_within(8.0), 0.95);  // within half a block of the truth
  EXPECT_LT(e.median(), 1.5);
  for (const BlockCorrespondence& b : d.blocks) {
    EXPECT_TRUE(r.roi.contains(
        cv::Point(static_cast<int>(b.colour_px.x()), static_cast<int>(b.colour_px.y()))));
    EXPECT_GE(b.pixels, sequence().settings().min_pixels_per_block);
  }
  // Deterministic.
  const DecodeResult again = decode(sequence(), r.frames, r.roi);
  ASSERT_EQ(again.blocks.size(), d.blocks.size());
  for (std::size_t i = 0; i < d.blocks.size(); ++i) {
    EXPECT_EQ(again.blocks[i].colour_px, d.blocks[i].colour_px);
  }
}

TEST(GrayCodeDecode, RenderedPillar) {
  const test::Scene scene = test::pillar_scene();
  const test::ColourRenderer renderer(test::default_rig(), scene);
  const std::vector<ColourFrame> frames = test::render_sequence(renderer, sequence());
  // The pillar's front half, top to bottom of a 0.6 m band.
  std::vector<Eigen::Vector3d> corners;
  for (double x : {-0.16, 0.16}) {
    for (double y : {-0.3, 0.3}) corners.emplace_back(x, y, 1.46);
  }
  const cv::Rect roi = test::colour_roi(renderer.rig().colour, corners, 0);
  const DecodeResult d = decode(sequence(), frames, roi);
  ASSERT_EQ(d.problem, "");
  EXPECT_GT(d.blocks.size(), 1000u);
  const BlockErrors e = block_errors(renderer, d);
  std::printf("pillar: %zu blocks, median error %.3f projector px, %.1f%% within half a block\n",
              d.blocks.size(), e.median(), 100.0 * e.fraction_within(8.0));
  EXPECT_GT(e.fraction_within(8.0), 0.95);
  EXPECT_LT(e.median(), 1.5);
}

// A pole between the projector and the sign shadows a band of it, which the camera (beside the
// projector) sees unlit; a mask keeps the light to the right part of the sign. Neither the
// shadow nor the masked part decodes.
TEST(GrayCodeDecode, ShadowAndMaskAreNotDecoded) {
  test::Scene scene = test::sign_scene();
  test::add_pole(scene, 0.03, 0.9);
  const test::LightRig rig = test::default_rig();
  const test::ColourRenderer renderer(rig, scene);
  cv::Mat mask = test::projector_mask(rig, scene, 0);
  const int cut_u = 640;
  mask(cv::Rect(0, 0, cut_u, mask.rows)).setTo(0);
  const std::vector<ColourFrame> frames = test::render_sequence(renderer, sequence(), mask, 100);
  const cv::Rect roi = test::colour_roi(rig.colour, test::rectangle_corners(scene.surfaces[0]), 10);
  const DecodeResult d = decode(sequence(), frames, roi);
  ASSERT_EQ(d.problem, "");
  EXPECT_GT(d.blocks.size(), 200u);

  int shadowed = 0, on_sign = 0;
  for (const BlockCorrespondence& b : d.blocks) {
    // Nothing from the masked-off side (a block straddling the cut may light its right part).
    EXPECT_GT(b.projector_px.x(), cut_u - 8.0) << b.column << "," << b.row;
    const int u = static_cast<int>(std::lround(b.colour_px.x()));
    const int v = static_cast<int>(std::lround(b.colour_px.y()));
    EXPECT_GT(renderer.lit_fraction(u, v), 0.0) << "decoded in the shadow at " << u << "," << v;
    if (renderer.surface_at(u, v) == 0) ++on_sign;
  }
  // The shadow on the sign is really there and large: count its pixels in the roi.
  for (int v = roi.y; v < roi.br().y; ++v) {
    for (int u = roi.x; u < roi.br().x; ++u) {
      shadowed += renderer.surface_at(u, v) == 0 && renderer.lit_fraction(u, v) == 0.0;
    }
  }
  std::printf("shadow: %d shadowed sign pixels, %zu blocks (%d on the sign)\n", shadowed,
              d.blocks.size(), on_sign);
  EXPECT_GT(shadowed, 500);
  const BlockErrors e = block_errors(renderer, d);
  EXPECT_GT(e.fraction_within(8.0), 0.95);
}

}  // namespace
}  // namespace projtour
