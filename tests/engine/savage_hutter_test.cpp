// Thickness-integrated SPH (engine/include/runout/engine/depth_averaged.hpp) against the Savage-Hutter
// similarity solution (issue 44): a parabolic cap released on an inclined plane with Coulomb bed friction.
//
// Source. Hutter, Siegel, Savage & Nohguchi (1993), Acta Mechanica 100, 37-68 (after Savage & Hutter 1989), as
// AvaFrame's ana1Tests run it: github.com/avaframe/AvaFrame at commit 21e4b9443ee16e3e80314f7d73d34d8de4b71530,
// avaframe/ana1Tests/simiSolTest.py (the ODE, its early-time series and initial conditions, h, u, v, the
// release getReleaseThickness), avaframe/ana1Tests/analysisTools.py (normL2Scal, normL2Vect,
// computeErrorAndNorm), avaframe/data/avaSimilaritySol/Inputs/simiSol_com1DFACfg.ini (the set-up) and
// docs/moduleAna1Tests.rst ("Similarity solution").
//
// Set-up (the ini's): plane inclined at zeta = 35 deg, Coulomb bed friction delta = 25 deg (mu = tan delta),
// earth-pressure coefficient K = 1 (flagEarth = False; the model's k = 1), release a paraboloid
// h0 (1 - s^2 / L_x^2 - y^2 / L_y^2), h0 = 4 m, L_x = L_y = 80 m measured on the slope (s along it: an ellipse
// in plan), at rest; compared at t = 5 s (tSave). Norms as AvaFrame's with relativError = True, on plan cells
// (here 1 m, over a 300 m x 300 m box holding the flow): L2 = sqrt(sum |num - ref|^2 / sum |ref|^2), Lmax =
// max |num - ref| / max |ref|, for h and for the vector h u (three components); the model's h and h u maps are
// its SPH sums cos zeta sum_j V_j (1, u_j) W(r, h_k,j) (Model::thickness_at's map).
// Differences from AvaFrame's com1DFA run, declared: particles on a square plan lattice (AvaFrame: random), the
// model's own kernel and step (h_k0 = 1.5 dp (4 m / dp)^(1/2), as the dam break's converging case (a''') in
// depth_averaged_test.cpp; cfl 0.2), spacings dp = 4, 2, 1 m (about 1 250, 5 000, 20 000 particles;
// smoothing ratio 1.5, 2.12, 3; h_k0 6, 4.24, 3 m).
//
// AIMS, declared 2026-12-06 05:08 UTC, before the model's first run on this case (the reference alone had run:
// SavageHutterSimilarity.ReferenceIsIntegratedToRounding, whose figures below argue the numbers):
//   S1: at dp = 1 m the relative L2 error of h and that of h u are each at most 5 %. Why 5 %: the dam break's
//       A1 (screening purpose), and the size of one degree of the friction angle in these norms, which the
//       reference gives (delta +-1 deg against 25 deg at 5 s): L2 h 4.1 %, h u 9.4 %; Lmax h 4.7 %, h u 8.4 %.
//       The model must be closer to the solution than one degree of delta moves it. The dam break at the same
//       smoothing ratio 3 measured 1.30 % / 1.32 %; this pile is smoother (no rarefaction kinks) but its kernel
//       is coarser against its size (h_k0 / L = 0.04 against 0.009).
//   S2: the L2 errors of h and of h u fall at each halving of dp (4 -> 2 -> 1 m), and the observed order
//       log2(E(4 m) / E(1 m)) / 2 is at least 0.5 for each: the dam break's A2 and its argument (SPH with the
//       kernel shrinking as dp^(1/2); a first-order step; the rim's kink).
//   S3: at dp = 1 m the relative Lmax error of h and that of h u are each at most 10 %. The largest error sits
//       at the rim's kink (the thickness's slope changes there from about 2 h0 / L to 0, which a kernel smooths
//       over its support: about 3 % of the peak at h_k 3 m from the smoothing alone) or the peak; 10 % is about
//       one degree of delta in Lmax (4.7 %, 8.4 %) with the rim's share on top.
//   S4: volume constant to 1e-12 relative and no non-finite value (the model throws on one); and checks of the
//       comparison itself: the grid's map holds the volume within 1e-3, the scattered map equals
//       Model::thickness_at within 1e-9 m.
//   A case that misses its aim stays as a DISABLED_ test run by ctest with WILL_FAIL
//   (SavageHutterSimilarity.KnownFailure.*, tests/CMakeLists.txt); the limits are not moved after the run.
//
// Result of the first run (2026-12-06 05:09 UTC; dp 4 / 2 / 1 m: 1 020 / 4 124 / 16 476 particles, not the
// "about 1 250, 5 000, 20 000" estimated above, which counted the slope's area rather than the plan's; 53 / 65 /
// 89 steps): L2 h 1.72 / 1.29 / 1.01 %, L2 h u 1.78 / 1.39 / 1.14 %, Lmax h 3.56 / 2.71 / 2.07 %, Lmax h u
// 4.24 / 3.23 / 2.46 %. S1, S3, S4 hold and the errors fall at each halving (S2's first part:
// ErrorsFallAsParticlesAreAdded); the observed order is 0.38 (h) and 0.32 (h u) against 0.5: S2's second part
// is the known failure DISABLED_ErrorsFallAtOrderOneHalf (split off as the sheets' B2 travel was, after the run).
// Why (diagnostic runs, not part of the test): the release's own SPH smoothing is already 1.57 / 0.92 / 0.54 %
// of L2 h at t = 0 (order 0.77), most of it at the rim; by 5 s the rim and dry ring carry 1.46 / 1.11 / 0.89 %
// and the interior (h_a > 1 m) 0.90 / 0.65 / 0.48 %: the thin edge, where the adaptive kernel grows towards
// its cap 4 h_k0, converges slowest. A 4x smaller step (cfl 0.05) lowers every error by 20-30 % but leaves the
// order at 0.45 / 0.36, so the first-order step is a part, not the cause.
// At the leapfrog step (2026-12-07, second-order positions, default cfl): L2 h 1.28 / 0.86 / 0.69 %, L2 h u
// 1.37 / 0.98 / 0.83 %, order 0.45 / 0.36, the figures of the 4x smaller step above: the step's share is gone
// and the rim's remains, so this stays a known failure.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "runout/engine/depth_averaged.hpp"
#include "runout/engine/kernels.hpp"

namespace da = runout::depth_averaged;
using runout::real;

namespace {

constexpr real kG = 9.81;
real deg(real d) { return d * runout::kPi / 180.0; }

// AvaFrame's set-up (avaframe/data/avaSimilaritySol/Inputs/simiSol_com1DFACfg.ini, section SIMISOL).
struct SimiSetup {
  real zeta = deg(35);   // plane inclination
  real delta = deg(25);  // bed friction angle (mu = tan delta = 0.466307658, the ini's mucoulomb)
  real lx = 80, ly = 80;  // release semi-axes along and across the slope, measured on the slope [m]
  real h0 = 4;            // release thickness at the centre, normal to the bed [m]
  real t_end = 5;         // compared at [s] (the ini's tSave)
  // flagEarth = True: Savage and Hutter's coefficients for the ini's internalFrictionAngle (25 deg) and delta
  // (the model's Config::savage_hutter); false: K_x = K_y = 1.
  bool earth = false;
  real phi_deg = 25;
};

// The similarity solution of Hutter, Siegel, Savage & Nohguchi (1993), as AvaFrame's ana1Tests/simiSolTest.py
// writes it, with earth-pressure coefficients K_x = K_y = 1 (the ini's flagEarth = False, the model's k = 1).
// Dimensionless time tau = t / T, T = sqrt(L_x / g). The pile stays a paraboloid,
//   h = H (1 - xi^2 - eta^2) / (f g),  xi = (s / L_x - (A - C) tau^2 / 2) / g,  eta = (y / L_y) / f,
//   u = U ((A - C) tau + (s / L_x - (A - C) tau^2 / 2) g' / g),  v = V (y / L_y) f' / f   (U = V = sqrt(g L)),
// s along the slope; its semi-axes g(tau), f(tau) obey
//   g'' = 2 B / (g^2 f),  f'' = 2 D / (g f^2) - C f' / ((A - C) tau),
// A = sin zeta, C = cos zeta tan delta, B = eps_x cos zeta K_x, D = eps_y^2 / eps_x cos zeta K_y, eps = H / L,
// from g = f = 1, g' = f' = 0. The last term (the friction's lateral part, -C v / u_c) is singular at tau = 0:
// up to tau0 the early-time series g = 1 + B tau^2, f = 1 + D E tau^2 (E = (A - C) / A) is used (its error is
// O(tau^3) in g', which carries on to 4e-9 in g at 5 s from tau0 = 0.01, 4e-12 from tau0 = 0.001), then classic
// RK4 with a fixed step (AvaFrame: the series to tau = 0.1, then dopri5: 4e-6 in g). Both tau0 and the step are checked in SavageHutterSimilarity.ReferenceIsIntegratedToRounding.
class Similarity {
 public:
  Similarity(const SimiSetup& s, real dtau = 1e-4, real tau0 = 0.001) : s_(s) {
    a_ = std::sin(s.zeta), c_ = std::cos(s.zeta) * std::tan(s.delta);
    // The pile stretches along and across from rest (g', f' >= 0, checked in the tests): both coefficients active.
    if (s.earth) {
      const auto e = da::savage_hutter_coefficients(s.phi_deg, s.delta * 180 / runout::kPi);
      kx_ = e.kx[0], ky_ = e.ky[0][0];
    }
    b_ = s.h0 / s.lx * std::cos(s.zeta) * kx_;
    d_ = (s.h0 / s.ly) * (s.h0 / s.ly) / (s.h0 / s.lx) * std::cos(s.zeta) * ky_;
    T_ = std::sqrt(s.lx / kG);
    tau_ = s.t_end / T_;
    integrate(dtau, std::min(tau0, tau_));
  }
  real g() const { return y_[0]; }
  real gp() const { return y_[1]; }
  real f() const { return y_[2]; }
  real fp() const { return y_[3]; }
  real kx() const { return kx_; }
  real ky() const { return ky_; }

  // Thickness normal to the bed and the velocity (plan-aligned 3D components, tangent to the plane z = -tan zeta x)
  // at plan point (x, y) at t_end; zero outside the pile.
  real thickness(real x, real y) const {
    const real xi = (x / std::cos(s_.zeta) / s_.lx - centre()) / g(), eta = y / s_.ly / f();
    return std::max(0.0, s_.h0 * (1 - xi * xi - eta * eta) / (f() * g()));
  }
  void velocity(real x, real y, real& vx, real& vy, real& vz) const {
    const real u = std::sqrt(kG * s_.lx) * ((a_ - c_) * tau_ + (x / std::cos(s_.zeta) / s_.lx - centre()) * gp() / g());
    const real v = std::sqrt(kG * s_.ly) * (y / s_.ly) * fp() / f();
    vx = u * std::cos(s_.zeta), vy = v, vz = -u * std::sin(s_.zeta);
  }

 private:
  real centre() const { return 0.5 * (a_ - c_) * tau_ * tau_; }  // centre's slope coordinate / L_x
  void rhs(real tau, const real* y, real* dy) const {
    dy[0] = y[1];
    dy[1] = 2 * b_ / (y[0] * y[0] * y[2]);
    dy[2] = y[3];
    dy[3] = 2 * d_ / (y[0] * y[2] * y[2]) - c_ * y[3] / ((a_ - c_) * tau);
  }
  void integrate(real dtau, real tau0) {
    const real e = (a_ - c_) / a_;
    y_[0] = 1 + b_ * tau0 * tau0, y_[1] = 2 * b_ * tau0;
    y_[2] = 1 + d_ * e * tau0 * tau0, y_[3] = 2 * d_ * e * tau0;
    const long n = static_cast<long>(std::ceil((tau_ - tau0) / dtau));
    const real h = (tau_ - tau0) / static_cast<real>(n);  // equal steps landing on tau exactly
    for (long k = 0; k < n; ++k) {
      const real t = tau0 + static_cast<real>(k) * h;
      real k1[4], k2[4], k3[4], k4[4], tmp[4];
      rhs(t, y_, k1);
      for (int i = 0; i < 4; ++i) tmp[i] = y_[i] + 0.5 * h * k1[i];
      rhs(t + 0.5 * h, tmp, k2);
      for (int i = 0; i < 4; ++i) tmp[i] = y_[i] + 0.5 * h * k2[i];
      rhs(t + 0.5 * h, tmp, k3);
      for (int i = 0; i < 4; ++i) tmp[i] = y_[i] + h * k3[i];
      rhs(t + h, tmp, k4);
      for (int i = 0; i < 4; ++i) y_[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    }
  }
  SimiSetup s_;
  real a_, b_, c_, d_, T_, tau_, kx_ = 1, ky_ = 1;
  real y_[4];
};

// The comparison grid: plan cells of 1 m over a box that holds the flow at t_end (the kernels' reach included;
// Fields::volume checks it), as AvaFrame compares on its raster (it over the whole DEM: zero cells add nothing).
struct Grid {
  real x0 = -130, y0 = -150, cell = 1;
  int nx = 300, ny = 300;
  real x(int i) const { return x0 + (i + 0.5) * cell; }
  real y(int j) const { return y0 + (j + 0.5) * cell; }
};

// h and the momentum h u (three components) per cell, row-major.
struct Fields {
  std::vector<real> h, hx, hy, hz;
  explicit Fields(const Grid& g) : h(g.nx * g.ny), hx(h.size()), hy(h.size()), hz(h.size()) {}
  // The volume the thickness map holds: sum of h times the bed area of a plan cell (cell^2 / cos zeta).
  real volume(const Grid& g, real cos_zeta) const {
    real v = 0;
    for (real x : h) v += x;
    return v * g.cell * g.cell / cos_zeta;
  }
};

Fields analytic_fields(const Similarity& sol, const Grid& g) {
  Fields F(g);
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const size_t k = static_cast<size_t>(j) * g.nx + i;
      const real h = sol.thickness(g.x(i), g.y(j));
      if (h <= 0) continue;
      real vx, vy, vz;
      sol.velocity(g.x(i), g.y(j), vx, vy, vz);
      F.h[k] = h, F.hx[k] = h * vx, F.hy[k] = h * vy, F.hz[k] = h * vz;
    }
  return F;
}

// The model's maps: each particle spreads its volume (and its momentum) with its own kernel, as
// Model::thickness_at does, cos zeta sum_j V_j W(r, h_k,j) (u_j inside the sum for h u). Scattered per particle
// (a gather per cell costs the whole flow per cell); thickness_at is the check of the scatter.
Fields model_fields(const da::Model& m, const Grid& g, real cos_zeta) {
  Fields F(g);
  const auto& p = m.particles();
  for (size_t j = 0; j < p.size(); ++j)
    runout::with_kernel<2>(m.config().kernel, p.smoothing[j], [&](const auto& K) {
      const real r = K.support();
      const int i0 = std::max(0, static_cast<int>(std::floor((p.x[j] - r - g.x0) / g.cell)));
      const int i1 = std::min(g.nx - 1, static_cast<int>(std::floor((p.x[j] + r - g.x0) / g.cell)));
      const int k0 = std::max(0, static_cast<int>(std::floor((p.y[j] - r - g.y0) / g.cell)));
      const int k1 = std::min(g.ny - 1, static_cast<int>(std::floor((p.y[j] + r - g.y0) / g.cell)));
      for (int k = k0; k <= k1; ++k)
        for (int i = i0; i <= i1; ++i) {
          const real w = cos_zeta * p.volume[j] * K.W(std::hypot(g.x(i) - p.x[j], g.y(k) - p.y[j]));
          const size_t c = static_cast<size_t>(k) * g.nx + i;
          F.h[c] += w, F.hx[c] += w * p.ux[j], F.hy[c] += w * p.uy[j], F.hz[c] += w * p.uz[j];
        }
    });
  return F;
}

// AvaFrame's norms (ana1Tests/analysisTools.py: normL2Scal, normL2Vect, computeErrorAndNorm) with its
// relativError = True: L2 = sqrt(sum |num - ref|^2 / sum |ref|^2) over the cells (the cell area / cos factor
// cancels), Lmax = max |num - ref| / max |ref|; h a scalar, h u the three-component vector.
struct Errors {
  real h_l2, h_max, hu_l2, hu_max;
};

Errors compare(const Fields& num, const Fields& ref) {
  real eh = 0, rh = 0, mh = 0, mrh = 0, ev = 0, rv = 0, mv = 0, mrv = 0;
  for (size_t k = 0; k < ref.h.size(); ++k) {
    const real dh = num.h[k] - ref.h[k];
    const real dv = std::pow(num.hx[k] - ref.hx[k], 2) + std::pow(num.hy[k] - ref.hy[k], 2) +
                    std::pow(num.hz[k] - ref.hz[k], 2);
    const real v = ref.hx[k] * ref.hx[k] + ref.hy[k] * ref.hy[k] + ref.hz[k] * ref.hz[k];
    eh += dh * dh, rh += ref.h[k] * ref.h[k], mh = std::max(mh, std::abs(dh)), mrh = std::max(mrh, ref.h[k]);
    ev += dv, rv += v, mv = std::max(mv, dv), mrv = std::max(mrv, v);
  }
  return {std::sqrt(eh / rh), mh / mrh, std::sqrt(ev / rv), std::sqrt(mv / mrv)};
}

}  // namespace

// The reference itself: RK4's step and the early-time series' end tau0 do not show in the solution at 5 s, and
// the paraboloid holds the release's volume pi/2 H L_x L_y (a check of the field formulas). Also prints what one
// degree of the bed friction angle changes in the norms (the scale the aims are argued from).
TEST(SavageHutterSimilarity, ReferenceIsIntegratedToRounding) {
  const SimiSetup s;
  const Similarity fine(s, 1e-4, 0.001), half(s, 5e-5, 0.001), early(s, 1e-5, 1e-4);
  for (const Similarity* o : {&half, &early}) {
    EXPECT_NEAR(o->g(), fine.g(), 1e-9);
    EXPECT_NEAR(o->gp(), fine.gp(), 1e-9);
    EXPECT_NEAR(o->f(), fine.f(), 1e-9);
    EXPECT_NEAR(o->fp(), fine.fp(), 1e-9);
  }
  std::printf("similarity solution at t = %.1f s: g = %.9f, g' = %.9f, f = %.9f, f' = %.9f\n", s.t_end, fine.g(),
              fine.gp(), fine.f(), fine.fp());
  const Grid grid;
  const Fields ref = analytic_fields(fine, grid);
  const real v0 = runout::kPi / 2 * s.h0 * s.lx * s.ly;
  EXPECT_NEAR(ref.volume(grid, std::cos(s.zeta)), v0, 1e-3 * v0) << "the paraboloid's volume";
  for (real dd : {-1.0, 1.0}) {
    SimiSetup o = s;
    o.delta = s.delta + deg(dd);
    const Errors e = compare(analytic_fields(Similarity(o), grid), ref);
    std::printf("delta %+.0f deg: L2 h %.4f, hu %.4f; Lmax h %.4f, hu %.4f\n", dd, e.h_l2, e.hu_l2, e.h_max, e.hu_max);
  }
}

namespace {

struct SimiRun {
  Errors e;
  size_t particles, steps;
};

// The release as a square plan lattice of spacing dp (cell centres, symmetric about the pile's centre), each
// particle the volume of the paraboloid's thickness over its cell, h0(s, y) dp^2 / cos zeta (thickness normal to
// the bed, a plan cell's bed area dp^2 / cos zeta), where h0 > 0. Kernel h_k0 = 1.5 dp (4 m / dp)^(1/2), the
// dam break's (a''') path; everything else the model's defaults (adaptive smoothing, cfl 0.2), Coulomb
// mu = tan delta, k = 1. Runs to t_end and compares with AvaFrame's norms; S4 is checked here for every run.
SimiRun run_similarity(real dp, bool earth = false) {
  SimiSetup s;
  s.earth = earth;
  const real c = std::cos(s.zeta);
  da::Config cfg;
  cfg.gravity = kG;
  cfg.earth_pressure = 1.0;
  cfg.spacing = dp;
  cfg.smoothing_ratio = 1.5 * std::sqrt(4.0 / dp);
  cfg.friction = "coulomb";
  cfg.friction_parameters = {{"mu", std::tan(s.delta)}};
  cfg.savage_hutter = earth;
  cfg.internal_friction_angle = s.phi_deg;
  cfg.bed_friction_angle = s.delta * 180 / runout::kPi;
  da::Particles p;
  const int nx = static_cast<int>(std::ceil(s.lx * c / dp)) + 1, ny = static_cast<int>(std::ceil(s.ly / dp)) + 1;
  for (int j = -ny; j < ny; ++j)
    for (int i = -nx; i < nx; ++i) {
      const real x = (i + 0.5) * dp, y = (j + 0.5) * dp, sl = x / c;
      const real h = s.h0 * (1 - (sl / s.lx) * (sl / s.lx) - (y / s.ly) * (y / s.ly));
      if (h > 0) p.add(x, y, h * dp * dp / c);
    }
  da::Model model(cfg, da::Bed::plane(0, -std::tan(s.zeta), 0), std::move(p));
  const real v0 = model.total_volume();
  model.advance_to(s.t_end);  // throws SimulationError on a non-finite value (S4)
  EXPECT_NEAR(model.total_volume(), v0, 1e-12 * v0) << "S4: volume at dp = " << dp;

  const Grid grid;
  const Fields num = model_fields(model, grid, c);
  EXPECT_NEAR(num.volume(grid, c), v0, 1e-3 * v0) << "S4: the grid holds the flow at dp = " << dp;
  real scatter = 0;
  for (int j = 0; j < grid.ny; j += 10)
    for (int i = 0; i < grid.nx; i += 10)
      scatter = std::max(scatter, std::abs(num.h[static_cast<size_t>(j) * grid.nx + i] -
                                           model.thickness_at(grid.x(i), grid.y(j))));
  EXPECT_LE(scatter, 1e-9) << "S4: the scattered map is thickness_at's at dp = " << dp;
  const Errors e = compare(num, analytic_fields(Similarity(s), grid));
  std::printf("Savage-Hutter%s dp = %.1f m (h_k0 %.2f m): %zu particles, %zu steps; L2 h %.4f, hu %.4f; "
              "Lmax h %.4f, hu %.4f\n",
              earth ? " (earth pressure)" : "", dp, model.smoothing_length(), model.particles().size(),
              model.steps(), e.h_l2, e.hu_l2, e.h_max, e.hu_max);
  if (earth) {  // S6: the same run against the isotropic reference
    const Errors iso = compare(num, analytic_fields(Similarity(SimiSetup{}), grid));
    std::printf("  against the K = 1 reference: L2 h %.4f, hu %.4f\n", iso.h_l2, iso.hu_l2);
    EXPECT_LT(e.h_l2, iso.h_l2) << "S6: closer to its own coefficients' solution (h)";
    EXPECT_LT(e.hu_l2, iso.hu_l2) << "S6: closer to its own coefficients' solution (h u)";
  }
  return {e, model.particles().size(), model.steps()};
}

}  // namespace

// S1 and S3 at the finest spacing.
TEST(SavageHutterSimilarity, WithinFivePercentAtTheFinestSpacing) {
  const SimiRun r = run_similarity(1.0);
  EXPECT_LE(r.e.h_l2, 0.05) << "S1: L2 of h";
  EXPECT_LE(r.e.hu_l2, 0.05) << "S1: L2 of h u";
  EXPECT_LE(r.e.h_max, 0.10) << "S3: Lmax of h";
  EXPECT_LE(r.e.hu_max, 0.10) << "S3: Lmax of h u";
}

// S2 over dp = 4, 2, 1 m. `order_too`: also the observed order (S2's second part, the known failure).
void expect_errors_fall(bool order_too) {
  const std::vector<real> spacings = {4.0, 2.0, 1.0};
  std::vector<Errors> e;
  for (real dp : spacings) e.push_back(run_similarity(dp).e);
  for (size_t k = 1; k < e.size(); ++k) {
    EXPECT_LT(e[k].h_l2, e[k - 1].h_l2) << "S2: L2 of h falls at dp = " << spacings[k];
    EXPECT_LT(e[k].hu_l2, e[k - 1].hu_l2) << "S2: L2 of h u falls at dp = " << spacings[k];
  }
  const real order_h = std::log2(e.front().h_l2 / e.back().h_l2) / 2;
  const real order_hu = std::log2(e.front().hu_l2 / e.back().hu_l2) / 2;
  std::printf("observed order 4 -> 1 m: h %.2f, hu %.2f\n", order_h, order_hu);
  if (order_too) {
    EXPECT_GE(order_h, 0.5) << "S2: order of L2 h";
    EXPECT_GE(order_hu, 0.5) << "S2: order of L2 h u";
  }
}

TEST(SavageHutterSimilarity, ErrorsFallAsParticlesAreAdded) { expect_errors_fall(false); }

// Known failure (tests/CMakeLists.txt, WILL_FAIL): S2's order, 0.38 (h) and 0.32 (h u) at the first run, 0.45 and
// 0.36 at the leapfrog step.
TEST(SavageHutterSimilarity, DISABLED_ErrorsFallAtOrderOneHalf) { expect_errors_fall(true); }

// Savage and Hutter's earth-pressure coefficients (issue 44 item 1; AvaFrame's flagEarth = True with the ini's
// internalFrictionAngle = delta = 25 deg). AIMS, declared 2026-12-06 09:47 UTC before the model's first run with
// them (the references alone had run: EarthPressureReferenceDiffersFromTheIsotropicOne):
//   S5: at dp = 1 m the L2 errors of h and of h u against the similarity solution with these coefficients are
//       each at most 5 % (S1's limit and argument), and Lmax at most 10 % (S3's).
//   S6: the same run is further from the K = 1 solution than from its own (L2 of h and of h u): the model
//       follows the coefficients, not only the case's geometry.
// The references alone (before the run): k_x = 1.4349, k_y = 0.7029 (both active: g' and f' > 0 to 5 s); the
// K = 1 solution is L2 h 4.91 %, h u 7.38 % from this one at 5 s, so S5's 5 % alone would hardly tell them apart:
// S6 is the aim that does.
// Result of the first run (2026-12-06 09:31 UTC, dp 1 m, 16 476 particles, 100 steps): L2 h 1.23 %, h u 1.48 %,
// Lmax h 2.51 %, h u 3.04 % against its own reference; against the K = 1 one L2 h 5.29 %, h u 7.83 %. S5 and S6
// hold.
TEST(SavageHutterSimilarity, EarthPressureReferenceDiffersFromTheIsotropicOne) {
  const auto e = da::savage_hutter_coefficients(25, 25);
  // phi = delta: the root vanishes, k_x active = passive = 2 / cos^2 phi - 1.
  EXPECT_NEAR(e.kx[0], 2 / std::pow(std::cos(deg(25)), 2) - 1, 1e-12);
  EXPECT_NEAR(e.kx[1], e.kx[0], 1e-12);
  EXPECT_LT(e.ky[0][0], 1.0);
  EXPECT_GT(e.ky[0][1], 1.0);
  EXPECT_THROW(da::savage_hutter_coefficients(20, 25), std::invalid_argument);
  SimiSetup s;
  s.earth = true;
  const Similarity sol(s);
  EXPECT_GT(sol.gp(), 0) << "the pile stretches along: k_x active";
  EXPECT_GT(sol.fp(), 0) << "and across: k_y active";
  const Grid grid;
  const Errors d = compare(analytic_fields(sol, grid), analytic_fields(Similarity(SimiSetup{}), grid));
  std::printf("k_x %.4f, k_y %.4f; g %.6f, f %.6f at 5 s; the K = 1 solution against it: L2 h %.4f, hu %.4f\n",
              sol.kx(), sol.ky(), sol.g(), sol.f(), d.h_l2, d.hu_l2);
  const real v0 = runout::kPi / 2 * s.h0 * s.lx * s.ly;
  EXPECT_NEAR(analytic_fields(sol, grid).volume(grid, std::cos(s.zeta)), v0, 1e-3 * v0);
}

TEST(SavageHutterSimilarity, EarthPressureWithinFivePercentAtTheFinestSpacing) {
  const SimiRun r = run_similarity(1.0, true);
  EXPECT_LE(r.e.h_l2, 0.05) << "S5: L2 of h";
  EXPECT_LE(r.e.hu_l2, 0.05) << "S5: L2 of h u";
  EXPECT_LE(r.e.h_max, 0.10) << "S5: Lmax of h";
  EXPECT_LE(r.e.hu_max, 0.10) << "S5: Lmax of h u";
}
