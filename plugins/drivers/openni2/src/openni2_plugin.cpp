// The openni2 plugin: depth (`openni2`) and colour (`openni2_colour`) of OpenNI2 devices.
#include "openni2_device.hpp"
#include "projtour/contract/plugin_author.hpp"

namespace projtour::openni2 {
namespace {

const projtour_kind_desc kKinds[] = {depth_kind(), colour_kind()};

}  // namespace
}  // namespace projtour::openni2

PROJTOUR_PLUGIN("openni2", "1.1.0", projtour::openni2::kKinds)
