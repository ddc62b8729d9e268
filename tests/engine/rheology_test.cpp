// Rheology laws and the shear-rate convention: simple shear u = g y must give |gamma_dot| = g and
// tau_xy = mu_eff g = tau_y + mu g^n for large m.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "runout/engine/rheology.hpp"
#include "runout/engine/solver.hpp"

using namespace runout;

namespace {
double mu_eff(const Rheology& r, double g, double p) {
  double out;
  r.effective_viscosity(std::span<const real>(&g, 1), std::span<const real>(&p, 1), std::span<real>(&out, 1));
  return out;
}
MaterialParams friction(double phi, double c, double mu, double n, double m) {
  MaterialParams p;
  p.name = "debris";
  p.rheology = "friction-hbp";
  p.density = 2000;
  p.set("viscosity", mu);
  p.set("flow_index", n);
  p.set("regularisation", m);
  p.set("friction_angle", phi);
  p.set("cohesion", c);
  return p;
}
}  // namespace

TEST(Rheology, FrictionHBPWithLargeMIsHerschelBulkleyInSimpleShear) {
  // tau = mu_eff * g must equal tau_y + mu g^n once m g >> 1.
  const auto r = make_rheology(friction(28.0, 500.0, 2.0, 1.05, 1e4));
  for (double p : {0.0, 1e3, 2e4}) {
    for (double g : {0.5, 3.0, 40.0}) {
      const double tau_y = std::max(p, 0.0) * std::sin(28.0 * kPi / 180) + 500.0 * std::cos(28.0 * kPi / 180);
      const double expected = tau_y + 2.0 * std::pow(g, 1.05);
      EXPECT_NEAR(mu_eff(*r, g, p) * g, expected, 1e-9 * expected) << "p=" << p << " g=" << g;
    }
  }
}

TEST(Rheology, YieldStressFollowsMohrCoulombWithPositivePressureOnly) {
  const auto r = make_rheology(friction(35.0, 200.0, 0.0, 1.0, 100.0));
  const double s = std::sin(35.0 * kPi / 180), c = std::cos(35.0 * kPi / 180);
  EXPECT_NEAR(r->yield_stress(1e4), 1e4 * s + 200 * c, 1e-9);
  EXPECT_NEAR(r->yield_stress(0.0), 200 * c, 1e-12);
  EXPECT_NEAR(r->yield_stress(-5e3), 200 * c, 1e-12);  // tension gives no frictional strength
  // And mu_eff sees it: at large g, tau = tau_y(P+) + 0.
  EXPECT_NEAR(mu_eff(*r, 50.0, -5e3) * 50.0, 200 * c, 1e-6);
  EXPECT_NEAR(mu_eff(*r, 50.0, 1e4) * 50.0, 1e4 * s + 200 * c, 1e-6);
}

TEST(Rheology, PhiZeroNOneCZeroIsNewtonian) {
  const auto r = make_rheology(friction(0.0, 0.0, 0.7, 1.0, 100.0));
  for (double g : {1e-6, 1e-2, 1.0, 1e3})
    for (double p : {-1e3, 0.0, 1e5}) EXPECT_DOUBLE_EQ(mu_eff(*r, g, p), 0.7);
}

TEST(Rheology, PapanastasiouLimitAtZeroShearIsTauYTimesM) {
  MaterialParams p;
  p.name = "hbp";
  p.rheology = "hbp";
  p.set("viscosity", 0.0);
  p.set("yield_stress", 300.0);
  p.set("regularisation", 100.0);
  const auto r = make_rheology(p);
  EXPECT_NEAR(mu_eff(*r, 1e-12, 0), 300.0 * 100.0, 1e-3);  // finite, = tau_y m
  EXPECT_TRUE(std::isfinite(mu_eff(*r, 1e-300, 0)));
}

TEST(Rheology, BinghamAndHbpAgreeForLargeM) {
  MaterialParams b;
  b.name = "b";
  b.rheology = "bingham";
  b.set("viscosity", 5.0);
  b.set("yield_stress", 100.0);
  MaterialParams h = b;
  h.rheology = "hbp";
  h.set("regularisation", 1e5);
  const auto rb = make_rheology(b), rh = make_rheology(h);
  for (double g : {0.1, 1.0, 10.0}) EXPECT_NEAR(mu_eff(*rb, g, 0), mu_eff(*rh, g, 0), 1e-9 * mu_eff(*rb, g, 0));
}

TEST(Rheology, BadParametersNameTheField) {
  auto expect_field = [](MaterialParams p, const std::string& field) {
    try {
      make_rheology(p);
      ADD_FAILURE() << "accepted bad " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  auto p = friction(28, 0, 1, 1, 100);
  p.set("flow_index", 0.0);
  expect_field(p, "flow_index");
  p = friction(90, 0, 1, 1, 100);
  expect_field(p, "friction_angle");
  p = friction(28, 0, 1, 1, 100);
  p.density = -1;
  expect_field(p, "density");
  p = friction(28, 0, 1, 1, 100);
  p.rheology = "mud";
  expect_field(p, "rheology");
}

// Through the solver: a 2D lattice sheared as u = g y. The interior particles must measure |gamma_dot| = g
// and a stress tau_xy = mu_eff g equal to the HB law, i.e. the solver's convention matches the law's.
TEST(Rheology, SolverMeasuresSimpleShearRate) {
  SceneSetup<2> s;
  s.config.dp = 0.01;
  s.config.smoothing_length = 0.015;
  s.config.gravity = {0, 0, 0};
  s.config.speed_of_sound = 50;
  s.config.max_viscosity = 1e12;
  s.materials.push_back(friction(0.0, 400.0, 3.0, 0.8, 1e4));  // c = 400 Pa, P = 0 -> tau_y = 400 Pa
  const double g = 2.5;
  for (int a = 0; a < 30; ++a)
    for (int b = 0; b < 30; ++b) {
      Vec<2> p(a * 0.01, b * 0.01);
      s.fluid.add(p, 2000.0, 2000.0 * 1e-4, 0, 0);
      s.fluid.vel[0].back() = g * p[1];
    }
  Solver<2> solver(std::move(s));
  solver.evaluate_rates();
  const auto& f = solver.fluid();
  int checked = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    const double x = f.pos[0][i], y = f.pos[1][i];
    if (x < 0.05 || x > 0.24 || y < 0.05 || y > 0.24) continue;  // interior: full kernel support
    ++checked;
    // 1%: the uncorrected SPH gradient on a lattice is off by ~0.3% at h = 1.5 dp (see the kernel lattice
    // test); a wrong convention would be off by a factor sqrt(2) or 2.
    EXPECT_NEAR(solver.fluid_shear_rate()[i], g, 0.01 * g);
    const double gm = solver.fluid_shear_rate()[i];
    const double tau = solver.fluid_effective_viscosity()[i] * gm;
    EXPECT_NEAR(tau, 400.0 + 3.0 * std::pow(gm, 0.8), 1e-6 * tau);
  }
  EXPECT_GT(checked, 100);
}

// The pore-pressure ratio r_u: friction acts on the effective stress (1 - r_u) P (Hungr 1995; DAN3D's frictional
// rheology), in the yield stress and in the walls' Coulomb coefficient; cohesion is untouched.
TEST(Rheology, PorePressureRatioScalesTheFrictionalStrengthOnly) {
  MaterialParams p = friction(28.0, 300.0, 1.0, 1.05, 100.0);
  const auto dry = make_rheology(p);
  const double ru = 1000.0 / 2088.0;  // a saturated mixture at hydrostatic pore pressure: rho_w / rho
  p.set("pore_pressure_ratio", ru);
  const auto wet = make_rheology(p);
  const double s = std::sin(28.0 * kPi / 180), c = 300.0 * std::cos(28.0 * kPi / 180);
  EXPECT_NEAR(wet->yield_stress(2e4), (1 - ru) * 2e4 * s + c, 1e-9);
  EXPECT_NEAR(wet->yield_stress(-1e3), c, 1e-12);
  EXPECT_NEAR(wet->wall_friction_coefficient(), (1 - ru) * dry->wall_friction_coefficient(), 1e-15);
  EXPECT_NEAR(wet->tensile_strength(), dry->tensile_strength() / (1 - ru), 1e-9);
  EXPECT_NEAR(mu_eff(*wet, 40.0, 2e4) * 40.0, (1 - ru) * 2e4 * s + c + std::pow(40.0, 1.05), 1e-3);
  // r_u = 1 would leave no friction at all: refused, with the field and its range named.
  p.set("pore_pressure_ratio", 1.0);
  try {
    make_rheology(p);
    FAIL() << "r_u = 1 accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("pore_pressure_ratio"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[0, 1)"), std::string::npos) << e.what();
  }
}
