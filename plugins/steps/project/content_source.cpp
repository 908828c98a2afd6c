#include "content_source.hpp"

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace projtour {

ContentSource::ContentSource(const std::filesystem::path& file) : file_(file) {
  if (!std::filesystem::exists(file)) {
    throw std::runtime_error("content " + file.string() + " does not exist");
  }
  first_ = cv::imread(file.string(), cv::IMREAD_COLOR);
  if (first_.empty()) {
    video_.open(file.string());
    if (!video_.isOpened() || !video_.read(first_) || first_.empty()) {
      video_.release();
      throw std::runtime_error("content " + file.string() +
                               " is neither an image nor a video OpenCV can read");
    }
    const double fps = video_.get(cv::CAP_PROP_FPS);
    if (fps > 0 && std::isfinite(fps)) fps_ = fps;
    const double count = video_.get(cv::CAP_PROP_FRAME_COUNT);
    if (count >= 1) frame_count_ = static_cast<long long>(count);
    index_ = 0;
  }
  if (first_.cols < 2 || first_.rows < 2) {
    throw std::runtime_error("content " + file.string() + " is smaller than 2x2 pixels");
  }
  current_ = first_;
  if (!is_video()) index_ = 0;
}

const cv::Mat& ContentSource::frame_at(double elapsed_s, bool* changed) {
  long long wanted = is_video() ? static_cast<long long>(std::floor(elapsed_s * fps_)) : 0;
  if (frame_count_ > 0) wanted %= frame_count_;
  if (is_video() && wanted != index_) {
    if (wanted < index_) {  // looped: back to the first frame
      video_.set(cv::CAP_PROP_POS_FRAMES, 1);
      current_ = first_;
      index_ = 0;
    }
    cv::Mat next;
    while (index_ < wanted) {
      if (!video_.read(next) || next.empty()) {
        // The end came before the frame count said (or it was unknown): loop from here on.
        frame_count_ = index_ + 1;
        return frame_at(elapsed_s, changed);
      }
      ++index_;
    }
    if (!next.empty()) {
      if (next.size() != first_.size()) {
        cv::resize(next, current_, first_.size());
      } else {
        current_ = next;
      }
    }
  }
  if (changed != nullptr) *changed = index_ != shown_;
  shown_ = index_;
  return current_;
}

}  // namespace projtour
