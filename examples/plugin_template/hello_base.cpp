// A driver plugin: `hello_base`, a BaseDriver that integrates its own velocity commands into
// odometry (a robot with perfect wheels). A real base's plugin has the same shape: take
// command_velocity() to the motors, read the encoders in update(), stop in safe_stop().
#include <projtour/contract/plugin_author.hpp>

#include <algorithm>
#include <cmath>

namespace {

class HelloBase : public projtour::BaseDriver {
 public:
  HelloBase(const projtour::Params& params, const projtour::RunContext&)
      : max_speed_mps_(params.number("max_speed_mps")) {}

  void command_velocity(double v_mps, double w_radps) override {
    v_mps_ = std::clamp(v_mps, -max_speed_mps_, max_speed_mps_);
    w_radps_ = w_radps;
  }

  projtour::Odometry odometry() const override { return odometry_; }

  // Mission time: the executor calls this once a tick, so the base advances with the tour.
  void update(double t_s) override {
    const double dt_s = std::max(0.0, t_s - odometry_.t_s);
    projtour::Pose2D& p = odometry_.pose;
    p.x_m += v_mps_ * std::cos(p.yaw_rad) * dt_s;
    p.y_m += v_mps_ * std::sin(p.yaw_rad) * dt_s;
    p.yaw_rad = projtour::wrap_angle_rad(p.yaw_rad + w_radps_ * dt_s);
    odometry_.t_s = t_s;
    odometry_.v_mps = v_mps_;
    odometry_.w_radps = w_radps_;
  }

  // Must never throw, and may come at any time: the base stops.
  void safe_stop() override {
    v_mps_ = 0.0;
    w_radps_ = 0.0;
  }

 private:
  double max_speed_mps_;
  double v_mps_ = 0.0;
  double w_radps_ = 0.0;
  projtour::Odometry odometry_;
};

const projtour_param_desc kParams[] = {
    {"max_speed_mps", "number", "0.5", "commands faster than this are clamped"},
};

const projtour_kind_desc kKinds[] = {
    projtour::driver_kind<HelloBase>("hello_base", "base",
                                     "integrates its velocity commands into odometry", kParams),
};

}  // namespace

PROJTOUR_PLUGIN("hello_base", "1.0.0", kKinds)
