// The load cell's sliding window (see load_filter.hpp for why).
#include "runout/engine/load_filter.hpp"

#include <algorithm>
#include <stdexcept>

namespace runout {

LoadFilter::LoadFilter(real window, real min_wetted_area) : window_(window), min_area_(min_wetted_area) {
  if (!(window > 0)) throw std::invalid_argument("load filter: the window must be > 0 s");
  if (!(min_wetted_area >= 0)) throw std::invalid_argument("load filter: the minimum wetted area must be >= 0");
}

LoadFilter::Cumulative LoadFilter::at(real t) const {
  if (history_.empty() || t < history_.front().t) return {t, 0, 0};  // unloaded before the first evaluation
  auto hi = std::lower_bound(history_.begin(), history_.end(), t,
                             [](const Cumulative& c, real x) { return c.t < x; });
  if (hi == history_.end()) return history_.back();
  if (hi == history_.begin() || hi->t == t) return *hi;
  const Cumulative& lo = *(hi - 1);
  const real u = (t - lo.t) / (hi->t - lo.t);
  return {t, lo.impulse + u * (hi->impulse - lo.impulse), lo.area_time + u * (hi->area_time - lo.area_time)};
}

void LoadFilter::add(real t, real force, real wetted_area) {
  peak_instant_ = std::max(peak_instant_, force);
  if (!started_) {
    // The first value stands for itself only: nothing before it was measured, and the run starts unloaded.
    started_ = true;
    latest_t_ = t;
    history_.push_back({t, 0, 0});
  } else {
    if (t < latest_t_) throw std::invalid_argument("load filter: time went backwards");
    if (t == latest_t_) return;
    const Cumulative& last = history_.back();
    history_.push_back({t, last.impulse + force * (t - last.t), last.area_time + wetted_area * (t - last.t)});
    latest_t_ = t;
  }
  // Keep one point at or before the window's start so the integral there can be interpolated.
  while (history_.size() > 2 && history_[1].t <= latest_t_ - window_) history_.pop_front();
  const Cumulative now = history_.back(), start = at(latest_t_ - window_);
  reading_.force = (now.impulse - start.impulse) / window_;
  reading_.wetted_area = (now.area_time - start.area_time) / window_;
  reading_.mean_pressure =
      reading_.wetted_area > 0 && reading_.wetted_area >= min_area_ ? reading_.force / reading_.wetted_area : 0;
  const real centre = latest_t_ - 0.5 * window_;
  if (reading_.force > peak_force_) peak_force_ = reading_.force, peak_force_time_ = centre;
  if (reading_.mean_pressure > peak_pressure_) peak_pressure_ = reading_.mean_pressure, peak_pressure_time_ = centre;
}

void LoadFilter::save_state(StateWriter& out) const {
  out.label("load_filter");
  out.value(window_), out.value(min_area_);
  out.value<uint64_t>(history_.size());
  for (const Cumulative& c : history_) out.value(c.t), out.value(c.impulse), out.value(c.area_time);
  out.value(latest_t_), out.value(started_);
  out.value(reading_.force), out.value(reading_.wetted_area), out.value(reading_.mean_pressure);
  out.value(peak_force_), out.value(peak_force_time_), out.value(peak_pressure_), out.value(peak_pressure_time_);
  out.value(peak_instant_);
}

void LoadFilter::load_state(StateReader& in) {
  in.expect("load_filter");
  in.value(window_), in.value(min_area_);
  if (!(window_ > 0) || !(min_area_ >= 0)) in.fail("holds a window or minimum area out of range");
  const auto n = in.value<uint64_t>();
  if (n > (uint64_t{1} << 32)) in.fail("holds an impossible length");
  history_.clear();
  for (uint64_t k = 0; k < n; ++k) {
    Cumulative c;
    in.value(c.t), in.value(c.impulse), in.value(c.area_time);
    history_.push_back(c);
  }
  in.value(latest_t_), in.value(started_);
  in.value(reading_.force), in.value(reading_.wetted_area), in.value(reading_.mean_pressure);
  in.value(peak_force_), in.value(peak_force_time_), in.value(peak_pressure_), in.value(peak_pressure_time_);
  in.value(peak_instant_);
}

}  // namespace runout
