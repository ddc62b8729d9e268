#pragma once
// A structure's load as a load cell and a design guideline read it. An SPH force on a wall is a sum over the
// particles within a kernel support of it: each particle that enters or leaves adds a jump, so the
// instantaneous force carries a noise whose period is about dp / v and whose peaks are events of a few
// particles (the flume's one-sample 1.2e5 Pa "peak pressure"). A load cell averages over its own response time;
// a guideline's design pressure is a force over the loaded face, not over one particle's area. So:
//   - the force is the mean over a sliding window of duration `window` (a causal boxcar; the structure is
//     unloaded before the run starts), of the instantaneous values held over the interval each closes;
//   - the wetted area is averaged the same way, and the mean pressure is the window's mean force over its mean
//     wetted area, counted only while that area is at least `min_wetted_area`.
// Peaks of these filtered values are the design values; the largest instantaneous force is kept as a diagnostic.
#include <deque>

#include "runout/engine/state_io.hpp"
#include "runout/engine/types.hpp"

namespace runout {

struct LoadReading {
  real force = 0;          // window mean [N, N/m in 2D]
  real wetted_area = 0;    // window mean [m2, m in 2D]
  real mean_pressure = 0;  // force / wetted_area, 0 while the area is under the minimum [Pa]
};

class LoadFilter {
 public:
  // window > 0 [s]; min_wetted_area >= 0.
  LoadFilter(real window, real min_wetted_area);

  // One instantaneous evaluation at time t (non-decreasing); it stands for the interval since the previous one.
  void add(real t, real force, real wetted_area);
  // The window's mean ending at the latest evaluation.
  const LoadReading& reading() const { return reading_; }

  real window() const { return window_; }
  real min_wetted_area() const { return min_area_; }
  real latest_time() const { return latest_t_; }
  // Peaks of the filtered force and mean pressure, timed at the centre of their window.
  real peak_force() const { return peak_force_; }
  real time_of_peak_force() const { return peak_force_time_; }
  real peak_mean_pressure() const { return peak_pressure_; }
  real time_of_peak_pressure() const { return peak_pressure_time_; }
  // The largest instantaneous force added (diagnostic: what an unfiltered reading would report).
  real peak_instant_force() const { return peak_instant_; }

  // Everything, the window and minimum area included: a monitor may have derived them from the flow at its
  // start, which a resumed run no longer has.
  void save_state(StateWriter& out) const;
  void load_state(StateReader& in);

 private:
  struct Cumulative {
    real t, impulse, area_time;  // time integrals of force and area since the start
  };
  // The integrals at time t (linear between stored points: the values are constant over each interval).
  Cumulative at(real t) const;

  real window_, min_area_;
  std::deque<Cumulative> history_;  // covers at least [latest - window, latest]
  real latest_t_ = 0;
  bool started_ = false;
  LoadReading reading_;
  real peak_force_ = 0, peak_force_time_ = 0, peak_pressure_ = 0, peak_pressure_time_ = 0, peak_instant_ = 0;
};

}  // namespace runout
