// make_thin_walls THICK.png THIN.png: the same walls one pixel thick (maps/SOURCE.md). A pixel
// that is not free (205 or darker: above map_server's free_thresh of 0.196) and touches a free
// pixel (8-neighbour) becomes 0, occupied; every other pixel that is not free becomes 128,
// unknown. What a laser saw of a wall is its face; the rest is a cleaned-up drawing.
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: make_thin_walls THICK.png THIN.png\n");
    return 2;
  }
  const cv::Mat thick = cv::imread(argv[1], cv::IMREAD_GRAYSCALE);
  if (thick.empty()) {
    std::fprintf(stderr, "make_thin_walls: %s: cannot read\n", argv[1]);
    return 2;
  }
  constexpr int kFreeAbove = 205;
  const cv::Mat free_mask = thick > kFreeAbove;
  cv::Mat near_free;
  cv::dilate(free_mask, near_free, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  cv::Mat thin = thick.clone();
  for (int y = 0; y < thick.rows; ++y) {
    for (int x = 0; x < thick.cols; ++x) {
      if (free_mask.at<unsigned char>(y, x)) continue;
      thin.at<unsigned char>(y, x) = near_free.at<unsigned char>(y, x) ? 0 : 128;
    }
  }
  if (!cv::imwrite(argv[2], thin)) {
    std::fprintf(stderr, "make_thin_walls: %s: cannot write\n", argv[2]);
    return 1;
  }
  return 0;
}
