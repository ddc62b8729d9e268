// The optimised force loops (cell-sorted blocks, fused passes, pair symmetry) against a plain O(N^2) loop
// over every pair, written from the equations (docs/design.md; thesis ch. 2 and eq. 4.1), on random particle
// sets: jittered lattices of fluid over a floor and a wall of boundary particles, random velocities and
// densities. Both must give the same accelerations, density rates, shear rates and effective viscosities to
// rounding: only the order of the sums differs.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <unordered_map>

#include "runout/engine/solver.hpp"

using namespace runout;

namespace {

struct Case {
  std::string name;
  int dim;
  KernelKind kernel;
  std::string rheology;  // "water" (inviscid), "newtonian", "bingham", "friction-hbp", "two" (friction-hbp + newtonian)
  BoundaryPressure boundary;
  DensityDiffusion diffusion;
  real alpha;
  bool periodic;  // along x
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

MaterialParams material(const std::string& kind) {
  MaterialParams m;
  m.name = kind;
  m.rheology = kind == "water" ? "newtonian" : kind;
  if (kind == "water") {
    m.set("viscosity", 0);
  } else if (kind == "newtonian") {
    m.density = 1200;
    m.set("viscosity", 0.5);
  } else if (kind == "bingham") {
    m.density = 1500;
    m.set("viscosity", 0.2);
    m.set("yield_stress", 20);
  } else {  // friction-hbp: cohesion gives it a finite tensile strength, so the pressure floor is exercised
    m.density = 2000;
    m.set("viscosity", 1.0);
    m.set("flow_index", 0.8);
    m.set("regularisation", 100);
    m.set("friction_angle", 30);
    m.set("cohesion", 50);
  }
  return m;
}

template <int D>
struct Reference {
  // Results by fluid id / boundary id.
  std::unordered_map<uint32_t, Vec<D>> acc;
  std::unordered_map<uint32_t, real> drho, shear_rate, mu_eff;
  std::unordered_map<uint32_t, real> boundary_drho, boundary_pressure;
  std::unordered_map<uint32_t, bool> boundary_near_fluid;
};

// The wall particles' pressure (extrapolated from the fluid along the wall normal, or DBC from their
// density) and whether any fluid is near each; rewrites B's density where extrapolated.
template <int D, class Kernel, class Sep>
void reference_wall_pressure(const SceneSetup<D>& s, const Kernel& kernel,
                             const std::unordered_map<uint32_t, Vec<D>>& normals, const std::vector<real>& p,
                             const Sep& sep, ParticleArrays<D>& B, std::vector<real>& pb, Reference<D>& out) {
  const SolverConfig& c = s.config;
  const auto& F = s.fluid;
  const size_t nf = F.size(), nb = B.size();
  const real c0 = c.speed_of_sound, gam = c.eos_gamma;
  const real support2 = kernel.support() * kernel.support();
  Vec<D> g;
  for (int d = 0; d < D; ++d) g[d] = c.gravity[d];
  auto tait = [&](real rho, real rho0) { return c0 * c0 * rho0 / gam * (std::pow(rho / rho0, gam) - 1.0); };
  for (size_t b = 0; b < nb; ++b) {
    bool near = false;
    real sw = 0, spw = 0;
    for (size_t j = 0; j < nf; ++j) {
      const Vec<D> dx = sep(B.position(b), F.position(j));
      if (dx.squaredNorm() >= support2) continue;
      near = true;
      const real w = kernel.W(dx.norm());
      sw += w;
      const Vec<D>& n = normals.at(B.id[b]);
      const real hydro = n.squaredNorm() > 0 ? g.dot(n) * n.dot(dx) : g.dot(dx);
      spw += (p[j] + F.rho[j] * hydro) * w;
    }
    out.boundary_near_fluid[B.id[b]] = near;
    if (c.boundary_pressure == BoundaryPressure::extrapolated) {
      pb[b] = sw > 0 ? std::max(spw / sw, 0.0) : 0.0;
      if (near) B.rho[b] = c.boundary_density * std::pow(1.0 + pb[b] / (c0 * c0 * c.boundary_density / gam), 1.0 / gam);
    } else {
      pb[b] = tait(B.rho[b], c.boundary_density);
    }
    out.boundary_pressure[B.id[b]] = pb[b];
  }
}

// Plain loops over all pairs, with the minimum image along periodic axes.
template <int D, class Kernel>
// `normals`: the wall normal of each boundary particle by id, as the solver has it (its estimate is
// tests/engine/wall_normals_test.cpp's concern; here only the pressure extrapolated along it is checked).
Reference<D> reference(const SceneSetup<D>& s, const Kernel& kernel, real max_viscosity,
                       const std::unordered_map<uint32_t, Vec<D>>& normals) {
  const SolverConfig& c = s.config;
  const auto& F = s.fluid;
  auto B = s.boundary;  // extrapolated boundary pressure rewrites the boundary density
  const size_t nf = F.size(), nb = B.size();
  const real h = c.smoothing_length, c0 = c.speed_of_sound, gam = c.eos_gamma;
  const real support2 = kernel.support() * kernel.support();
  const real eta2 = 0.01 * h * h;
  const bool ddt = c.density_diffusion != DensityDiffusion::none && c.density_diffusion_delta > 0;
  const real ddt_coef = ddt ? 2.0 * c.density_diffusion_delta * h * c0 : 0.0;
  const bool fourtakas = c.density_diffusion == DensityDiffusion::fourtakas;
  const real v_slip = 0.01 * std::sqrt(9.81 * c.dp);
  Vec<D> g;
  for (int d = 0; d < D; ++d) g[d] = c.gravity[d];
  std::vector<std::unique_ptr<Rheology>> rheo;
  bool viscous = false;
  for (const auto& m : s.materials) {
    rheo.push_back(make_rheology(m));
    viscous = viscous || !rheo.back()->is_inviscid();
  }
  auto tait = [&](real rho, real rho0) { return c0 * c0 * rho0 / gam * (std::pow(rho / rho0, gam) - 1.0); };
  auto sep = [&](const Vec<D>& a, const Vec<D>& b) {
    Vec<D> dx = a - b;
    for (int d = 0; d < D; ++d)
      if (c.periodic[d]) {
        const real L = c.domain_max[d] - c.domain_min[d];
        dx[d] -= L * std::round(dx[d] / L);
      }
    return dx;
  };

  std::vector<real> p(nf), pb(nb);
  for (size_t i = 0; i < nf; ++i) {
    const auto& m = s.materials[F.material[i]];
    p[i] = std::max(tait(F.rho[i], m.density), -rheo[F.material[i]]->tensile_strength());
  }
  Reference<D> out;
  reference_wall_pressure(s, kernel, normals, p, sep, B, pb, out);

  // Pass 1: continuity, density diffusion, velocity gradient, kernel-averaged pressure.
  std::vector<real> div(nf, 0), diff(nf, 0), gdot(nf), yield_p(nf), mu(nf, 0), mu_wall(nf, 0);
  for (size_t i = 0; i < nf; ++i) {
    const Vec<D> xi = F.position(i), vi = F.velocity(i);
    const int mi = F.material[i];
    Mat<D> L = Mat<D>::Zero();
    real pw = p[i] * F.mass[i] / F.rho[i] * kernel.W(0), ww = F.mass[i] / F.rho[i] * kernel.W(0);
    for (size_t j = 0; j < nf; ++j) {
      const Vec<D> dx = sep(xi, F.position(j));
      const real r2 = dx.squaredNorm();
      if (j == i || r2 >= support2 || r2 < 1e-24) continue;
      const real gradf = kernel.grad_factor(std::sqrt(r2));
      const real Vj = F.mass[j] / F.rho[j];
      const Vec<D> vij = vi - F.velocity(j);
      div[i] += Vj * gradf * vij.dot(dx);
      if (ddt && F.material[j] == mi) {
        real drho = F.rho[j] - F.rho[i];
        if (fourtakas) drho += s.materials[mi].density * g.dot(dx) / (c0 * c0);
        diff[i] -= drho * gradf * Vj;
      }
      L -= Vj * gradf * vij * dx.transpose();
      pw += Vj * kernel.W(std::sqrt(r2)) * p[j];
      ww += Vj * kernel.W(std::sqrt(r2));
    }
    for (size_t b = 0; b < nb; ++b) {
      const Vec<D> dx = sep(xi, B.position(b));
      const real r2 = dx.squaredNorm();
      if (r2 >= support2 || r2 < 1e-24) continue;
      const real gradf = kernel.grad_factor(std::sqrt(r2));
      const real Vb = B.mass[b] / B.rho[b];
      div[i] += Vb * gradf * vi.dot(dx);
      L -= Vb * gradf * vi * dx.transpose();
    }
    yield_p[i] = pw / ww;
    const Mat<D> Ds = 0.5 * (L + L.transpose());
    const real tr3 = Ds.trace() / 3.0;
    Mat<D> Dd = Ds;
    for (int d = 0; d < D; ++d) Dd(d, d) -= tr3;
    real dd = Dd.squaredNorm();
    if (D == 2) dd += tr3 * tr3;
    gdot[i] = std::max(std::sqrt(2.0 * dd), c.shear_rate_floor);
    if (viscous) {
      const std::vector<real> gd1{gdot[i]}, p1{yield_p[i]}, zero{0.0};
      std::vector<real> m1(1);
      rheo[mi]->effective_viscosity(gd1, p1, m1);
      mu[i] = std::min(m1[0], max_viscosity);
      if (rheo[mi]->wall_friction_coefficient() > 0) {
        rheo[mi]->effective_viscosity(gd1, zero, m1);
        mu_wall[i] = std::min(m1[0], max_viscosity);
      } else {
        mu_wall[i] = mu[i];
      }
    }
  }

  // Pass 2: momentum.
  for (size_t i = 0; i < nf; ++i) {
    const Vec<D> xi = F.position(i), vi = F.velocity(i);
    const int mi = F.material[i];
    const real rhoi = F.rho[i];
    Vec<D> a = Vec<D>::Zero(), push = Vec<D>::Zero();
    auto pair = [&](const Vec<D>& dx, real r2, const Vec<D>& vij, real mj, real rhoj, real pj, real mui, real muj,
                    bool wall) {
      const real gradf = kernel.grad_factor(std::sqrt(r2));
      const real vdotdx = vij.dot(dx);
      real pterm = p[i] / (rhoi * rhoi) + pj / (rhoj * rhoj);
      if (wall) pterm = std::max(pterm, 0.0);
      if (c.artificial_viscosity > 0 && vdotdx < 0)
        pterm -= c.artificial_viscosity * c0 * (h * vdotdx / (r2 + eta2)) / (0.5 * (rhoi + rhoj));
      a -= mj * pterm * gradf * dx;
      if (wall) push -= mj * pterm * gradf * dx;
      if (viscous) a += mj * (mui + muj) / (rhoi * rhoj) * gradf * r2 / (r2 + eta2) * vij;
    };
    for (size_t j = 0; j < nf; ++j) {
      const Vec<D> dx = sep(xi, F.position(j));
      const real r2 = dx.squaredNorm();
      if (j == i || r2 >= support2 || r2 < 1e-24) continue;
      pair(dx, r2, vi - F.velocity(j), F.mass[j], F.rho[j], p[j], mu[i], mu[j], false);
    }
    for (size_t b = 0; b < nb; ++b) {
      const Vec<D> dx = sep(xi, B.position(b));
      const real r2 = dx.squaredNorm();
      if (r2 >= support2 || r2 < 1e-24) continue;
      pair(dx, r2, vi, B.mass[b], B.rho[b], pb[b], mu_wall[i], mu_wall[i], true);
    }
    const real friction = rheo[mi]->wall_friction_coefficient();
    if (viscous && friction > 0 && push.norm() > 0) {
      const Vec<D> nrm = push / push.norm();
      const Vec<D> vt = vi - vi.dot(nrm) * nrm;
      const real vts = vt.norm();
      if (vts > 0) a -= friction * push.norm() * -std::expm1(-vts / v_slip) / vts * vt;
    }
    a += g;
    out.acc[F.id[i]] = a;
    out.drho[F.id[i]] = rhoi * div[i] + ddt_coef * diff[i];
    out.shear_rate[F.id[i]] = gdot[i];
    out.mu_eff[F.id[i]] = mu[i];
  }
  // DBC continuity of the boundary: v_b = 0.
  for (size_t b = 0; b < nb; ++b) {
    real d = 0;
    for (size_t j = 0; j < nf; ++j) {
      const Vec<D> dx = sep(B.position(b), F.position(j));
      const real r2 = dx.squaredNorm();
      if (r2 >= support2 || r2 < 1e-24) continue;
      d += F.mass[j] / F.rho[j] * kernel.grad_factor(std::sqrt(r2)) * -F.velocity(j).dot(dx);
    }
    out.boundary_drho[B.id[b]] = B.rho[b] * d;
  }
  return out;
}

// Fluid on a jittered lattice over a three-layer floor and against a two-layer wall at x = 0 (the wall is
// left out when x is periodic), random velocities up to 2 m/s and densities from -1 % to +3 % of the rest
// density (tension and compression), boundary densities up to +2 %.
template <int D>
SceneSetup<D> random_scene(const Case& k, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<real> jitter(-0.3, 0.3), speed(-2.0, 2.0), dens(-0.01, 0.03), bdens(0.0, 0.02);
  SceneSetup<D> s;
  SolverConfig& c = s.config;
  c.dp = 0.1;
  c.smoothing_length = 1.5 * c.dp;
  c.kernel = k.kernel;
  c.speed_of_sound = 20;
  c.artificial_viscosity = k.alpha;
  c.density_diffusion = k.diffusion;
  c.boundary_pressure = k.boundary;
  // Tilted gravity, so the Fourtakas term has a horizontal part too.
  c.gravity = D == 2 ? std::array<real, 3>{-2.0, -9.81, 0.0} : std::array<real, 3>{-2.0, 1.0, -9.81};
  const int nx = D == 2 ? 24 : 12, ny = 10, nz = D == 2 ? 12 : 8;  // fluid lattice (2D: x, z)
  const real dp = c.dp;
  if (k.periodic) {
    c.periodic[0] = true;
    c.domain_min[0] = 0;
    c.domain_max[0] = nx * dp;
  }
  if (k.rheology == "two") {
    s.materials = {material("friction-hbp"), material("newtonian")};
  } else {
    s.materials = {material(k.rheology)};
  }
  const int layers_y = D == 3 ? ny : 1;
  for (int a = 0; a < nx; ++a)
    for (int b = 0; b < layers_y; ++b)
      for (int z = 0; z < nz; ++z) {
        Vec<D> x;
        x[0] = (a + 0.5 + jitter(rng)) * dp;
        if (D == 3) x[1] = (b + 0.5 + jitter(rng)) * dp;
        x[D - 1] = (z + 0.8 + jitter(rng)) * dp;
        if (k.periodic) x[0] = std::fmod(x[0] + nx * dp, nx * dp);
        const uint16_t mat = s.materials.size() > 1 && z >= nz / 2 ? 1 : 0;
        const real rho0 = s.materials[mat].density;
        const real rho = rho0 * (1.0 + dens(rng));
        s.fluid.add(x, rho, rho0 * std::pow(dp, D), mat, 0);
        for (int d = 0; d < D; ++d) s.fluid.vel[d].back() = speed(rng);
      }
  // Floor: three layers under the fluid (over the whole period, or 3 dp beyond the fluid on each side).
  const int fx0 = k.periodic ? 0 : -3, fx1 = k.periodic ? nx : nx + 3;
  const int fy0 = -3, fy1 = ny + 3;
  for (int a = fx0; a < fx1; ++a)
    for (int b = (D == 3 ? fy0 : 0); b < (D == 3 ? fy1 : 1); ++b)
      for (int z = 0; z < 3; ++z) {
        Vec<D> x;
        x[0] = (a + 0.5) * dp;
        if (D == 3) x[1] = (b + 0.5) * dp;
        x[D - 1] = -z * dp;
        s.boundary.add(x, c.boundary_density * (1.0 + bdens(rng)), c.boundary_density * std::pow(dp, D), 0, 1);
      }
  if (!k.periodic)  // wall at x < 0
    for (int a = 0; a < 2; ++a)
      for (int b = (D == 3 ? fy0 : 0); b < (D == 3 ? fy1 : 1); ++b)
        for (int z = 1; z < nz + 2; ++z) {
          Vec<D> x;
          x[0] = -(a + 0.5) * dp - 0.3 * dp;
          if (D == 3) x[1] = (b + 0.5) * dp;
          x[D - 1] = z * dp;
          s.boundary.add(x, c.boundary_density * (1.0 + bdens(rng)), c.boundary_density * std::pow(dp, D), 0, 2);
        }
  return s;
}

template <int D>
void compare(const Case& k, unsigned seed) {
  const SceneSetup<D> setup = random_scene<D>(k, seed);
  Solver<D> solver(setup);
  solver.evaluate_rates();
  std::unordered_map<uint32_t, Vec<D>> normals;
  for (size_t b = 0; b < solver.boundary().size(); ++b) {
    Vec<D> n;
    for (int d = 0; d < D; ++d) n[d] = solver.boundary_normal()[d][b];
    normals[solver.boundary().id[b]] = n;
  }
  const Reference<D> ref = with_kernel<D>(setup.config.kernel, setup.config.smoothing_length,
                                          [&](auto kernel) { return reference<D>(setup, kernel, solver.max_viscosity(), normals); });
  const auto& f = solver.fluid();
  ASSERT_EQ(f.size(), setup.fluid.size());
  // Scale: the largest reference value of each quantity, so a near-zero entry does not inflate the error.
  real acc_scale = 0, drho_scale = 0, gd_scale = 0, mu_scale = 0, bdrho_scale = 0, bp_scale = 0;
  for (const auto& [id, a] : ref.acc) acc_scale = std::max(acc_scale, a.norm());
  for (const auto& [id, v] : ref.drho) drho_scale = std::max(drho_scale, std::abs(v));
  for (const auto& [id, v] : ref.shear_rate) gd_scale = std::max(gd_scale, v);
  for (const auto& [id, v] : ref.mu_eff) mu_scale = std::max(mu_scale, v);
  for (const auto& [id, v] : ref.boundary_drho) bdrho_scale = std::max(bdrho_scale, std::abs(v));
  for (const auto& [id, v] : ref.boundary_pressure)
    if (ref.boundary_near_fluid.at(id)) bp_scale = std::max(bp_scale, std::abs(v));
  ASSERT_GT(acc_scale, 1.0);
  ASSERT_GT(drho_scale, 0.0);
  ASSERT_GT(bdrho_scale, 0.0);
  real acc_err = 0, drho_err = 0, gd_err = 0, mu_err = 0, bdrho_err = 0, bp_err = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    const uint32_t id = f.id[i];
    Vec<D> a;
    for (int d = 0; d < D; ++d) a[d] = solver.fluid_acceleration()[d][i];
    acc_err = std::max(acc_err, (a - ref.acc.at(id)).norm() / acc_scale);
    drho_err = std::max(drho_err, std::abs(solver.fluid_density_rate()[i] - ref.drho.at(id)) / drho_scale);
    if (mu_scale > 0) {
      gd_err = std::max(gd_err, std::abs(solver.fluid_shear_rate()[i] - ref.shear_rate.at(id)) / gd_scale);
      mu_err = std::max(mu_err, std::abs(solver.fluid_effective_viscosity()[i] - ref.mu_eff.at(id)) / mu_scale);
    }
  }
  const auto& b = solver.boundary();
  for (size_t j = 0; j < b.size(); ++j) {
    const uint32_t id = b.id[j];
    bdrho_err = std::max(bdrho_err, std::abs(solver.boundary_density_rate()[j] - ref.boundary_drho.at(id)) / bdrho_scale);
    if (ref.boundary_near_fluid.at(id) && bp_scale > 0)
      bp_err = std::max(bp_err, std::abs(solver.boundary_pressure()[j] - ref.boundary_pressure.at(id)) / bp_scale);
  }
  // Double rounding of sums of a few hundred pair terms in another order: measured <= 5e-15 of the largest
  // value (2026-11-29). A missing, doubled or sign-flipped pair term, or a wrong neighbour set, shows at 1e-3 and
  // above (dropping the walls' no-pull clamp alone: 1e-2).
  constexpr real kTol = 1e-12;
  EXPECT_LT(acc_err, kTol) << "acceleration, seed " << seed;
  EXPECT_LT(drho_err, kTol) << "density rate, seed " << seed;
  EXPECT_LT(bdrho_err, kTol) << "boundary density rate, seed " << seed;
  EXPECT_LT(bp_err, kTol) << "boundary pressure, seed " << seed;
  if (mu_scale > 0) {
    EXPECT_LT(gd_err, kTol) << "shear rate, seed " << seed;
    EXPECT_LT(mu_err, kTol) << "effective viscosity, seed " << seed;
  }
}

}  // namespace

class ForceLoopReference : public ::testing::TestWithParam<Case> {};

TEST_P(ForceLoopReference, MatchesPlainPairLoop) {
  const Case& k = GetParam();
  for (unsigned seed : {1u, 2u, 3u}) {
    if (k.dim == 2)
      compare<2>(k, seed);
    else
      compare<3>(k, seed);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, ForceLoopReference,
    ::testing::Values(
        Case{"2d_wendland_water_dbc", 2, KernelKind::wendland, "water", BoundaryPressure::dbc, DensityDiffusion::fourtakas, 0.1, false},
        Case{"2d_cubic_friction_extrapolated_periodic", 2, KernelKind::cubic, "friction-hbp", BoundaryPressure::extrapolated, DensityDiffusion::molteni, 0.0, true},
        Case{"2d_wendland_bingham_dbc", 2, KernelKind::wendland, "bingham", BoundaryPressure::dbc, DensityDiffusion::fourtakas, 0.05, false},
        Case{"3d_cubic_water_dbc", 3, KernelKind::cubic, "water", BoundaryPressure::dbc, DensityDiffusion::fourtakas, 0.1, false},
        Case{"3d_wendland_two_materials_dbc_periodic", 3, KernelKind::wendland, "two", BoundaryPressure::dbc, DensityDiffusion::fourtakas, 0.0, true},
        Case{"3d_cubic_newtonian_extrapolated", 3, KernelKind::cubic, "newtonian", BoundaryPressure::extrapolated, DensityDiffusion::none, 0.1, false},
        Case{"3d_wendland_water_extrapolated_periodic", 3, KernelKind::wendland, "water", BoundaryPressure::extrapolated, DensityDiffusion::molteni, 0.1, true}),
    [](const auto& info) { return info.param.name; });
