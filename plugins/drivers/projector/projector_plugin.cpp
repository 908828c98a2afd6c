// Projector drivers. Both keep the projector's frame size from the robot file, so blank() can
// show black without having seen a frame.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "projtour/contract/plugin_author.hpp"
#include "projtour/contract/run_image.hpp"

namespace projtour {
namespace {

cv::Size projector_size(const RunContext& run) {
  if (run.mission != nullptr && run.mission->robot.projector.intrinsics.width > 0) {
    const PinholeModel& m = run.mission->robot.projector.intrinsics;
    return {m.width, m.height};
  }
  return {1280, 800};
}

void check_frame(const cv::Mat& frame, const cv::Size& expected, const char* driver) {
  if (frame.empty() || frame.type() != CV_8UC3) {
    throw DriverError(std::string("projector ") + driver + ": frame must be a non-empty BGR image");
  }
  if (frame.size() != expected) {
    std::ostringstream s;
    s << "projector " << driver << ": frame is " << frame.cols << "x" << frame.rows
      << ", the projector is " << expected.width << "x" << expected.height;
    throw DriverError(s.str());
  }
}

// Every shown frame becomes run_dir/projector/frame_NNNNNN.png; index.csv lists each show and
// blank with its mission time, so a headless run can be replayed and checked.
class FilesProjector : public ProjectorDriver {
 public:
  FilesProjector(const Params& params, const RunContext& run) : size_(projector_size(run)) {
    dir_ = params.string("dir").empty() ? run.run_dir / "projector"
                                        : std::filesystem::path(params.string("dir"));
    if (dir_.empty() || dir_ == "projector") {
      throw DriverError("projector files: no run directory and no `dir` parameter");
    }
    // A resumed run continues the index and the frame numbers: nothing of the first part is
    // overwritten.
    try {
      make_run_directory(dir_);
      const bool fresh = !std::filesystem::exists(dir_ / "index.csv");
      index_ = AppendOnlyFile(dir_ / "index.csv");
      if (fresh) index_.append("t_s,event,file\n");
    } catch (const std::exception& e) {
      throw DriverError(std::string("projector files: ") + e.what());
    }
    std::error_code ec;
    for (std::filesystem::directory_iterator it(dir_, ec), end; !ec && it != end;
         it.increment(ec)) {
      const std::string name = it->path().filename().string();
      long n = 0;
      if (std::sscanf(name.c_str(), "frame_%ld.png", &n) == 1) frames_ = std::max(frames_, n);
    }
  }

  void update(double t_s) override { t_s_ = t_s; }

  void show(const cv::Mat& frame_bgr) override {
    check_frame(frame_bgr, size_, "files");
    std::ostringstream name;
    name << "frame_" << std::setw(6) << std::setfill('0') << ++frames_ << ".png";
    const std::filesystem::path file = dir_ / name.str();
    try {
      write_run_image(file, frame_bgr);
      index_.append(time_text() + ",show," + name.str() + "\n");
    } catch (const std::exception& e) {
      throw DriverError(std::string("projector files: ") + e.what());
    }
    blank_ = false;
  }

  void blank() override {
    if (!blank_) index_.append(time_text() + ",blank,\n");
    blank_ = true;
  }
  bool is_blank() const override { return blank_; }
  void safe_stop() override {
    try {
      blank();
    } catch (...) {  // safe_stop must not throw; the index is best effort here
    }
  }

 private:
  cv::Size size_;
  std::filesystem::path dir_;
  // The mission time as the index always wrote it (an ostream's default 6 significant digits).
  std::string time_text() const {
    std::ostringstream t;
    t << t_s_;
    return t.str();
  }
  AppendOnlyFile index_;
  long frames_ = 0;
  double t_s_ = 0.0;
  bool blank_ = true;
};

// A borderless full-screen window placed on the projector's screen. HighGUI cannot enumerate
// screens, so the window is moved to the screen's left edge (screen * width unless
// screen_offset_x says otherwise) before going full screen there.
class DisplayProjector : public ProjectorDriver {
 public:
  DisplayProjector(const Params& params, const RunContext& run)
      : size_(projector_size(run)), window_(params.string("window")) {
    const char* display = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    if ((display == nullptr || *display == '\0') && (wayland == nullptr || *wayland == '\0')) {
      throw DriverError(
          "projector display: no display ($DISPLAY is unset); run with a display or use the "
          "`files` projector driver for headless runs");
    }
    const long long screen = params.integer("screen");
    long long offset_x = params.integer("screen_offset_x");
    if (offset_x < 0) offset_x = screen * size_.width;
    try {
      cv::namedWindow(window_, cv::WINDOW_NORMAL | cv::WINDOW_GUI_NORMAL);
      cv::moveWindow(window_, static_cast<int>(offset_x), 0);
      cv::setWindowProperty(window_, cv::WND_PROP_FULLSCREEN, cv::WINDOW_FULLSCREEN);
    } catch (const cv::Exception& e) {
      throw DriverError("projector display: cannot open a window on screen " +
                        std::to_string(screen) + ": " + e.what());
    }
    black_ = cv::Mat::zeros(size_, CV_8UC3);
    blank();
  }
  ~DisplayProjector() override {
    try {
      cv::destroyWindow(window_);
    } catch (...) {
    }
  }

  void show(const cv::Mat& frame_bgr) override {
    check_frame(frame_bgr, size_, "display");
    present(frame_bgr);
    blank_ = false;
  }
  void blank() override {
    present(black_);
    blank_ = true;
  }
  bool is_blank() const override { return blank_; }
  void safe_stop() override {
    try {
      blank();
    } catch (...) {
    }
  }

 private:
  void present(const cv::Mat& frame) {
    try {
      cv::imshow(window_, frame);
      cv::waitKey(1);  // lets HighGUI paint
    } catch (const cv::Exception& e) {
      throw DriverError(std::string("projector display: ") + e.what());
    }
  }

  cv::Size size_;
  std::string window_;
  cv::Mat black_;
  bool blank_ = true;
};

const projtour_param_desc kFilesParams[] = {
    {"dir", "string", "", "directory for the frames; empty = <run_dir>/projector"}};
const projtour_param_desc kDisplayParams[] = {
    {"screen", "integer", "0", "index of the screen the projector is (0 = primary)"},
    {"screen_offset_x", "integer", "-1",
     "x of that screen's left edge in the desktop; -1 = screen * projector width"},
    {"window", "string", "projtour projector", "window title"}};

const projtour_kind_desc kKinds[] = {
    driver_kind<FilesProjector>("files", "projector",
                                "writes every shown frame as PNG into the run directory",
                                kFilesParams),
    driver_kind<DisplayProjector>("display", "projector",
                                  "full-screen OpenCV window on the projector's screen",
                                  kDisplayParams)};

}  // namespace
}  // namespace projtour

PROJTOUR_PLUGIN("projector", "1.0.0", projtour::kKinds)
