#pragma once
// A target's content: a still image, or a video played by mission time (looping).
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

namespace projtour {

class ContentSource {
 public:
  // Throws std::runtime_error naming the file when neither an image nor a video opens.
  explicit ContentSource(const std::filesystem::path& file);

  bool is_video() const { return video_.isOpened(); }
  cv::Size size() const { return first_.size(); }
  // The frame to show `elapsed_s` after the start, and whether it differs from the previous
  // call's (a still image changes only on the first call).
  const cv::Mat& frame_at(double elapsed_s, bool* changed);

 private:
  std::filesystem::path file_;
  cv::VideoCapture video_;
  double fps_ = 25.0;
  long long frame_count_ = 0;  // 0 = unknown until the end is hit
  long long index_ = -1;       // index of `current_`
  long long shown_ = -1;
  cv::Mat first_, current_;
};

}  // namespace projtour
