#pragma once
// write_run_file for a picture, for the plugins and the executor that draw with OpenCV: encoded
// in memory (the format from the file's extension), then written as any run file is -- never
// through a link, a failure thrown. Header-only, so that the contract library itself keeps
// Eigen as its only dependency.
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

#include "projtour/contract/run_files.hpp"

namespace projtour {

inline void write_run_image(const std::filesystem::path& file, const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  if (image.empty() || !cv::imencode(file.extension().string(), image, bytes)) {
    throw std::runtime_error("cannot encode " + file.string() + " as " + file.extension().string());
  }
  write_run_file(file, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace projtour
