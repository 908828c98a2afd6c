// The mrpt_sensor laser driver: an absent device is a clear error naming it.
#include <gtest/gtest.h>

#include <fstream>

#include "projtour/host/params_reader.hpp"
#include "projtour/host/plugin_loader.hpp"
#include "projtour_test/run_rig.hpp"
#include "projtour_test/temp_dir.hpp"

namespace projtour {
namespace {

TEST(MrptSensor, AbsentSerialDeviceIsAnErrorNamingThePort) {
  const test::TempDir scratch;
  const auto dir = scratch.path();
  const auto ini = dir / "laser.ini";
  std::ofstream(ini) << "[LASER_2D]\ndriver = CHokuyoURG\nprocess_rate = 10\n"
                        "sensorLabel = HOKUYO\nCOM_port_LIN = /dev/ttyProjtourAbsent0\n";
  host::PluginRegistry registry;
  registry.load_library(PROJTOUR_PLUGIN_BUILD_DIR "/libprojtour_mrpt_sensor.so");
  Params params = host::default_params(registry.require("mrpt_sensor").params);
  params.set("ini", ini.string());
  const test::RunRig rig{test::RunRig::RunDir::none};
  try {
    registry.create_driver("mrpt_sensor", params, rig.run);
    FAIL() << "expected the driver to fail without a device";
  } catch (const host::PluginError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("/dev/ttyProjtourAbsent0"), std::string::npos) << message;
    EXPECT_NE(message.find("mrpt_sensor: cannot open CHokuyoURG (COM_port_LIN = "
                           "/dev/ttyProjtourAbsent0) from [LASER_2D] of " +
                           ini.string() +
                           ": Error trying to open the serial port /dev/ttyProjtourAbsent0"),
              std::string::npos)
        << message;
  }
}

TEST(MrptSensor, UnknownDriverAndMissingIniAreErrors) {
  host::PluginRegistry registry;
  registry.load_library(PROJTOUR_PLUGIN_BUILD_DIR "/libprojtour_mrpt_sensor.so");
  Params params = host::default_params(registry.require("mrpt_sensor").params);
  params.set("ini", std::string("/nonexistent/laser.ini"));
  const test::RunRig rig{test::RunRig::RunDir::none};
  try {
    registry.create_driver("mrpt_sensor", params, rig.run);
    FAIL();
  } catch (const host::PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("ini file /nonexistent/laser.ini not found"),
              std::string::npos)
        << e.what();
  }
  const test::TempDir scratch;
  const auto dir = scratch.path();
  std::ofstream(dir / "l.ini") << "[LASER_2D]\ndriver = CNoSuchScanner\n";
  params.set("ini", (dir / "l.ini").string());
  try {
    registry.create_driver("mrpt_sensor", params, rig.run);
    FAIL();
  } catch (const host::PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown MRPT sensor driver \"CNoSuchScanner\""),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace projtour
