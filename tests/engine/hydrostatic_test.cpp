// Validation: water at rest in a 2D tank (scenarios/validation/hydrostatic_2d.json).
//
// Physical facts checked after the start-up waves have been damped:
//  * the pressure is hydrostatic, within 3 % of rho0 g (H - z0) away from the free surface and the bed (deeper
//    than 3 dp below the surface, higher than 2 dp above the bed face z = 0), both for every particle (its
//    pressure averaged over the last 0.25 s) and for every horizontal layer mean;
//  * the water is at rest: the largest speed is under 5 % of sqrt(g H), so the dynamic pressure rho v^2 / 2 of
//    what is left of the start-up waves stays under 0.13 % of rho g H, far inside the 3 % tolerance;
//  * no particle leaks (the solver throws SimulationError on a leak, which fails the test) and the fluid mass
//    is exact (relative error < 1e-12: no particle is created or lost).
//
// Reference: the weight of the water above each particle. A static tank keeps every particle under the same
// water, so with H the fill height (top face of the fluid block) and z0 the particle's initial height that weight
// is rho0 g (H - z0), exactly, whatever the fluid's compression (the weakly compressible column shrinks by
// g H^2 / (2 c0^2) ~ 1.4 mm = 0.14 dp under its own weight; comparing with rho0 g (H - z) at the particle's
// current height would add that shift to the error, up to 4 % at 3 dp depth; it is printed too).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <variant>
#include <vector>

#include "runout/engine/solver.hpp"
#include "runout/scenarios/scene.hpp"

using namespace runout;

TEST(HydrostaticValidation, TankSettlesToHydrostaticPressure) {
  const Scene scene = load_scene(RUNOUT_SOURCE_DIR "/scenarios/validation/hydrostatic_2d.json");
  ASSERT_EQ(scene.dimensions, 2);
  SceneSetup<2> setup = std::get<SceneSetup<2>>(scene.setup);
  const real dp = scene.dp;
  const real rho0 = setup.materials.at(0).density;
  const real g = -setup.config.gravity[1];
  ASSERT_GT(g, 0);
  // Nominal free surface: the top face of the fluid lattice (particles sit at (k + 1/2) dp).
  real H = -1e300;
  for (size_t i = 0; i < setup.fluid.size(); ++i) H = std::max(H, setup.fluid.pos[1][i] + 0.5 * dp);
  const real bed = 0.0;  // the tank's inner bottom face (scene: tank min z = 0)
  const size_t n0 = setup.fluid.size();
  std::vector<double> z0(n0);
  for (size_t i = 0; i < n0; ++i) z0[setup.fluid.id[i]] = setup.fluid.pos[1][i];

  Solver<2> solver(std::move(setup));
  // The weakly compressible column keeps ringing in its slowest acoustic mode (a quarter wave over the depth,
  // period 4 H / c0 ~ 0.07 s) long after the start-up: artificial viscosity damps it, and the pressure is
  // averaged over the last `window` seconds (several periods) so what is compared is the mean state, not one
  // phase of the residual oscillation. Each particle is followed by its id (the solver re-sorts them).
  const real window = 0.25;
  std::vector<double> p_sum(n0, 0.0), z_sum(n0, 0.0);
  double t_sum = 0;
  const auto t0 = std::chrono::steady_clock::now();
  while (solver.time() < scene.duration) {
    const real dt = solver.step().dt;  // a leak or NaN throws and fails the test
    if (solver.time() < scene.duration - window) continue;
    const auto& fa = solver.fluid();
    const auto& pa = solver.fluid_pressure();
    for (size_t i = 0; i < fa.size(); ++i) {
      p_sum[fa.id[i]] += pa[i] * dt;
      z_sum[fa.id[i]] += fa.pos[1][i] * dt;
    }
    t_sum += dt;
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_GT(t_sum, 0.9 * window);

  const auto& f = solver.fluid();
  ASSERT_EQ(f.size(), n0);  // nothing removed

  // Per particle (time means), and per layer (bins of height dp on the initial lattice rows).
  struct Layer {
    double sum_p = 0, sum_ref = 0;
    int n = 0;
  };
  std::map<long, Layer> layers;
  double worst_particle = 0, sum_abs = 0;
  int checked = 0;
  double worst_eulerian = 0;  // against rho0 g (H - z) at the time-mean current height, for comparison
  for (size_t id = 0; id < n0; ++id) {
    const double z = z_sum[id] / t_sum, pm = p_sum[id] / t_sum;
    const double depth = H - z0[id];
    if (depth <= 3 * dp || z0[id] - bed <= 2 * dp) continue;
    const double ref = rho0 * g * depth;
    const double rel = (pm - ref) / ref;
    worst_particle = std::max(worst_particle, std::abs(rel));
    worst_eulerian = std::max(worst_eulerian, std::abs((pm - rho0 * g * (H - z)) / (rho0 * g * (H - z))));
    sum_abs += std::abs(rel);
    ++checked;
    auto& L = layers[static_cast<long>(std::floor((z0[id] - bed) / dp))];
    L.sum_p += pm;
    L.sum_ref += ref;
    ++L.n;
  }
  ASSERT_GT(checked, 100);
  double worst_layer = 0;
  std::printf("  layer z0 [m]  n   mean p [Pa]   rho g (H - z0) [Pa]   deviation\n");
  for (const auto& [k, L] : layers) {
    const double mp = L.sum_p / L.n, mr = L.sum_ref / L.n;
    const double rel = (mp - mr) / mr;
    worst_layer = std::max(worst_layer, std::abs(rel));
    std::printf("  %9.3f  %3d  %11.1f  %19.1f  %+9.3f %%\n", (k + 0.5) * dp, L.n, mp, mr, 100 * rel);
  }
  real vmax = 0;
  for (size_t i = 0; i < f.size(); ++i) vmax = std::max(vmax, std::hypot(f.vel[0][i], f.vel[1][i]));
  const auto mb = solver.mass_balance();  // final state
  const double mass_err =
      static_cast<double>((mb.total_current() + mb.total_outflow() - mb.total_initial()) / mb.total_initial());
  std::printf(
      "  hydrostatic: %d particles checked, worst particle %.3f %%, mean |dev| %.3f %%, worst layer %.3f %% "
      "(against rho0 g (H - z) at the current height: worst particle %.3f %%), max speed %.4f m/s (%.3f %% of "
      "sqrt(gH)), mass error %.2e, %ld steps, %.1f s wall\n",
      checked, 100 * worst_particle, 100 * sum_abs / checked, 100 * worst_layer, 100 * worst_eulerian, vmax,
      100 * vmax / std::sqrt(g * H), mass_err, solver.steps(), wall);

  EXPECT_LT(worst_particle, 0.03);
  EXPECT_LT(worst_layer, 0.03);
  EXPECT_LT(vmax, 0.05 * std::sqrt(g * H));
  EXPECT_LT(std::abs(mass_err), 1e-12);
}
