// Thickness-integrated SPH (engine/include/runout/engine/depth_averaged.hpp) against the energy line on a
// parabolic slope (issue 44 item 3), as AvaFrame's ana1Tests run it.
//
// Source. github.com/avaframe/AvaFrame at commit 21e4b9443ee16e3e80314f7d73d34d8de4b71530:
// avaframe/ana1Tests/energyLineTest.py (the centre of mass path, its runout angle, the "velocity altitude"
// z + u^2 / 2g against the alpha line), avaframe/ana1Tests/energyLineTestCfg.ini (the com1DFA set-up) and
// avaframe/in3Utils/generateTopo.py (parabola(), getParabolaParams(): the "PF" slope).
//
// The fact. A mass point sliding with Coulomb friction mu and no curvature term loses mu g cos(theta) ds3 of
// energy per unit mass over a surface element ds3, i.e. mu g dx per plan dx along its path, whatever the slope:
//   z + u^2 / (2 g) = z0 - mu s      (s its plan travel).
// Without a pressure term (AvaFrame's sphOption = 0) the particles do not interact, so each obeys it and, the
// relation being linear, so do the mass averages: z_c + <u^2> / (2 g) = z_c0 - mu s_c, s_c the plan travel of
// the centre of mass (here along x only: the bed does not vary across, so no particle moves across). The centre
// of mass stops on the alpha line: its runout angle atan((z_c0 - z_c,end) / s_c,end) is atan(mu), exactly.
//
// Set-up (the ini's com1DFA overrides): Coulomb mu = 0.4 (alpha = 21.801 deg), no pressure gradient
// (sphOption = 0: the model's k = 0), no curvature in the friction or the tangent (curvAccInFriction =
// curvAccInTangent = 0: Config::curvature = false), release thickness 1 m (relTh). The slope: generateTopo's PF,
// z = A x^2 + B x + C for x < fLen, flat beyond, A = C / fLen^2, B = -2 C / fLen, with generateTopoCfg.ini's
// C = 1000 m and meanAlpha = 34 deg (fLen = C / tan 34 deg = 1 482.6 m), sampled as a DEM at its dx = 5 m
// (Bed::grid, as a scene's DEM runs), x 0..3 000 m, y -200..200 m. Declared here, not AvaFrame's (its release
// polygon lives in a frame this copy does not give): the release a plan rectangle x 100..300 m, y -50..50 m,
// particles on a square plan lattice of spacing dp, each the volume h0 dp^2 / cos(theta) of its cell; the
// model's defaults otherwise (kernel, cfl 0.2, adaptive smoothing, h_k0 = 1.5 dp). Spacings dp = 10, 5, 2.5 m
// (200, 800, 3 200 particles). Sampled every 0.25 s until every particle is at rest (at most 200 s).
//
// Measured, as energyLineTest.py does: the runout angle error |alpha_c - alpha| (degrees), and the velocity
// altitude's deviation from the alpha line, z_c + <u^2>/(2 g) - (z_c0 - mu s_c), as an rms over the samples,
// relative to the centre's fall height z_c0 - z_c,end (energyLineTest.py's rmseVelocityElevation, made
// relative).
//
// AIMS, declared 2026-12-06 08:35 UTC, before the model's first run on this case:
//   E1: at every spacing the runout angle error is at most 0.1 deg. Why 0.1 deg: on this slope it is
//       dL = H dalpha / sin^2(alpha) = 12.7 m of the centre's 2 km runout (H 750 m), about 2.5 DEM cells, and
//       a tenth of the degree that the Savage-Hutter aims take as one unit of the friction angle's effect; the
//       error sources are a first-order step (travel error ~ 1/steps: about 2 500 steps at dp 10 m) and the
//       bilinear DEM (its elevation off the parabola by at most A dx^2 / 8 = 1.4 mm).
//   E2: at every spacing the relative rms deviation of the velocity altitude from the alpha line is at most
//       0.5 % (3.75 m of the 750 m fall, below one DEM cell's drop on the steepest part).
//   E3: both errors fall at each halving of dp (10 -> 5 -> 2.5 m) and the observed order
//       log2(E(10 m) / E(2.5 m)) / 2 is at least 0.5 for each: the step is cfl h_k0 / |u|, proportional to dp,
//       and the integrator first order (expected 1; 0.5 as the other depth-averaged aims take).
//   E4: every particle at rest by the end (the friction limiter stops them: speed exactly 0), the volume
//       constant to 1e-12 relative, every particle's y unchanged to 1e-9 m.
//   A case that misses its aim stays as a DISABLED_ test run by ctest with WILL_FAIL (tests/CMakeLists.txt); the
//   limits are not moved after the run.
//
// Result of the first run (2026-12-06 08:49 UTC; dp 10 / 5 / 2.5 m: 200 / 800 / 3 200 particles, 989 / 1 773 /
// 3 412 steps, all at rest by 48.5 s, 7.8 s on one thread for the three): runout angle 21.8234 / 21.8212 /
// 21.8151 deg against 21.8014 (errors 0.0220 / 0.0198 / 0.0137 deg), velocity altitude rms 7.27e-4 / 6.49e-4 /
// 4.76e-4 of the 751.7 m fall. E1, E2, E4 hold and the errors fall at each halving; the observed order is
// 0.34 (angle) and 0.31 (altitude) against 0.5: E3's order is the known failure
// DISABLED_ErrorsFallAtOrderOneHalf. Why (a diagnostic run, not part of the test, the step cap lowered by hand):
// the step is also capped at Config::dt_max = 0.1 s, a time that does not shrink with dp, and the slow start and
// stop run at that cap; with dt_max = 0.01 s the angle errors are 0.0008 / 0.0007 / 0.0001 deg (order 1.7) and
// the altitude rms 1.17e-4 / 1.17e-4 / 0.96e-4 (4 972 / 4 972 / 5 161 steps). At the default cap the angle
// error stays 4.5-7 times inside E1's limit, so the cap is left as it is.
//
// Promoted 2026-12-07: the model's step became a kick-drift-kick leapfrog (second-order positions; the cap and
// every other setting as they were). Same set-up: 990 / 1 775 / 3 415 steps, runout angle errors 0.0034 /
// 0.0018 / 0.0010 deg, velocity altitude rms 1.45e-4 / 7.54e-5 / 4.00e-5 of the fall: order 0.91 (angle) and
// 0.93 (altitude). The first-order positions, not the cap itself, were what kept the slow start and stop from
// converging.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "runout/engine/depth_averaged.hpp"

namespace da = runout::depth_averaged;
using runout::real;

namespace {

constexpr real kG = 9.81, kMu = 0.4, kH0 = 1.0;
constexpr real kDx = 5.0, kX0 = 0, kX1 = 3000, kY0 = -200, kY1 = 200;

// generateTopo.py's PF slope (getParabolaParams with meanAlpha != 0).
struct Parabola {
  real c = 1000, f_len = 1000 / std::tan(34 * runout::kPi / 180);
  real a = c / (f_len * f_len), b = -2 * c / f_len;
  real z(real x) const { return x < f_len ? a * x * x + b * x + c : c - b * b / (4 * a); }
};

da::Bed parabola_dem() {
  const Parabola p;
  const int nx = static_cast<int>(std::lround((kX1 - kX0) / kDx)) + 1;
  const int ny = static_cast<int>(std::lround((kY1 - kY0) / kDx)) + 1;
  std::vector<real> z(static_cast<size_t>(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) z[static_cast<size_t>(j) * nx + i] = p.z(kX0 + i * kDx);
  return da::Bed::grid(kX0, kY0, kDx, kDx, nx, ny, std::move(z));
}

struct CentreOfMass {
  real x = 0, z = 0, u2 = 0;  // volume-weighted plan x, bed elevation and squared speed
};

CentreOfMass centre(const da::Model& m) {
  const auto& p = m.particles();
  CentreOfMass c;
  real v = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const real w = p.volume[i];
    c.x += w * p.x[i];
    c.z += w * m.bed().sample(p.x[i], p.y[i]).z;
    c.u2 += w * (p.ux[i] * p.ux[i] + p.uy[i] * p.uy[i] + p.uz[i] * p.uz[i]);
    v += w;
  }
  c.x /= v, c.z /= v, c.u2 /= v;
  return c;
}

struct EnergyRun {
  real angle_error_deg, altitude_rms;  // E1, E2
  size_t particles, steps;
};

EnergyRun run_energy_line(real dp) {
  da::Config cfg;
  cfg.gravity = kG;
  cfg.earth_pressure = 0.0;  // sphOption = 0
  cfg.curvature = false;     // curvAccInFriction = curvAccInTangent = 0
  cfg.spacing = dp;
  cfg.friction = "coulomb";
  cfg.friction_parameters = {{"mu", kMu}};
  const da::Bed bed = parabola_dem();
  da::Particles p;
  std::vector<real> y0;
  for (real y = -50 + dp / 2; y < 50; y += dp)
    for (real x = 100 + dp / 2; x < 300; x += dp) {
      p.add(x, y, kH0 * dp * dp / bed.sample(x, y).cos_slope());
      y0.push_back(y);
    }
  da::Model model(cfg, bed, std::move(p));
  const real v0 = model.total_volume();
  const CentreOfMass start = centre(model);
  std::vector<CentreOfMass> samples{start};
  auto at_rest = [&] {
    const auto& q = model.particles();
    for (size_t i = 0; i < q.size(); ++i)
      if (q.ux[i] != 0 || q.uy[i] != 0 || q.uz[i] != 0) return false;
    return true;
  };
  for (real t = 0.25; t <= 200 && !(t > 1 && at_rest()); t += 0.25) {
    model.advance_to(t);
    samples.push_back(centre(model));
  }
  EXPECT_TRUE(at_rest()) << "E4: every particle at rest by 200 s at dp = " << dp;
  EXPECT_NEAR(model.total_volume(), v0, 1e-12 * v0) << "E4: volume at dp = " << dp;
  real drift = 0;
  for (size_t i = 0; i < model.particles().size(); ++i)
    drift = std::max(drift, std::abs(model.particles().y[i] - y0[model.particles().id[i]]));
  EXPECT_LE(drift, 1e-9) << "E4: no particle moves across at dp = " << dp;

  const CentreOfMass& end = samples.back();
  const real fall = start.z - end.z, travel = end.x - start.x;
  const real angle = std::atan(fall / travel) * 180 / runout::kPi, alpha = std::atan(kMu) * 180 / runout::kPi;
  real sq = 0;
  for (const CentreOfMass& c : samples) {
    const real d = c.z + c.u2 / (2 * kG) - (start.z - kMu * (c.x - start.x));
    sq += d * d;
  }
  const EnergyRun r{std::abs(angle - alpha), std::sqrt(sq / static_cast<real>(samples.size())) / fall,
                    model.particles().size(), model.steps()};
  std::printf("energy line dp = %.1f m: %zu particles, %zu steps, %.2f s; centre falls %.2f m over %.2f m: runout "
              "angle %.4f deg (alpha %.4f, error %.4f deg); velocity altitude rms %.3e of the fall\n",
              dp, r.particles, r.steps, model.time(), fall, travel, angle, alpha, r.angle_error_deg, r.altitude_rms);
  return r;
}

std::vector<EnergyRun> run_all() {
  std::vector<EnergyRun> r;
  for (real dp : {10.0, 5.0, 2.5}) r.push_back(run_energy_line(dp));
  return r;
}

// E1, E2 and E4 at every spacing; E3's fall at each halving. `order_too`: also E3's observed order (the known
// failure).
void expect_alpha_line(bool order_too) {
  const std::vector<EnergyRun> r = run_all();
  for (size_t k = 0; k < r.size(); ++k) {
    EXPECT_LE(r[k].angle_error_deg, 0.1) << "E1 at run " << k;
    EXPECT_LE(r[k].altitude_rms, 0.005) << "E2 at run " << k;
  }
  for (size_t k = 1; k < r.size(); ++k) {
    EXPECT_LT(r[k].angle_error_deg, r[k - 1].angle_error_deg) << "E3: the angle error falls at run " << k;
    EXPECT_LT(r[k].altitude_rms, r[k - 1].altitude_rms) << "E3: the altitude error falls at run " << k;
  }
  const real order_angle = std::log2(r.front().angle_error_deg / r.back().angle_error_deg) / 2;
  const real order_altitude = std::log2(r.front().altitude_rms / r.back().altitude_rms) / 2;
  std::printf("observed order 10 -> 2.5 m: angle %.2f, velocity altitude %.2f\n", order_angle, order_altitude);
  if (order_too) {
    EXPECT_GE(order_angle, 0.5) << "E3: order of the angle error";
    EXPECT_GE(order_altitude, 0.5) << "E3: order of the altitude error";
  }
}

}  // namespace

TEST(DepthAveragedEnergyLine, CentreOfMassFollowsTheAlphaLine) { expect_alpha_line(false); }

// E3's order (a known failure at the symplectic-Euler step: 0.34 and 0.31 at the first run).
TEST(DepthAveragedEnergyLine, ErrorsFallAtOrderOneHalf) { expect_alpha_line(true); }
