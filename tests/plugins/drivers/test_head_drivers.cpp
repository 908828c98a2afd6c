#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "projtour/contract/drivers.hpp"
#include "projtour/host/params_reader.hpp"
#include "projtour_test/geometry_rig.hpp"
#include "projtour_test/scoped_state.hpp"

using namespace projtour;
using namespace projtour::geometry_test;

namespace {

std::shared_ptr<Driver> make_driver(Rig& rig, const std::string& kind,
                                    const std::map<std::string, ParamValue>& overrides = {}) {
  const host::KindInfo& info = rig.registry.require(kind);
  auto p = std::make_unique<Params>(host::default_params(info.params));
  for (const auto& [name, value] : overrides) p->set(name, value);
  auto d = rig.registry.create_driver(kind, *p, rig.run_ctx);
  rig.params_keep.push_back(std::move(p));
  return d;
}

std::string read_file(const std::filesystem::path& f) {
  std::ifstream in(f);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

TEST(FilesProjector, WritesEveryFrameAndRecordsBlanks) {
  Rig rig;
  auto driver = std::dynamic_pointer_cast<ProjectorDriver>(make_driver(rig, "files"));
  ASSERT_TRUE(driver);
  EXPECT_TRUE(driver->is_blank());
  cv::Mat frame(800, 1280, CV_8UC3, cv::Scalar(10, 20, 30));
  driver->update(1.5);
  driver->show(frame);
  EXPECT_FALSE(driver->is_blank());
  frame.setTo(cv::Scalar(200, 100, 0));
  driver->update(1.6);
  driver->show(frame);
  driver->update(2.0);
  driver->blank();
  driver->safe_stop();  // already blank: no second entry
  EXPECT_TRUE(driver->is_blank());
  const auto dir = rig.dir / "projector";
  const cv::Mat first = cv::imread((dir / "frame_000001.png").string());
  const cv::Mat second = cv::imread((dir / "frame_000002.png").string());
  ASSERT_FALSE(first.empty());
  ASSERT_FALSE(second.empty());
  EXPECT_EQ(first.at<cv::Vec3b>(400, 640), cv::Vec3b(10, 20, 30));
  EXPECT_EQ(second.at<cv::Vec3b>(0, 0), cv::Vec3b(200, 100, 0));
  EXPECT_EQ(read_file(dir / "index.csv"),
            "t_s,event,file\n1.5,show,frame_000001.png\n1.6,show,frame_000002.png\n2,blank,\n");
  EXPECT_THROW(driver->show(cv::Mat::zeros(10, 10, CV_8UC3)), DriverError);
}

TEST(DisplayProjector, FailsClearlyWithoutADisplay) {
  Rig rig;
  const test::ScopedEnv no_display("DISPLAY", nullptr);
  const test::ScopedEnv no_wayland("WAYLAND_DISPLAY", nullptr);
  try {
    make_driver(rig, "display", {{"screen", 1LL}});
    ADD_FAILURE() << "display driver created without a display";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("$DISPLAY"), std::string::npos) << e.what();
  }
}

TEST(PtuDPerception, AbsentPortIsNamedInTheError) {
  Rig rig;
  const std::string port = "/dev/ttyUSB_projtour_absent";
  try {
    make_driver(rig, "ptu_dperception", {{"port", port}});
    ADD_FAILURE() << "created a PTU driver on a port that does not exist";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(port), std::string::npos) << e.what();
  }
}

TEST(PtuDPerception, SignsMustBeUnit) {
  Rig rig;
  const host::KindInfo& info = rig.registry.require("ptu_dperception");
  Params p = host::default_params(info.params);
  p.set("tilt_sign", 2.0);
  EXPECT_NE(rig.registry.validate_params("ptu_dperception", p), "");
}
