#pragma once
// The proof image a run stores with a showing (history_recorder.cpp). Apart from history.hpp:
// it needs OpenCV, which `projtour history` does not.
#include <filesystem>
#include <vector>

namespace projtour {

// A small JPEG (`width_px` wide) of a picture file: the colour camera's view of the check with
// the observed corners marked (verify's camera_view.png). Empty when the file cannot be read.
std::vector<unsigned char> proof_jpeg_from(const std::filesystem::path& picture,
                                           int width_px = 320);

}  // namespace projtour
