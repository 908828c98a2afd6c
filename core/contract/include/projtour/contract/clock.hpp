#pragma once
// Mission time. Behaviours read time only from here, so a dry run may run faster than real time.

namespace projtour {

class Clock {
 public:
  virtual ~Clock();
  // Seconds since the mission started.
  virtual double now_s() const = 0;
};

// A clock the executor advances one tick at a time.
class SteppedClock : public Clock {
 public:
  double now_s() const override { return now_s_; }
  void advance(double dt_s) { now_s_ += dt_s; }
  void set(double t_s) { now_s_ = t_s; }

 private:
  double now_s_ = 0.0;
};

}  // namespace projtour
