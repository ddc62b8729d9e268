// Frozen golden values: accelerations, density rates and effective viscosities of a small fixed particle set
// for every registered rheology x kernel x wall model (2D; and 3D with one kernel and wall), compared with the
// values stored in tests/engine/golden/ (as LAMMPS does per pair style). The force-loop reference test checks the
// optimised loops against a plain pair loop; this one catches any drift of the physics itself, in either.
//
// A change that moves the physics on purpose regenerates the files explicitly, and says why in its commit:
//   RUNOUT_REGENERATE_GOLDEN=1 build/tests/engine_golden_values_test
// A newly registered model fails here until its file is generated (and its parameters are added below).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "runout/engine/solver.hpp"

using namespace runout;

namespace {

const std::string kGoldenDir = std::string(RUNOUT_SOURCE_DIR) + "/tests/engine/golden/";

// Parameters of each model on the golden set: mid-range values that exercise every term of its law.
const std::map<std::string, std::pair<real, ParameterValues>> kMaterials = {
    {"newtonian", {1000, {{"viscosity", 0.5}}}},
    {"bingham", {1500, {{"viscosity", 0.2}, {"yield_stress", 20}}}},
    {"hbp", {1800, {{"viscosity", 1.0}, {"flow_index", 0.8}, {"regularisation", 50}, {"yield_stress", 40}}}},
    {"friction-hbp",
     {2000, {{"viscosity", 1.0}, {"flow_index", 1.05}, {"friction_angle", 30}, {"cohesion", 50}}}},
    {"mu-i", {1500, {{"mu_s", 0.38}, {"mu_2", 0.64}, {"grain_diameter", 5e-4}}}},
};

struct Case {
  std::string rheology, kernel, wall;
  int dim;
  std::string name() const {
    std::string n = std::to_string(dim) + "d_" + rheology + "_" + kernel + "_" + wall;
    for (auto& c : n)
      if (c == '-') c = '_';
    return n;
  }
};

// Deterministic in [-1, 1) on every platform (std:: distributions are not).
real jitter(uint32_t k) {
  k ^= k >> 16;
  k *= 0x7feb352dU;
  k ^= k >> 15;
  k *= 0x846ca68bU;
  k ^= k >> 16;
  return k / 2147483648.0 - 1.0;
}

template <int D>
SceneSetup<D> golden_scene(const Case& c) {
  const real dp = 0.01;
  SceneSetup<D> s;
  s.config.dp = dp;
  s.config.smoothing_length = 1.5 * dp;
  s.config.kernel = kernel_from_name(c.kernel);
  s.config.speed_of_sound = 20;
  s.config.artificial_viscosity = 0.05;
  s.config.boundary_pressure = boundary_pressure_from_name(c.wall);
  s.config.gravity = {0, 0, 0};
  s.config.gravity[D - 1] = -9.81;
  const auto& [rho0, params] = kMaterials.at(c.rheology);
  MaterialParams m;
  m.name = c.rheology;
  m.rheology = c.rheology;
  m.density = rho0;
  m.parameters = params;
  s.materials.push_back(m);
  s.config.boundary_density = rho0;
  const int nx = 8, ny = D == 3 ? 4 : 1, nz = 6;
  uint32_t k = 1;
  for (int a = 0; a < nx; ++a)
    for (int b = 0; b < ny; ++b)
      for (int z = 0; z < nz; ++z) {
        Vec<D> x;
        x[0] = (a + 0.5 + 0.2 * jitter(k++)) * dp;
        if (D == 3) x[1] = (b + 0.5 + 0.2 * jitter(k++)) * dp;
        x[D - 1] = (z + 1.0 + 0.2 * jitter(k++)) * dp;
        s.fluid.add(x, rho0 * (1.0 + 0.01 * jitter(k++)), rho0 * std::pow(dp, D), 0, 0);
        for (int d = 0; d < D; ++d) s.fluid.vel[d].back() = 0.5 * jitter(k++);
      }
  for (int a = -3; a < nx + 3; ++a)
    for (int b = (D == 3 ? -3 : 0); b < (D == 3 ? ny + 3 : 1); ++b)
      for (int z = 0; z < 3; ++z) {
        Vec<D> x;
        x[0] = (a + 0.5) * dp;
        if (D == 3) x[1] = (b + 0.5) * dp;
        x[D - 1] = -z * dp;
        s.boundary.add(x, rho0 * (1.0 + 0.005 * jitter(k++)), rho0 * std::pow(dp, D), 0, 1);
      }
  return s;
}

// Named columns of values, in particle order (the input order: ids are assigned in it).
using Columns = std::map<std::string, std::vector<real>>;

template <int D>
Columns evaluate(const Case& c) {
  Solver<D> solver(golden_scene<D>(c));
  solver.evaluate_rates();
  Columns out;
  const auto& f = solver.fluid();
  std::vector<size_t> by_id(f.size());
  for (size_t i = 0; i < f.size(); ++i) by_id[f.id[i]] = i;
  for (size_t q = 0; q < f.size(); ++q) {
    const size_t i = by_id[q];
    for (int d = 0; d < D; ++d) out["acc" + std::to_string(d)].push_back(solver.fluid_acceleration()[d][i]);
    out["drho"].push_back(solver.fluid_density_rate()[i]);
    out["mu_eff"].push_back(solver.fluid_effective_viscosity()[i]);
  }
  const auto& b = solver.boundary();
  std::vector<size_t> b_by_id(b.size());
  for (size_t j = 0; j < b.size(); ++j) b_by_id[b.id[j]] = j;
  for (size_t q = 0; q < b.size(); ++q) {
    out["boundary_drho"].push_back(solver.boundary_density_rate()[b_by_id[q]]);
    out["boundary_pressure"].push_back(solver.boundary_pressure()[b_by_id[q]]);
  }
  return out;
}

void write(const std::string& path, const Columns& cols) {
  std::ofstream out(path);
  char buf[40];
  for (const auto& [name, values] : cols) {
    out << name;
    for (real v : values) {
      std::snprintf(buf, sizeof buf, " %.17g", v);
      out << buf;
    }
    out << "\n";
  }
}

bool read(const std::string& path, Columns& cols) {
  std::ifstream in(path);
  if (!in) return false;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string name;
    s >> name;
    real v;
    while (s >> v) cols[name].push_back(v);
  }
  return true;
}

std::vector<Case> all_cases() {
  std::vector<Case> cases;
  for (const auto& r : rheology_names()) {
    for (const auto& k : kernel_names())
      for (const auto& w : boundary_pressure_names()) cases.push_back({r, k, w, 2});
    cases.push_back({r, kernel_names().front(), "extrapolated", 3});
  }
  return cases;
}

}  // namespace

class GoldenValues : public ::testing::TestWithParam<Case> {};

TEST_P(GoldenValues, MatchFrozenValues) {
  const Case& c = GetParam();
  ASSERT_TRUE(kMaterials.count(c.rheology)) << "add golden parameters for rheology '" << c.rheology << "'";
  const Columns now = c.dim == 2 ? evaluate<2>(c) : evaluate<3>(c);
  const std::string path = kGoldenDir + c.name() + ".txt";
  if (std::getenv("RUNOUT_REGENERATE_GOLDEN")) {
    write(path, now);
    GTEST_SKIP() << "wrote " << path;
  }
  Columns frozen;
  ASSERT_TRUE(read(path, frozen)) << "no golden values at " << path
                                  << ": RUNOUT_REGENERATE_GOLDEN=1 build/tests/engine_golden_values_test writes them";
  ASSERT_EQ(frozen.size(), now.size()) << path;
  for (const auto& [name, values] : now) {
    ASSERT_TRUE(frozen.count(name)) << name;
    const auto& ref = frozen.at(name);
    ASSERT_EQ(ref.size(), values.size()) << name;
    real scale = 0, err = 0;
    for (real v : ref) scale = std::max(scale, std::abs(v));
    for (size_t k = 0; k < ref.size(); ++k) err = std::max(err, std::abs(values[k] - ref[k]));
    // The same sums in another order (threads, vector width, fused multiply-add on another CPU) differ by
    // ~1e-15 of the largest value (the force-loop reference test measures 5e-15); a changed term moves 1e-6 and
    // more.
    EXPECT_LE(err, 1e-12 * std::max(scale, 1e-300)) << c.name() << ": " << name << " drifted by " << err
                                                     << " (scale " << scale << ")";
  }
}

INSTANTIATE_TEST_SUITE_P(Models, GoldenValues, ::testing::ValuesIn(all_cases()),
                         [](const auto& info) { return info.param.name(); });
