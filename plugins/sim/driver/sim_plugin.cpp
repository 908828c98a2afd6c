// The plugin's descriptor: six simulated drivers sharing one world per run.
#include "projtour/contract/plugin_author.hpp"
#include "projtour_sim/sim_drivers.hpp"

namespace {

using namespace projtour;
using namespace projtour::sim;

const projtour_param_desc kBaseParams[] = {
    {"velocity_time_constant_s", "number", "0.1",
     "first-order lag of the wheels' response to a velocity command"}};
const projtour_param_desc kLaserParams[] = {
    {"occupancy_threshold", "number", "0.6",
     "cells less free than this stop a ray (rate, field of view, rays: robot file)"}};
const projtour_param_desc kPanTiltParams[] = {
    {"settle_s", "number", "0.1", "time at rest within tolerance before reached() holds"}};
const projtour_param_desc kCameraParams[] = {
    {"max_incidence_deg", "number", "75",
     "surfaces seen more obliquely give no depth (intrinsics, range, rate: robot file)"}};
const projtour_param_desc kColourCameraParams[] = {
    {"room_lux", "number", "300",
     "room light: illuminance on a level surface from above (a wall or a target gets half)"},
    {"lamp_lumens", "number", "300",
     "the projector's output for an all-white frame (about 4x a target's room light at 1.4 m)"},
    {"noise", "number", "1",
     "scale of the sensor's shot and read noise (0 = noise-free; intrinsics, rate: robot file)"},
    {"blur_px", "number", "0.6", "defocus blur, Gaussian sigma in pixels (0 = sharp)"}};
const projtour_param_desc kProjectorParams[] = {
    {"log_file", "string", "sim_projector_log.jsonl",
     "every show/blank with the time and what moved, in the run directory (\"\" = none)"}};

const projtour_kind_desc kKinds[] = {
    driver_kind<SimBase>("sim_base", "base",
                         "differential drive (MRPT's simulator) with odometry drift and a bumper",
                         kBaseParams),
    driver_kind<SimLaser>("sim_laser", "laser",
                          "MRPT's scan simulator on the map from the true pose, with range noise",
                          kLaserParams),
    driver_kind<SimPanTilt>("sim_pan_tilt", "pan_tilt",
                            "rate-limited pan and tilt with encoder noise", kPanTiltParams),
    driver_kind<SimDepthCamera>("sim_depth_camera", "depth_camera",
                                "ray-cast 640x480 depth with the Kinect-v1 noise model",
                                kCameraParams),
    driver_kind<SimColourCamera>(
        "sim_colour_camera", "colour_camera",
        "ray-traced colour view: room light plus the projector's light and shadows, with noise",
        kColourCameraParams),
    driver_kind<SimProjector>("sim_projector", "projector",
                              "records what is shown, when, and whether anything moved",
                              kProjectorParams),
};

}  // namespace

PROJTOUR_PLUGIN("sim", "1.0.0", kKinds)
