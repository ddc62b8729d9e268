// Validation: steady plane Poiseuille flow of a Bingham fluid (scenarios/validation/poiseuille_bingham_2d.json).
//
// A body force g_x drives the fluid along a periodic channel between two DBC walls. Across the channel the
// shear stress is linear, |tau_xz| = rho g_x |z - z_c|, so the fluid is unyielded (a rigid plug) where that is
// under the yield stress, |z - z_c| < y0 = tau_y / (rho g_x), and Bingham-sheared outside:
//     u(z) = rho g_x / (2 mu) [ (B - y0)^2 - (|z - z_c| - y0)^2 ]   for y0 <= |z - z_c| <= B,
//     u(z) = rho g_x (B - y0)^2 / (2 mu)                            in the plug,
// with B the half-width between the two no-slip walls. The scene's material is the hbp law with n = 1 and the
// Papanastasiou regularisation the studies use (m = 100 s): it departs from Bingham only where m |gamma_dot| is
// of order 1, within mu / (m rho g_x) = 0.01 mm of the yield surface. (The unregularised bingham law with no cap
// misses this profile by 30 %: docs/validation.md, section 3.)
//
// Where the no-slip wall is: the DBC boundary particles carry v = 0 at their centres and the solver's viscous
// operator sees zero velocity at every boundary particle, so the analytic wall is put at the centres of the
// first boundary layer, half a spacing outside the wall face: B = b + dp/2, with b = N dp / 2 the half-width
// of the fluid layer between the faces. (At the face itself, B = b, the analytic plug speed is 10 % lower at
// this resolution.) The test also prints the half-width that fits the simulated profile best.
//
// The scene runs the numerics a yield-stress material gets by default (the implicit viscous step, no cap), so
// the plug is not marked by a capped viscosity: its half-width is read off the profile, as the y0 of the Bingham
// profile (with the wall at B) that fits the time-averaged rows best by least squares.
//
// Checked (one run): (1) the run reached steady state (the centre speed changed by < 0.5 % of the plug speed
// over the last 20 % of the run); (2) every layer's mean velocity (rows of particles, time-averaged over the last
// 0.1 s) is within 5 % of the analytic plug speed of the Bingham profile; (3) the fitted plug half-width is y0
// within the error the 5 % implies: the plug speed rho g (B - y0)^2 / (2 mu) moves by 2 dy0 / (B - y0) per unit
// of y0, so a plug speed within 5 % places the yield surface within 0.025 (B - y0) (0.26 dp here).
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

namespace {

struct Result {
  bool ran = false;
  double U = 0, worst = 0, u_centre_end = 0, u_centre_at_80 = 0, y0 = 0, y0_sim = 0, dp = 0, B = 0;
};

Result simulate() {
  Result res;
  const Scene scene = load_scene(RUNOUT_SOURCE_DIR "/scenarios/validation/poiseuille_bingham_2d.json");
  if (scene.dimensions != 2) return res;
  SceneSetup<2> setup = std::get<SceneSetup<2>>(scene.setup);
  if (setup.materials.size() != 1) return res;
  const MaterialParams mat = setup.materials[0];
  if (!(mat.rheology == "bingham" || mat.rheology == "hbp")) return res;
  const real dp = scene.dp;
  const real rho = mat.density, mu = mat.value("viscosity"), tau_y = mat.value("yield_stress");
  const real gx = setup.config.gravity[0];
  if (!(gx > 0)) return res;
  if (setup.config.gravity[1] != 0.0) return res;
  if (!setup.config.periodic[0]) return res;
  if (setup.config.viscous_step != ViscousStep::implicit || setup.config.max_viscosity > 0)
    return res;  // the test checks the default numerics: the implicit step with no cap

  // Wall faces: half a spacing beyond the outermost fluid rows.
  real zmin = 1e300, zmax = -1e300;
  for (size_t i = 0; i < setup.fluid.size(); ++i) {
    zmin = std::min(zmin, setup.fluid.pos[1][i]);
    zmax = std::max(zmax, setup.fluid.pos[1][i]);
  }
  const real z_lo = zmin - 0.5 * dp, z_hi = zmax + 0.5 * dp;
  const real b = 0.5 * (z_hi - z_lo), zc = 0.5 * (z_hi + z_lo);
  const real B = b + 0.5 * dp;  // no-slip at the first boundary layer's centres (see the header)
  const real y0 = tau_y / (rho * gx);
  const real U = rho * gx * (B - y0) * (B - y0) / (2 * mu);
  auto analytic = [&](real z, real half_width) {
    const real y = std::abs(z - zc);
    if (y >= half_width) return 0.0;
    if (y <= y0) return rho * gx * (half_width - y0) * (half_width - y0) / (2 * mu);
    return rho * gx / (2 * mu) * ((half_width - y0) * (half_width - y0) - (y - y0) * (y - y0));
  };
  if (!(b > 2 * y0)) return res;  // a plug well inside the channel

  Solver<2> solver(std::move(setup));
  const int nl = static_cast<int>(std::lround((z_hi - z_lo) / dp));
  const real window = 0.1;  // time-average the final profile over the last 0.1 s
  std::vector<double> u_sum(nl, 0.0), n_sum(nl, 0.0);
  double u_centre_at_80 = -1;
  auto centre_speed = [&]() {
    const auto& f = solver.fluid();
    double s = 0;
    int n = 0;
    for (size_t i = 0; i < f.size(); ++i)
      if (std::abs(f.pos[1][i] - zc) < dp) {
        s += f.vel[0][i];
        ++n;
      }
    return s / n;
  };
  const auto t0 = std::chrono::steady_clock::now();
  while (solver.time() < scene.duration) {
    solver.step();  // a leak or NaN throws and fails the test
    if (u_centre_at_80 < 0 && solver.time() >= 0.8 * scene.duration) u_centre_at_80 = centre_speed();
    if (solver.time() < scene.duration - window) continue;
    const auto& f = solver.fluid();
    for (size_t i = 0; i < f.size(); ++i) {
      const int k = static_cast<int>(std::floor((f.pos[1][i] - z_lo) / dp));
      if (k < 0 || k >= nl) continue;
      u_sum[k] += f.vel[0][i];
      n_sum[k] += 1;
    }
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double u_centre_end = centre_speed();

  std::printf("  layer z [mm]  u_sim [m/s]  u_bingham [m/s]  dev/U_plug\n");
  double worst = 0;
  std::vector<double> zs, us;
  for (int k = 0; k < nl; ++k) {
    if (!(n_sum[k] > 0)) return res;  // an empty layer: the run is not what the test expects
    const real z = z_lo + (k + 0.5) * dp;
    const double u = u_sum[k] / n_sum[k];
    const double ua = analytic(z, B);
    worst = std::max(worst, std::abs(u - ua) / U);
    zs.push_back(z);
    us.push_back(u);
    std::printf("  %11.1f  %11.4f  %15.4f  %+9.2f %%\n", 1e3 * z, u, ua, 100 * (u - ua) / U);
  }
  // Plug half-width: the Bingham profile's y0 (wall at B) that fits the rows best, in 0.01 dp steps.
  auto profile = [&](real z, real plug, real half_width) {
    const real y = std::abs(z - zc);
    if (y >= half_width) return 0.0;
    const real g = rho * gx / (2 * mu);
    return y <= plug ? g * (half_width - plug) * (half_width - plug)
                     : g * ((half_width - plug) * (half_width - plug) - (y - plug) * (y - plug));
  };
  double y0_sim = 0, y0_err = 1e300;
  for (double w = 0; w < B; w += 0.01 * dp) {
    double e = 0;
    for (size_t q = 0; q < zs.size(); ++q) e += std::pow(us[q] - profile(zs[q], w, B), 2);
    if (e < y0_err) {
      y0_err = e;
      y0_sim = w;
    }
  }
  // Effective wall position: the half-width that fits the profile best (least squares, 0.01 dp steps).
  double best_w = b, best_err = 1e300;
  for (double w = b - dp; w <= b + 2 * dp + 1e-12; w += 0.01 * dp) {
    double e = 0;
    for (size_t q = 0; q < zs.size(); ++q) e += (us[q] - analytic(zs[q], w)) * (us[q] - analytic(zs[q], w));
    if (e < best_err) {
      best_err = e;
      best_w = w;
    }
  }
  std::printf(
      "  poiseuille: U_plug %.4f m/s, worst |u - u_bingham| %.2f %% of U_plug, centre speed %.4f (at 80 %% of the "
      "run %.4f), plug half-width %.2f mm (fitted; analytic %.2f), best-fit wall "
      "half-width %.3f mm (faces: %.3f mm, first boundary layer: %.3f mm; i.e. the wall sits %.2f dp %s the face), "
      "%ld steps, %.1f s wall\n",
      U, 100 * worst, u_centre_end, u_centre_at_80, 1e3 * y0_sim, 1e3 * y0, 1e3 * best_w,
      1e3 * b, 1e3 * B, std::abs(best_w - b) / dp, best_w >= b ? "beyond" : "inside", solver.steps(), wall);

  res.ran = true;
  res.U = U;
  res.worst = worst;
  res.u_centre_end = u_centre_end;
  res.u_centre_at_80 = u_centre_at_80;
  res.y0 = y0;
  res.y0_sim = y0_sim;
  res.dp = dp;
  res.B = B;
  return res;
}

}  // namespace

// One run, several checks (ctest runs every TEST in its own process, so splitting them would repeat the run).
// The former viscous operator (divergence of tau = 2 mu_eff D' built from the SPH velocity gradient) let
// alternate particle rows slide (an odd-even mode) and failed here by 15 %; the Morris et al. (1997) operator
// with the per-particle mu_eff passes (docs/validation.md, section 3).
TEST(PoiseuilleValidation, BinghamSteadyProfileAndPlugWidth) {
  const Result r = simulate();
  ASSERT_TRUE(r.ran) << "the scene is not the periodic, body-force driven Bingham channel this test expects";
  EXPECT_LT(std::abs(r.u_centre_end - r.u_centre_at_80), 0.005 * r.U) << "not steady yet";
  EXPECT_LE(std::abs(r.y0_sim - r.y0), 0.025 * (r.B - r.y0)) << "plug half-width, fitted to the profile";
  EXPECT_LT(r.worst, 0.05) << "worst layer deviation from the Bingham profile, as a fraction of the plug speed";
}
