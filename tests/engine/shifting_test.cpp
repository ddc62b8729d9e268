// Fickian particle shifting (engine/src/solver/shifting.cpp; Lind et al. 2012): a particle moves down the gradient
// of its particle concentration C_i = sum_j V_j W_ij by A h |v| dt grad C, so a shift is a diffusion of C with
// diffusivity A h |v|, off at a free surface and for a particle at rest.
//
// The set-up isolates the shift: a 2D block with free surfaces above and below, periodic along x, no gravity and
// no viscosity, every particle at one velocity. With no relative velocity the continuity density stays rho0, the
// pressure 0 and the velocities constant, so without shifting the block translates rigidly and only the shift can
// rearrange it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "runout/engine/kernels.hpp"
#include "runout/engine/solver.hpp"

using namespace runout;

namespace {

constexpr double kDp = 0.01, kWidth = 20 * kDp, kRows = 16, kRho = 1000;

// The block, its interior particles displaced by up to a quarter spacing on each axis (a fixed seed).
SceneSetup<2> block(ParticleShifting shifting, double speed, Integrator integrator = Integrator::symplectic) {
  SceneSetup<2> s;
  s.config.dp = kDp;
  s.config.smoothing_length = 1.5 * kDp;
  s.config.speed_of_sound = 20;
  s.config.gravity = {0, 0, 0};
  s.config.integrator = integrator;
  s.config.particle_shifting = shifting;
  s.config.periodic = {true, false, false};
  s.config.domain_min = {0, -1, 0};
  s.config.domain_max = {kWidth, 1, 0};
  MaterialParams water;
  water.name = "water";
  water.set("viscosity", 0.0);
  s.materials.push_back(water);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.25 * kDp, 0.25 * kDp);
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < kRows; ++j) {
      const bool surface = j == 0 || j == kRows - 1;
      const double x = (i + 0.5) * kDp + (surface ? 0.0 : jitter(rng));
      const double y = (j + 0.5) * kDp + (surface ? 0.0 : jitter(rng));
      s.fluid.add(Vec<2>(x, y), kRho, kRho * kDp * kDp, 0, 0);
      s.fluid.vel[0].back() = speed;
    }
  return s;
}

// rms of C_i about its mean over the particles more than 4 dp from both surfaces (a full kernel support, 3 dp,
// inside the block), the periodic images included.
double concentration_spread(const ParticleArrays<2>& f) {
  const WendlandC2<2> kernel(1.5 * kDp);
  std::vector<double> c;
  for (size_t i = 0; i < f.size(); ++i) {
    if (f.pos[1][i] < 4 * kDp || f.pos[1][i] > (kRows - 4) * kDp) continue;
    double sum = 0;
    for (size_t j = 0; j < f.size(); ++j) {
      double dx = f.pos[0][i] - f.pos[0][j];
      dx -= kWidth * std::round(dx / kWidth);
      sum += f.mass[j] / f.rho[j] * kernel.W(std::hypot(dx, f.pos[1][i] - f.pos[1][j]));
    }
    c.push_back(sum);
  }
  double mean = 0, sq = 0;
  for (double v : c) mean += v / c.size();
  for (double v : c) sq += (v - mean) * (v - mean) / c.size();
  return std::sqrt(sq);
}

std::pair<double, double> height_range(const ParticleArrays<2>& f) {
  const auto [lo, hi] = std::minmax_element(f.pos[1].begin(), f.pos[1].end());
  return {*lo, *hi};
}

}  // namespace

// Over 0.05 s at 1 m/s the shift's diffusion length sqrt(A h |v| t) is 3.9 dp, several times the disorder's
// wavelengths (1-2 dp): the concentration's spread must at least halve. Without shifting the block translates
// rigidly and the spread stays to rounding.
TEST(ParticleShifting, EvensOutAMovingDisorderedBlock) {
  for (const Integrator integrator : {Integrator::symplectic, Integrator::verlet}) {
    Solver<2> off(block(ParticleShifting::none, 1.0, integrator));
    Solver<2> on(block(ParticleShifting::fickian, 1.0, integrator));
    const double start = concentration_spread(on.fluid());
    ASSERT_GT(start, 0.01) << "the disorder is there to be evened out";
    while (on.time() < 0.05) on.step();
    while (off.time() < 0.05) off.step();
    const double shifted = concentration_spread(on.fluid()), rigid = concentration_spread(off.fluid());
    std::printf("integrator %d: C spread %.4f at the start, %.4f shifted, %.4f without shifting (%ld steps)\n",
                static_cast<int>(integrator), start, shifted, rigid, on.steps());
    EXPECT_LT(shifted, 0.5 * start);
    EXPECT_NEAR(rigid, start, 1e-9);
  }
}

// The free surfaces are not pushed out: a surface particle's concentration gradient points out of the fluid, and an
// unchecked shift moves it out by up to the cap (0.1 dp) every step (with the surface threshold removed: 3.1 dp
// over these 0.05 s, about 330 steps). The block's height may change by less than a tenth of a spacing.
TEST(ParticleShifting, LeavesTheFreeSurfacesInPlace) {
  Solver<2> on(block(ParticleShifting::fickian, 1.0));
  const auto [lo0, hi0] = height_range(on.fluid());
  while (on.time() < 0.05) on.step();
  const auto [lo, hi] = height_range(on.fluid());
  std::printf("surfaces moved by %.4f dp (bottom) and %.4f dp (top)\n", (lo - lo0) / kDp, (hi - hi0) / kDp);
  EXPECT_LT(std::abs(lo - lo0), 0.1 * kDp);
  EXPECT_LT(std::abs(hi - hi0), 0.1 * kDp);
}

// A particle at rest is not shifted (the shift scales with |v|): a resting deposit does not creep by it.
TEST(ParticleShifting, LeavesAParticleAtRestInPlace) {
  const SceneSetup<2> start = block(ParticleShifting::fickian, 0.0);
  Solver<2> on(block(ParticleShifting::fickian, 0.0));
  for (int k = 0; k < 100; ++k) on.step();
  for (size_t i = 0; i < start.fluid.size(); ++i) {
    // The solver sorts its particles by cell, so each start position is looked for among them all.
    bool found = false;
    for (size_t j = 0; j < on.fluid().size() && !found; ++j)
      found = on.fluid().pos[0][j] == start.fluid.pos[0][i] && on.fluid().pos[1][j] == start.fluid.pos[1][i];
    EXPECT_TRUE(found) << "particle " << i << " moved";
  }
}
