// Thickness-integrated SPH (engine/include/runout/engine/depth_averaged.hpp) against analytic solutions.
//
// Aims and tolerances, declared before the first run (docs/validation.md, section 11) and not moved after:
//
// (a) Dam break on an inclined plane with Coulomb friction (Mangeney et al. 2000; Faccanoni & Mangeney 2012,
//     test 2, case 1.2, as AvaFrame's ana1Tests/damBreak sets it up): slope theta = 22 deg, bed friction angle
//     delta = 21 deg, release thickness h0 = 1 m over 40 m of slope (s in [-40, 0] m, s along the slope),
//     k = 1, g = 9.81 m/s^2; a strip periodic across (10 particle rows). Compared at t = 5 s with the analytic
//     h(s, t), u(s, t) (the rarefaction into a dry bed, in the frame accelerating at g cos(theta)(tan(theta) -
//     tan(delta))), over s in [-20, 45] m: the rear's own rarefaction (not in the analytic solution) reaches
//     s = -40 + (sqrt(g cos h0) + m0 t / 2) t = -22.6 m by then, the analytic front is at 32.4 m.
//       E_h = ||h - h_a||_2 / ||h_a||_2 on the centre line, sampled every 0.05 m (SPH thickness at the point);
//       E_u = sqrt(sum V (u - u_a)^2 / sum V u_a^2) over the particles in the window where h_a >= 0.05 h0
//             (u the along-slope velocity of the particle, u_a at its position).
//     Resolutions dp = 0.5, 0.25, 0.125 m (kernel smoothing length 1.5 dp).
//     A1: E_h <= 0.05 and E_u <= 0.05 at every resolution. 5 %: the screening purpose (one degree of delta
//         changes the plateau speed m0 t by 20 % at 5 s: the model must be well inside the parameter's effect).
//     A2: E_h and E_u fall at each halving of dp, and the observed order between dp = 0.5 and 0.125 m,
//         log2(E(0.5) / E(0.125)) / 2, is at least 0.5: half the first order that SPH with a smoothing length
//         proportional to the spacing reaches at the solution's kinks (rarefaction tail, front), and a
//         first-order time integrator with dt proportional to dp.
//     A3: total volume constant to 1e-12 relative (particles carry fixed volume); no non-finite value (the
//         model throws SimulationError on one).
//     Result of the first run (dp 0.5 / 0.25 / 0.125 m): E_h 0.147 / 0.143 / 0.108, E_u 0.127 / 0.154 / 0.133:
//     A1 and A2 fail; kept as the known failure DISABLED_SquareLatticeConvergesToTheFaccanoniMangeneySolution.
//     (The neighbour search's image shifts, added for (a''), change the rounding of a disordered flow: the
//     same case now gives E_h 0.147 / 0.144 / 0.103, E_u 0.127 / 0.149 / 0.130.)
//     Why: in a periodic strip the particles stay in rows dp apart across and spread only along the slope, so
//     where h < h0 / smoothing_ratio the rows lose their neighbours along the slope (an isolated row's SPH
//     thickness is about 0.5 h0 at 1.5 dp): the thin part of the rarefaction and the front (analytic front
//     32 m, computed 17 m) are not resolved, at any dp (the floor scales with h_k / dp, not with dp).
// (a') Declared after that run, before any run of it: the same dam break on a sheared lattice, row j offset
//     along the slope by (j / rows - 1/2) dp (a periodic lattice with vectors (dp, 0), (dp / rows, dp)), across a
//     strip of constant width 5 m (rows = 5 m / dp: 10, 20, 40). Projected on the slope the particles are then
//     dp / rows apart, so a strip resolves thicknesses down to about h0 dp / (rows h_k), which falls as dp^2.
//     Same aims A1, A2, A3 and the same norms, window, time and resolutions.
//     Result of its first run: E_h 0.088 / 0.080 / 0.072, E_u 0.101 / 0.086 / 0.074 (order 0.14 and 0.22):
//     falls, but A1 and the order fail; kept as the known failure
//     DISABLED_ShearedLatticeConvergesToTheFaccanoniMangeneySolution. Why: the thin front still separates into
//     particles whose SPH thickness is their own kernel's (V W(0) cos = 0.25 h0 at h_k = 1.5 dp): the front
//     stops near s = 18 m (analytic 32 m), and with h_k / dp fixed that floor does not fall as dp does.
//     (a) and (a') run with a fixed smoothing length (Config::adaptive_smoothing = false), as declared.
// (a'') Declared after (a')'s run, before any run of it: (a') with the adaptive smoothing length added to the
//     model after it (Config::adaptive_smoothing, now the default: h_k,i = 1.5 sqrt(V_i / rho_i), between
//     1.5 dp and 4 x that), so a thinning particle keeps its neighbours (as in shallow-water SPH, Vacondio et al.
//     2012). Same aims A1, A2, A3, norms, window, time, resolutions and sheared 5 m strip.
//     Result of its first run: E_h 0.0375 / 0.0359 / 0.0366, E_u 0.0478 / 0.0491 / 0.0484: A1 holds at every
//     resolution, A2 fails (order 0.02 and -0.01); kept as the known failure
//     DISABLED_AdaptiveSmoothingConvergesToTheFaccanoniMangeneySolution. Why: the error sits in the thin front
//     (computed front near 25 m, analytic 32 m; the layer behind it too thick), where the kernel has reached
//     its cap 4 h_k0 and its thickness floor (a row of particles dp apart across: 0.74 dp / (4 h_k0) h0 =
//     0.12 h0) is again fixed by h_k0 / dp, not by dp.
// (a''') Declared after (a'')'s run, before any run of it: (a'') on the convergence path of SPH itself, the
//     kernel shrinking more slowly than the spacing so that the neighbours per kernel grow (as AvaFrame's
//     com1DFA refines: particles per kernel radius growing as the kernel radius falls): h_k0 = 0.75 m
//     (dp / 0.5 m)^(1/2), i.e. smoothing ratio 1.5, 2.12, 3 at dp = 0.5, 0.25, 0.125 m. Same aims A1, A2, A3.
// (b) A uniform sheet (doubly periodic, 12 x 12 particles) on a plane with Coulomb friction mu:
//     B1: tan(theta) < mu (theta = 20 deg, mu = 0.5): at rest after 2 s, exactly (speed 0, no displacement):
//         the friction limiter stops a particle whose friction impulse exceeds its momentum.
//     B2: tan(theta) > mu (theta = 30 deg, mu = 0.3): the rigid-block acceleration a = g (sin - mu cos).
//         At t = 2 s every particle's along-slope speed within 1e-6 relative of a t (the step, symplectic Euler
//         when declared and leapfrog since 2026-12-07, is exact in the velocity for a constant acceleration; the
//         periodic lattice's pressure gradient is rounding), the mean travel along the slope within 1 % of
//         a t^2 / 2 (first-order positions, more than 100 steps).
//         (First run: 88 steps at the default CFL, travel +1.4 %: the travel part is the known failure
//         DISABLED_RigidBlockTravelsWithinOnePercent, at the default step, for the reason B3's is: first-order
//         positions. Capping the step to get the declared step count was tried and undone: a setting moved after
//         the result. Promoted 2026-12-07 when the model's step became a kick-drift-kick leapfrog, second order in
//         the positions and exact under a constant acceleration: travel 4.7126 m against 4.7126 m, 87 steps.)
//         On the plane
//         as a formula, as a callable, and as a DEM grid (plane sampled on 5 m nodes, the fall line turned
//         40 deg in plan).
//     B3: a sheet at 5 m/s on flat ground (mu = 0.5) stops after u0 / (mu g) and stays stopped: at t = 2 s
//         speed exactly 0, travel within 1 % of u0^2 / (2 mu g).
//         (First run, default CFL, ~80 steps: stopped exactly, travel -2.4 %: the travel part is the known
//         failure DISABLED_StoppingSheetTravelsWithinOnePercent: symplectic Euler's positions are first order.
//         Promoted 2026-12-07 with the leapfrog step: travel 2.5484 m against 2.5484 m, 63 steps.)
//     B4: Voellmy (mu = 0.155, xi = 500 m/s^2, h0 = 1 m, theta = 30 deg): after 30 s (eight time constants)
//         the speed within 1 % of the uniform-flow speed sqrt(xi h0 (sin - mu cos)).
// (d) Declared with this case, before its first run: a 10 m x 10 m x 2 m pile (dp = 0.5 m) released into a
//     valley given as a DEM grid (2 m nodes; z = -tan(25 deg) x + 0.02 y^2, curvature across), Voellmy
//     (mu = 0.2, xi = 500 m/s^2), 10 s: no non-finite value; volume constant to 1e-12 relative; the centre of
//     mass on the valley axis within 0.05 m (1 % of the release's half-width: the case is symmetric); and the
//     energy bound: the mean kinetic energy per unit mass at most g (the drop of the mean bed elevation under
//     the particles) + g h0 / 2 (the column's own potential), since friction only takes energy out.
// (e) Declared with this case, before its first run: the bed's centripetal load. One particle (its own
//     thickness has no gradient, so it is a rigid Coulomb block) released at rest at x = -30 m on the DEM grid
//     of z = x^2 / (2 R), R = 30 m (2 m nodes), mu = 0.2. Its first turning point, from the block's energy
//     equation with the load of the bend, d(v^2/2)/dx = -g z' - mu (g + z'' cos^2(theta) v^2), integrated by
//     RK4 in the test, is at x = 14.20 m (travel 44.20 m); without the load it would be 18.00 m (travel 48.00 m,
//     8.6 % more). Aim: the travel to the turning point within 1 % of 44.20 m (first-order positions).
// (c) Thickness of a uniform lattice within 1 % of h0 (the kernel's zeroth moment on a lattice at 1.5 dp);
//     the bed's grid form reproduces a plane's gradient exactly and a paraboloid's curvature; unknown friction
//     names and out-of-range parameters are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "runout/engine/depth_averaged.hpp"

namespace da = runout::depth_averaged;
using runout::real;

namespace {

constexpr real kG = 9.81;
real deg(real d) { return d * runout::kPi / 180.0; }

// A lattice of nx x ny particles of plan spacing dp from (x0, y0) (cell centres), each the volume of thickness
// h0 normal to a bed of slope cos_slope.
da::Particles lattice(real x0, real y0, int nx, int ny, real dp, real h0, real cos_slope) {
  da::Particles p;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) p.add(x0 + (i + 0.5) * dp, y0 + (j + 0.5) * dp, h0 * dp * dp / cos_slope);
  return p;
}

// ---- (a) the dam break -------------------------------------------------------------------------------

struct DamBreakAnalytic {
  real gz, m0, cL, h0;
  DamBreakAnalytic(real theta, real delta, real h)
      : gz(kG * std::cos(theta)), m0(gz * (std::tan(theta) - std::tan(delta))), cL(std::sqrt(gz * h)), h0(h) {}
  // Thickness and along-slope velocity at slope coordinate s (the dam at s = 0) at time t > 0.
  std::pair<real, real> at(real s, real t) const {
    const real tail = (0.5 * m0 * t - cL) * t, front = (2 * cL + 0.5 * m0 * t) * t;
    if (s <= tail) return {h0, m0 * t};
    if (s <= front) {
      const real w = 2 * cL - s / t + 0.5 * m0 * t;
      return {w * w / (9 * gz), 2.0 / 3.0 * (cL + s / t + m0 * t)};
    }
    return {0.0, 0.0};
  }
};

struct DamBreakErrors {
  real eh, eu;
  size_t particles, steps;
};

// sheared: rows across a 5 m strip, row j offset by (j / rows - 1/2) dp (a'); else 10 rows of a square lattice (a).
// refine_kernel: smoothing ratio 1.5 (0.5 m / dp)^(1/2) (a'''); else 1.5.
DamBreakErrors run_dam_break(real dp, bool sheared, bool adaptive, bool refine_kernel = false) {
  const real theta = deg(22), delta = deg(21), h0 = 1.0, length = 40.0, t_end = 5.0;
  const real c = std::cos(theta);
  const int rows = sheared ? static_cast<int>(std::lround(5.0 / dp)) : 10;
  const int nx = static_cast<int>(std::lround(length * c / dp));
  da::Config cfg;
  cfg.gravity = kG;
  cfg.spacing = dp;
  cfg.adaptive_smoothing = adaptive;
  cfg.smoothing_ratio = refine_kernel ? 1.5 * std::sqrt(0.5 / dp) : 1.5;
  cfg.friction = "coulomb";
  cfg.friction_parameters = {{"mu", std::tan(delta)}};
  cfg.periodic = {false, true};
  cfg.domain_min = da::Vec2(0, 0);
  cfg.domain_max = da::Vec2(0, rows * dp);
  // The plan strip [-nx dp, 0] x [0, rows dp]: the slope coordinate is s = x / cos(theta).
  da::Particles particles = lattice(-nx * dp, 0, nx, rows, dp, h0, c);
  if (sheared)
    for (size_t i = 0; i < particles.size(); ++i) particles.x[i] += (static_cast<real>(i / nx) / rows - 0.5) * dp;
  da::Model model(cfg, da::Bed::plane(0, -std::tan(theta), 0), std::move(particles));
  const real v0 = model.total_volume();
  model.advance_to(t_end);
  EXPECT_NEAR(model.total_volume(), v0, 1e-12 * v0) << "A3: volume";

  const DamBreakAnalytic ana(theta, delta, h0);
  real num = 0, den = 0;
  for (real s = -20.0; s <= 45.0 + 1e-9; s += 0.05) {
    const real h = model.thickness_at(s * c, 0.5 * rows * dp), ha = ana.at(s, t_end).first;
    num += (h - ha) * (h - ha), den += ha * ha;
  }
  const real eh = std::sqrt(num / den);
  const auto& p = model.particles();
  real unum = 0, uden = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const real s = p.x[i] / c;
    const auto [ha, ua] = ana.at(s, t_end);
    if (s < -20.0 || s > 45.0 || ha < 0.05 * h0) continue;
    const real u = p.ux[i] / c;  // the velocity is tangent to the plane: its along-slope part is u_x / cos
    unum += p.volume[i] * (u - ua) * (u - ua), uden += p.volume[i] * ua * ua;
  }
  return {eh, std::sqrt(unum / uden), p.size(), model.steps()};
}

void expect_dam_break_converges(bool sheared, bool adaptive, bool refine_kernel = false) {
  const std::vector<real> spacings = {0.5, 0.25, 0.125};
  std::vector<DamBreakErrors> e;
  for (real dp : spacings) {
    e.push_back(run_dam_break(dp, sheared, adaptive, refine_kernel));
    std::printf("dam break (%s, %s h_k%s) dp = %.3f m: %zu particles, %zu steps, E_h = %.4f, E_u = %.4f\n",
                sheared ? "sheared" : "square", adaptive ? "adaptive" : "fixed", refine_kernel ? ", refined" : "", dp, e.back().particles, e.back().steps, e.back().eh, e.back().eu);
  }
  for (size_t k = 0; k < e.size(); ++k) {
    EXPECT_LE(e[k].eh, 0.05) << "A1: E_h at dp = " << spacings[k];
    EXPECT_LE(e[k].eu, 0.05) << "A1: E_u at dp = " << spacings[k];
    if (k > 0) {
      EXPECT_LT(e[k].eh, e[k - 1].eh) << "A2: E_h falls at dp = " << spacings[k];
      EXPECT_LT(e[k].eu, e[k - 1].eu) << "A2: E_u falls at dp = " << spacings[k];
    }
  }
  const real order_h = std::log2(e.front().eh / e.back().eh) / 2, order_u = std::log2(e.front().eu / e.back().eu) / 2;
  std::printf("observed order 0.5 -> 0.125 m: h %.2f, u %.2f\n", order_h, order_u);
  EXPECT_GE(order_h, 0.5) << "A2: order of E_h";
  EXPECT_GE(order_u, 0.5) << "A2: order of E_u";
}

// (a): the known failure (rows lose their neighbours along the slope where the flow thins).
TEST(DepthAveragedDamBreak, DISABLED_SquareLatticeConvergesToTheFaccanoniMangeneySolution) {
  expect_dam_break_converges(false, false);
}

// (a'): the known failure (the thin front below a particle's own thickness floor).
TEST(DepthAveragedDamBreak, DISABLED_ShearedLatticeConvergesToTheFaccanoniMangeneySolution) {
  expect_dam_break_converges(true, false);
}

// (a''): the known failure (A1 holds; the thin front's floor keeps the error from falling).
TEST(DepthAveragedDamBreak, DISABLED_AdaptiveSmoothingConvergesToTheFaccanoniMangeneySolution) {
  expect_dam_break_converges(true, true);
}

// (a''')
TEST(DepthAveragedDamBreak, ConvergesToTheFaccanoniMangeneySolutionAsTheKernelShrinks) {
  expect_dam_break_converges(true, true, true);
}

// ---- (b) sheets -------------------------------------------------------------------------------------------

struct Sheet {
  da::Config cfg;
  real dp = 0.25;
  int n = 12;
  Sheet(const std::string& friction, runout::ParameterValues params, real spacing = 0.25) : dp(spacing) {
    cfg.gravity = kG;
    cfg.spacing = dp;
    cfg.friction = friction;
    cfg.friction_parameters = std::move(params);
    cfg.periodic = {true, true};
    cfg.domain_min = da::Vec2(0, 0);
    cfg.domain_max = da::Vec2(n * dp, n * dp);
  }
  da::Model make(da::Bed bed, real h0, real cos_slope) const {
    return da::Model(cfg, std::move(bed), lattice(0, 0, n, n, dp, h0, cos_slope));
  }
};

TEST(DepthAveragedSheet, RestsWhereTheSlopeIsBelowTheFrictionAngle) {
  const real theta = deg(20);
  Sheet sheet("coulomb", {{"mu", 0.5}});
  da::Model m = sheet.make(da::Bed::plane(0, -std::tan(theta), 0), 0.1, std::cos(theta));
  std::vector<std::pair<real, real>> start(m.particles().size());
  for (size_t i = 0; i < start.size(); ++i) start[m.particles().id[i]] = {m.particles().x[i], m.particles().y[i]};
  m.advance_to(2.0);
  const auto& p = m.particles();
  for (size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(p.ux[i], 0.0) << "B1";
    EXPECT_EQ(p.uy[i], 0.0) << "B1";
    EXPECT_EQ(p.uz[i], 0.0) << "B1";
    EXPECT_EQ(p.x[i], start[p.id[i]].first) << "B1";
    EXPECT_EQ(p.y[i], start[p.id[i]].second) << "B1";
  }
}

// The rigid-block check on a bed whose fall line points along (cos phi, sin phi) in plan.
// `travel`: also the mean travel (B2's second part, a known failure at the default step).
void expect_rigid_block(const da::Bed& bed, real theta, real phi, bool travel_too = false) {
  const real mu = 0.3, t = 2.0;
  Sheet sheet("coulomb", {{"mu", mu}});
  da::Model m = sheet.make(bed, 0.1, std::cos(theta));
  std::vector<real> x0(m.particles().size()), y0(m.particles().size());
  for (size_t i = 0; i < x0.size(); ++i) x0[m.particles().id[i]] = m.particles().x[i], y0[m.particles().id[i]] = m.particles().y[i];
  m.advance_to(t);
  const real a = kG * (std::sin(theta) - mu * std::cos(theta));
  const auto& p = m.particles();
  const real c = std::cos(theta), L = sheet.n * sheet.dp;
  real travel = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const real along = (p.ux[i] * std::cos(phi) + p.uy[i] * std::sin(phi)) / c;
    EXPECT_NEAR(along, a * t, 1e-6 * a * t) << "B2: speed";
    // Plan displacement on the nearest periodic image (it wraps), then along the slope.
    real dx = p.x[i] - x0[p.id[i]], dy = p.y[i] - y0[p.id[i]];
    const real s_plan = a * t * t / 2 * c;  // expected plan travel, to pick the image
    dx += L * std::round((s_plan * std::cos(phi) - dx) / L);
    dy += L * std::round((s_plan * std::sin(phi) - dy) / L);
    travel += (dx * std::cos(phi) + dy * std::sin(phi)) / c;
  }
  travel /= static_cast<real>(p.size());
  std::printf("rigid block: speed %.6f m/s (a t %.6f), travel %.4f m (a t^2/2 %.4f), %zu steps\n",
              (p.ux[0] * std::cos(phi) + p.uy[0] * std::sin(phi)) / c, a * t, travel, a * t * t / 2, m.steps());
  if (travel_too) {
    EXPECT_NEAR(travel, a * t * t / 2, 0.01 * a * t * t / 2) << "B2: travel after " << m.steps() << " steps";
  }
}

// B2's travel within 1 % at the default step (a known failure at the symplectic-Euler step: 88 steps, +1.4 %).
TEST(DepthAveragedSheet, RigidBlockTravelsWithinOnePercent) {
  const real theta = deg(30);
  expect_rigid_block(da::Bed::plane(2.0, -std::tan(theta), 0), theta, 0, true);
}

TEST(DepthAveragedSheet, SlidesWithTheRigidBlockAccelerationOnAPlane) {
  const real theta = deg(30);
  expect_rigid_block(da::Bed::plane(2.0, -std::tan(theta), 0), theta, 0);
}

TEST(DepthAveragedSheet, SlidesWithTheRigidBlockAccelerationOnACallableBed) {
  const real theta = deg(30), tn = std::tan(theta);
  expect_rigid_block(da::Bed::function([tn](real x, real) { return -tn * x; }, 0.01), theta, 0);
}

TEST(DepthAveragedSheet, SlidesWithTheRigidBlockAccelerationOnADemGrid) {
  // Some 40 m of DEM around the sheet, 5 m nodes; fall line turned 40 deg in plan.
  const real theta = deg(30), phi = deg(40), tn = std::tan(theta);
  const int nx = 13, ny = 13;
  std::vector<real> z;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const real x = -20.0 + 5.0 * i, y = -20.0 + 5.0 * j;
      z.push_back(100.0 - tn * (x * std::cos(phi) + y * std::sin(phi)));
    }
  expect_rigid_block(da::Bed::grid(-20, -20, 5, 5, nx, ny, z), theta, phi);
}

// B3: a sheet at u0 on flat ground, run to t = 2 s at the default step; returns the mean travel.
real stopping_sheet_travel(real mu, real u0) {
  Sheet sheet("coulomb", {{"mu", mu}});
  da::Particles p = lattice(0, 0, sheet.n, sheet.n, sheet.dp, 0.1, 1.0);
  std::fill(p.ux.begin(), p.ux.end(), u0);
  da::Model m(sheet.cfg, da::Bed::plane(0, 0, 0), p);
  std::vector<real> x0(m.particles().size());
  for (size_t i = 0; i < x0.size(); ++i) x0[m.particles().id[i]] = m.particles().x[i];
  m.advance_to(2.0);
  const real L = sheet.n * sheet.dp, expected = u0 * u0 / (2 * mu * kG);
  real travel = 0;
  for (size_t i = 0; i < m.particles().size(); ++i) {
    EXPECT_EQ(m.particles().ux[i], 0.0) << "B3: stopped";
    EXPECT_EQ(m.particles().uy[i], 0.0) << "B3: stopped";
    EXPECT_EQ(m.particles().uz[i], 0.0) << "B3: stopped";
    real dx = m.particles().x[i] - x0[m.particles().id[i]];
    dx += L * std::round((expected - dx) / L);
    travel += dx;
  }
  travel /= static_cast<real>(m.particles().size());
  std::printf("stopping sheet: travel %.4f m after %zu steps (analytic %.4f m)\n", travel, m.steps(), expected);
  return travel;
}

TEST(DepthAveragedSheet, FrictionStopsASheetWithoutReversingIt) { stopping_sheet_travel(0.5, 5.0); }

// B3's travel within 1 % at the default step (a known failure at the symplectic-Euler step: -2.4 %).
TEST(DepthAveragedSheet, StoppingSheetTravelsWithinOnePercent) {
  const real mu = 0.5, u0 = 5.0, expected = u0 * u0 / (2 * mu * kG);
  EXPECT_NEAR(stopping_sheet_travel(mu, u0), expected, 0.01 * expected) << "B3: travel";
}

TEST(DepthAveragedSheet, VoellmyReachesTheUniformFlowSpeed) {
  const real theta = deg(30), mu = 0.155, xi = 500, h0 = 1.0;
  Sheet sheet("voellmy", {{"mu", mu}, {"xi", xi}}, 0.5);
  da::Model m = sheet.make(da::Bed::plane(0, -std::tan(theta), 0), h0, std::cos(theta));
  m.advance_to(30.0);
  const real expected = std::sqrt(xi * h0 * (std::sin(theta) - mu * std::cos(theta)));
  real mean = 0;
  for (size_t i = 0; i < m.particles().size(); ++i) mean += m.particles().ux[i] / std::cos(theta);
  mean /= static_cast<real>(m.particles().size());
  std::printf("Voellmy uniform-flow speed %.4f m/s (analytic %.4f)\n", mean, expected);
  EXPECT_NEAR(mean, expected, 0.01 * expected) << "B4";
}

// ---- (d) a pile in a DEM valley ------------------------------------------------------------------------

TEST(DepthAveragedTerrain, PileInADemValleyStaysFiniteConservesVolumeAndObeysTheEnergyBound) {
  const real tn = std::tan(deg(25)), h0 = 2.0, dp = 0.5;
  const int nx = 71, ny = 41;  // x in [-20, 120] m, y in [-40, 40] m
  std::vector<real> z;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const real x = -20.0 + 2.0 * i, y = -40.0 + 2.0 * j;
      z.push_back(-tn * x + 0.02 * y * y);
    }
  const da::Bed bed = da::Bed::grid(-20, -40, 2, 2, nx, ny, z);
  da::Particles p;
  for (int j = 0; j < 20; ++j)
    for (int i = 0; i < 20; ++i) {
      const real x = (i + 0.5) * dp, y = -5.0 + (j + 0.5) * dp;
      p.add(x, y, h0 * dp * dp / bed.sample(x, y).cos_slope());
    }
  da::Config cfg;
  cfg.spacing = dp;
  cfg.friction = "voellmy";
  cfg.friction_parameters = {{"mu", 0.2}, {"xi", 500.0}};
  auto mean_z = [&](const da::Model& m) {
    real s = 0;
    for (size_t i = 0; i < m.particles().size(); ++i) s += bed.sample(m.particles().x[i], m.particles().y[i]).z;
    return s / static_cast<real>(m.particles().size());
  };
  da::Model m(cfg, bed, p);
  const real v0 = m.total_volume(), z0 = mean_z(m);
  ASSERT_NO_THROW(m.advance_to(10.0));
  EXPECT_NEAR(m.total_volume(), v0, 1e-12 * v0);
  const auto& q = m.particles();
  real xm = 0, ym = 0, ke = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    xm += q.x[i], ym += q.y[i];
    ke += 0.5 * (q.ux[i] * q.ux[i] + q.uy[i] * q.uy[i] + q.uz[i] * q.uz[i]);
  }
  const real n = static_cast<real>(q.size());
  xm /= n, ym /= n, ke /= n;
  const real bound = kG * (z0 - mean_z(m)) + kG * h0 / 2;
  std::printf("valley: centre of mass (%.3f, %.4f) m, kinetic energy %.2f J/kg, bound %.2f J/kg, %zu steps\n", xm, ym,
              ke, bound, m.steps());
  EXPECT_NEAR(ym, 0.0, 0.05);
  EXPECT_LE(ke, bound);
  EXPECT_GT(xm, 5.0);  // it moved down the valley at all
}

// ---- (e) a block through a bend ------------------------------------------------------------------------

// The block's first turning point from rest at x0 on z = x^2 / (2 R): RK4 in x on E = v^2 / 2.
real bend_turning_point(real R, real x0, real mu) {
  auto f = [&](real x, real E) { return -kG * x / R - mu * kG - mu * (1 / R) / (1 + x * x / (R * R)) * 2 * E; };
  real x = x0, E = 0;
  const real dx = 1e-4;
  for (;;) {
    const real k1 = f(x, E), k2 = f(x + dx / 2, E + dx / 2 * k1), k3 = f(x + dx / 2, E + dx / 2 * k2),
               k4 = f(x + dx, E + dx * k3);
    const real En = E + dx / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    if (En <= 0 && x > x0 + 1e-2) return x + dx * E / (E - En);
    E = En, x += dx;
  }
}

TEST(DepthAveragedTerrain, ABlockThroughABendFeelsItsCentripetalLoad) {
  const real R = 30, x0 = -30, mu = 0.2;
  std::vector<real> z;
  const int nx = 41, ny = 5;  // x in [-40, 40] m, y in [-4, 4] m
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const real x = -40.0 + 2.0 * i;
      z.push_back(x * x / (2 * R));
    }
  const da::Bed bed = da::Bed::grid(-40, -4, 2, 2, nx, ny, z);
  da::Particles p;
  p.add(x0, 0, 1.0);
  da::Config cfg;
  cfg.spacing = 0.5;
  cfg.friction_parameters = {{"mu", mu}};
  da::Model m(cfg, bed, p);
  real x_max = x0;
  while (m.time() < 8.0) {
    m.step();
    x_max = std::max(x_max, m.particles().x[0]);
  }
  const real expected = bend_turning_point(R, x0, mu);
  std::printf("bend: turning point %.3f m (block with the bend's load %.3f m), travel %.3f against %.3f m, %zu steps\n",
              x_max, expected, x_max - x0, expected - x0, m.steps());
  EXPECT_NEAR(x_max - x0, expected - x0, 0.01 * (expected - x0));
}

// ---- (c) pieces -------------------------------------------------------------------------------------------

TEST(DepthAveragedPieces, LatticeThicknessIsTheReleaseThickness) {
  const real theta = deg(25), h0 = 0.7;
  Sheet sheet("coulomb", {{"mu", 1.0}});
  da::Model m = sheet.make(da::Bed::plane(0, 0, -std::tan(theta)), h0, std::cos(theta));
  for (real h : m.particles().h) EXPECT_NEAR(h, h0, 0.01 * h0);
  std::printf("lattice thickness %.5f m (h0 %.2f m)\n", m.particles().h[0], h0);
  EXPECT_NEAR(m.thickness_at(1.0, 1.3), h0, 0.01 * h0);
}

TEST(DepthAveragedPieces, GridBedReproducesPlaneAndParaboloid) {
  std::vector<real> plane, bowl;
  for (int j = 0; j < 11; ++j)
    for (int i = 0; i < 11; ++i) {
      const real x = i * 2.0, y = j * 2.0;
      plane.push_back(3 + 0.2 * x - 0.5 * y);
      bowl.push_back(0.01 * x * x + 0.02 * x * y + 0.03 * y * y);
    }
  const auto p = da::Bed::grid(0, 0, 2, 2, 11, 11, plane).sample(7.3, 11.1);
  EXPECT_NEAR(p.z, 3 + 0.2 * 7.3 - 0.5 * 11.1, 1e-12);
  EXPECT_NEAR(p.grad.x(), 0.2, 1e-12);
  EXPECT_NEAR(p.grad.y(), -0.5, 1e-12);
  EXPECT_NEAR(p.cos_slope(), 1 / std::sqrt(1 + 0.04 + 0.25), 1e-12);
  // Interior of the paraboloid: central differences are exact for a quadratic.
  const auto b = da::Bed::grid(0, 0, 2, 2, 11, 11, bowl).sample(9.0, 9.0);
  EXPECT_NEAR(b.grad.x(), 0.02 * 9 + 0.02 * 9, 1e-12);
  EXPECT_NEAR(b.hess(0, 0), 0.02, 1e-12);
  EXPECT_NEAR(b.hess(0, 1), 0.02, 1e-12);
  EXPECT_NEAR(b.hess(1, 1), 0.06, 1e-12);
  const auto f = da::Bed::function([](real x, real y) { return 0.01 * x * x + 0.02 * x * y + 0.03 * y * y; }, 0.01)
                     .sample(9.0, 9.0);
  EXPECT_NEAR(f.hess(1, 1), 0.06, 1e-6);
  EXPECT_NEAR(f.grad.y(), 0.02 * 9 + 0.06 * 9, 1e-6);
}

TEST(DepthAveragedPieces, DeclaredParametersMatchTheConfigAndBadSettingsAreRefused) {
  const da::Config c;
  const auto& specs = da::config_parameters();
  EXPECT_EQ(runout::parameter_spec(specs, "earth_pressure").default_value, c.earth_pressure);
  EXPECT_EQ(runout::parameter_spec(specs, "smoothing_ratio").default_value, c.smoothing_ratio);
  EXPECT_EQ(runout::parameter_spec(specs, "cfl").default_value, c.cfl);
  EXPECT_EQ(runout::parameter_spec(specs, "dt_max").default_value, c.dt_max);
  auto make = [](da::Config cfg) { return da::Model(cfg, da::Bed::plane(0, 0, 0), lattice(0, 0, 2, 2, 1, 1, 1)); };
  da::Config bad = c;
  bad.spacing = 0;
  EXPECT_THROW(make(bad), std::invalid_argument);
  bad = c;
  bad.friction = "samosat";
  EXPECT_THROW(make(bad), std::invalid_argument);
  bad = c;
  bad.friction_parameters = {{"mu", -1.0}};
  EXPECT_THROW(make(bad), std::invalid_argument);
  bad = c;
  bad.periodic = {true, false};  // no period given
  EXPECT_THROW(make(bad), std::invalid_argument);
  EXPECT_NO_THROW(make(c));
}

TEST(DepthAveragedPieces, FrictionLawsAreNamedAndChecked) {
  ASSERT_EQ(da::friction_models().size(), 2u);
  EXPECT_EQ(da::friction_model("coulomb").name, "coulomb");
  EXPECT_EQ(da::friction_model("voellmy").name, "voellmy");
  EXPECT_THROW(da::friction_model("samosat"), std::invalid_argument);
  EXPECT_THROW(da::make_friction("voellmy", {{"xi", 0.0}}, kG), std::invalid_argument);
  EXPECT_THROW(da::make_friction("coulomb", {{"xi", 1.0}}, kG), std::invalid_argument);
  const auto v = da::make_friction("voellmy", {{"mu", 0.2}, {"xi", 400.0}}, kG);
  std::vector<real> sn = {2.0}, u = {10.0}, h = {1.0}, tau(1);
  v->shear_stress(sn, u, h, tau);
  EXPECT_NEAR(tau[0], 0.2 * 2.0 + kG * 100.0 / 400.0, 1e-12);
}

}  // namespace
