// The load cell's window on signals with known answers: a rectangular impulse of known force, area and
// duration (longer and shorter than the window), the unloaded start, and particle noise on a steady load.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "runout/engine/load_filter.hpp"

using namespace runout;

namespace {

constexpr real kDt = 1e-3;  // evaluation interval [s]

// F0 on area A0 for evaluations k in (k_start, k_start + k_len] (each value stands for the millisecond it closes:
// the impulse lasts exactly k_len ms), nothing before or after; evaluated every millisecond for 2 s.
LoadFilter impulse(real window, real min_area, real f0, real a0, int k_start, int k_len) {
  LoadFilter filter(window, min_area);
  for (int k = 0; k <= 2000; ++k) {
    const bool on = k > k_start && k <= k_start + k_len;
    filter.add(k * kDt, on ? f0 : 0, on ? a0 : 0);
  }
  return filter;
}

}  // namespace

TEST(LoadFilter, AnImpulseLongerThanTheWindowReadsItsForceAndPressure) {
  // 1000 N on 0.5 m2 for 0.3 s, window 0.1 s: the window fits inside the impulse, so the reading is exact.
  const LoadFilter f = impulse(0.1, 0.05, 1000, 0.5, 1000, 300);
  EXPECT_NEAR(f.peak_force(), 1000, 1e-6);
  EXPECT_NEAR(f.peak_mean_pressure(), 2000, 1e-6);
  EXPECT_NEAR(f.peak_instant_force(), 1000, 1e-9);
  // The peak is timed at its window's centre: the timing is known to within the window.
  EXPECT_GE(f.time_of_peak_force(), 1.0 + 0.05 - 1e-9);
  EXPECT_LE(f.time_of_peak_force(), 1.3 - 0.05 + 1e-9);
  EXPECT_NEAR(f.reading().force, 0, 1e-9);  // long after the impulse
}

TEST(LoadFilter, AnImpulseShorterThanTheWindowIsSpreadOverIt) {
  // 20 ms of 1000 N in a 0.1 s window: the cell reads the impulse over the window, 1000 x 0.02 / 0.1 = 200 N;
  // the mean area is 0.5 x 0.2 = 0.1 m2, so the mean pressure stays 1000 / 0.5 = 2000 Pa.
  const LoadFilter f = impulse(0.1, 0.05, 1000, 0.5, 1000, 20);
  EXPECT_NEAR(f.peak_force(), 200, 1e-6);
  EXPECT_NEAR(f.peak_mean_pressure(), 2000, 1e-6);
  EXPECT_NEAR(f.peak_instant_force(), 1000, 1e-9);  // the unfiltered peak a single sample would report
  EXPECT_GE(f.time_of_peak_force(), 1.0 - 0.05 - 1e-9);
  EXPECT_LE(f.time_of_peak_force(), 1.02 + 1e-9);
  // With a minimum wetted area above the window's mean (0.1 m2) no mean pressure is reported.
  const LoadFilter small = impulse(0.1, 0.2, 1000, 0.5, 1000, 20);
  EXPECT_EQ(small.peak_mean_pressure(), 0);
  EXPECT_NEAR(small.peak_force(), 200, 1e-6);
}

TEST(LoadFilter, TheStructureIsUnloadedBeforeTheRunStarts) {
  // A steady 1000 N from the first evaluation: after half a window the cell reads half of it.
  LoadFilter f(0.1, 0);
  for (int k = 0; k <= 50; ++k) f.add(k * kDt, 1000, 1);
  EXPECT_NEAR(f.reading().force, 500, 1e-6);
  for (int k = 51; k <= 200; ++k) f.add(k * kDt, 1000, 1);
  EXPECT_NEAR(f.reading().force, 1000, 1e-6);
  EXPECT_NEAR(f.reading().wetted_area, 1, 1e-9);
}

TEST(LoadFilter, ParticleNoiseOnASteadyLoadIsAveragedOut) {
  // A steady 1000 N with independent noise uniform in +-1000 N at each evaluation (a particle entering or
  // leaving the support each ms): the instantaneous peak is ~2000 N. A 0.1 s window averages 100 values, so the
  // reading's standard deviation is 1000 / sqrt(3) / sqrt(100) = 58 N; over 20 windows the largest reading stays
  // within 1000 + 6 sigma (a bound a Gaussian passes 20 times with probability > 1 - 1e-7).
  std::mt19937 rng(12345);
  std::uniform_real_distribution<real> noise(-1000, 1000);
  LoadFilter f(0.1, 0);
  for (int k = 0; k <= 2000; ++k) f.add(k * kDt, 1000 + noise(rng), 1);
  EXPECT_GT(f.peak_instant_force(), 1900);
  EXPECT_LT(f.peak_force(), 1000 + 6 * 58);
  EXPECT_GT(f.peak_force(), 1000);
}

TEST(LoadFilter, RefusesAWindowThatIsNotPositiveAndTimeGoingBack) {
  EXPECT_THROW(LoadFilter(0, 0), std::invalid_argument);
  EXPECT_THROW(LoadFilter(0.1, -1), std::invalid_argument);
  LoadFilter f(0.1, 0);
  f.add(1.0, 1, 1);
  EXPECT_THROW(f.add(0.5, 1, 1), std::invalid_argument);
}
