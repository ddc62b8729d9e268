// The implicit viscous step (numerics.viscosity = implicit; docs/design.md, "Implicit viscous step").
//
// The explicit pass applies the Morris et al. (1997) operator a_i = -sum_j m_j w_ij (v_i - v_j) with
// w_ij = -(mu_i + mu_j) / (rho_i rho_j) F r^2 / (r^2 + eta^2) >= 0, the no-slip walls' a_i = -c_i v_i and the
// basal Coulomb friction. Its time step must stay under 0.125 h^2 rho / mu_eff, which a yield-stress material
// below its yield stress (mu_eff = m tau_y, 1e4-1e7 Pa s) cannot afford: hence the cap. Here the velocities
// v* of a half step (predictor) or a step (corrector), every other force applied, go through one
// backward-Euler step of the same terms,
//   M (1 + dt c) v + dt K v + dt M k (I - n n^T) v = M v*,   (K v)_i = sum_j m_i m_j w_ij (v_i - v_j),
// with k the friction's secant drag along the wall's tangent plane (particle_wall.hpp). The matrix is symmetric
// positive definite (a weighted graph Laplacian plus positive diagonal blocks), so the step is unconditionally
// stable and dissipative for any mu_eff; it is solved by conjugate gradients on the pair lists with the exact
// inverse of each particle's D x D diagonal block as preconditioner, warm-started from v^n. mu_eff and k are
// those of the evaluation just made (lagged: the solve is linear). Inlet buffer particles keep their
// prescribed velocity: their pairs enter the right-hand side.
#include <omp.h>

#include <algorithm>
#include <cmath>

#include "../ordered_sum.hpp"
#include "impl.hpp"
#include "runout/engine/kernels.hpp"

namespace runout {

template <int D>
bool Solver<D>::implicit_viscosity() const {
  if (config_.viscous_step != ViscousStep::implicit) return false;
  for (const auto& r : rheologies_)
    if (!r->is_inviscid()) return true;
  return false;
}

namespace {

// Per fluid pair of the lists (their layout), dt m_i m_j w_ij; per particle the mass times (1 + dt c_i) and the
// Jacobi diagonal (that plus every pair weight of the particle, both list directions).
template <int D, class Kernel, class ImplT>
void viscous_weights(const PassContext<D>& c, const Kernel& kernel, ImplT& I, size_t n, real dt,
                     std::vector<real>& self, std::vector<real>& diag) {
  auto& K = I.pass.visc_pair;
  K.resize(I.pairs.lists.buf.size());
  for (size_t t = 0; t < K.size(); ++t) K[t].resize(I.pairs.lists.buf[t].size());
  self.resize(n);
  diag.resize(n);
  auto separation = [&](const std::array<const real*, D>& Q, uint32_t j, const Vec<D>& x) {
    real r2 = 0;
    for (int d = 0; d < D; ++d) {
      real dxd = x[d] - Q[d][j];
      if (c.any_periodic && c.period[d] > 0) dxd -= c.period[d] * std::round(dxd / c.period[d]);
      r2 += dxd * dxd;
    }
    return r2;
  };
  // F r^2 / (r^2 + eta^2) of a pair at r^2 (<= 0).
  auto shape = [&](real r2) {
    const real r = std::sqrt(r2);
    return r > 0 ? kernel.grad_factor_in_support(r, 1.0 / r) * r2 / (r2 + c.eta2) : 0.0;
  };
  I.accumulate(
      n, 1, 0,
      [&](real* A, real*, PassMaxima&) {
        I.for_each_fluid([&](uint32_t i) {
          Vec<D> xi;
          for (int d = 0; d < D; ++d) xi[d] = c.P[d][i];
          const uint32_t* list = I.list_of(i);
          real* Ki = K[I.pairs.lists.thread[i]].data() + I.pairs.lists.off[i];
          const uint32_t nfl = I.pairs.lists.nf[i], nbl = I.pairs.lists.nb[i];
          const real mi = c.mass[i], mui = c.mu_eff[i], inv_rhoi = c.inv_rho[i];
          real sum = 0, wall = 0;
          for (uint32_t q = 0; q < nfl; ++q) {
            const uint32_t j = list[q];
            const real w = -(mui + c.mu_eff[j]) * inv_rhoi * c.inv_rho[j] * shape(separation(c.P, j, xi));
            const real k = dt * mi * c.mass[j] * w;
            Ki[q] = k;
            sum += k;
            A[j] += k;
          }
          for (uint32_t q = nfl; q < nfl + nbl; ++q) {
            const uint32_t b = list[q];
            wall -= c.bmass[b] * 2.0 * c.mu_wall[i] * inv_rhoi / c.brho[b] * shape(separation(c.BP, b, xi));
          }
          A[i] += sum;
          self[i] = mi * (1.0 + dt * wall);
        });
      },
      [&](auto&& fsum, size_t i, PassMaxima&) { diag[i] = self[i] + fsum(0, i); },
      [](auto&&, uint32_t, uint32_t) {});
}

// The basal friction's drag, dt m_i k_i (I - n_i n_i^T), and the Jacobi diagonal's: per particle.
template <int D>
struct FrictionDrag {
  std::vector<real> coef;                // dt m_i k_i (0: no wall push)
  std::array<const real*, D> normal{};   // n_i
  // (n_i . v) n_i subtracted from v: the tangential part.
  void tangential(size_t i, const real* v, real* t) const {
    real vn = 0;
    for (int d = 0; d < D; ++d) vn += normal[d][i] * v[d];
    for (int d = 0; d < D; ++d) t[d] = v[d] - vn * normal[d][i];
  }
};

// y = A x over the D components (x, y: n x D, particle-major); rows of fixed particles set to 0.
template <int D, class ImplT>
void viscous_apply(ImplT& I, size_t n, const std::vector<real>& self, const FrictionDrag<D>& drag,
                   const std::vector<char>& fixed, const real* x, real* y) {
  I.accumulate(
      n, D, 0,
      [&](real* A, real*, PassMaxima&) {
        I.for_each_fluid([&](uint32_t i) {
          const uint32_t* list = I.list_of(i);
          const real* Ki = I.pass.visc_pair[I.pairs.lists.thread[i]].data() + I.pairs.lists.off[i];
          const uint32_t nfl = I.pairs.lists.nf[i];
          real acc[D] = {};
          for (uint32_t q = 0; q < nfl; ++q) {
            const uint32_t j = list[q];
            for (int d = 0; d < D; ++d) {
              const real t = Ki[q] * (x[i * D + d] - x[j * D + d]);
              acc[d] += t;
              A[j * D + d] -= t;
            }
          }
          for (int d = 0; d < D; ++d) A[i * D + d] += acc[d];
        });
      },
      [&](auto&& fsum, size_t i, PassMaxima&) {
        real t[D] = {};
        if (drag.coef[i] > 0) drag.tangential(i, x + i * D, t);
        for (int d = 0; d < D; ++d)
          y[i * D + d] = fixed[i] ? 0.0 : self[i] * x[i * D + d] + drag.coef[i] * t[d] + fsum(d, i);
      },
      [](auto&&, uint32_t, uint32_t) {});
}

// z = P^-1 r with P the block diagonal of A: a I + b (I - n n^T), inverted exactly.
template <int D>
void precondition(size_t n, const std::vector<real>& diag, const FrictionDrag<D>& drag, const real* r, real* z) {
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const real a = diag[i], b = drag.coef[i];
    real t[D] = {};
    if (b > 0) drag.tangential(i, r + i * D, t);
    for (int d = 0; d < D; ++d) z[i * D + d] = (r[i * D + d] - t[d]) / a + t[d] / (a + b);
  }
}

// Repeats to the bit at a given thread count (ordered_sum.hpp): a CG that iterates differently from run to run
// would make no two-thread run repeat.
real dot(size_t nd, const real* a, const real* b) {
  return ordered_sum(nd, [&](size_t k) { return a[k] * b[k]; });
}

}  // namespace

template <int D>
void Solver<D>::implicit_viscous_step(real dt) {
  auto& I = *impl_;
  auto& pass = I.pass;
  const size_t n = fluid_.size();
  const size_t nd = n * D;
  const PassContext<D> c = pass_context();
  std::vector<real> self, diag;
  with_kernel<D>(config_.kernel, config_.smoothing_length,
                 [&](auto kernel) { viscous_weights<D>(c, kernel, I, n, dt, self, diag); });
  FrictionDrag<D> drag;
  drag.coef.assign(n, 0.0);
  if (!pass.friction_drag.empty()) {
    for (int d = 0; d < D; ++d) drag.normal[d] = pass.friction_normal[d].data();
    for (size_t i = 0; i < n; ++i) drag.coef[i] = dt * fluid_.mass[i] * pass.friction_drag[i];
  }
  std::vector<char> fixed(n, 0);
  if (!inlets_.empty())
    for (size_t i = 0; i < n; ++i) fixed[i] = is_inlet_buffer(fluid_.tag[i]);
  // x: v^n warm start where free, the prescribed velocity where fixed; b = M v*.
  std::vector<real> x(nd), b(nd), r(nd), z(nd), p(nd), q(nd);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i)
    for (int d = 0; d < D; ++d) {
      x[i * D + d] = fixed[i] ? fluid_.vel[d][i] : saved_.vel[d][i];
      b[i * D + d] = fixed[i] ? 0.0 : fluid_.mass[i] * fluid_.vel[d][i];
    }
  viscous_apply<D>(I, n, self, drag, fixed, x.data(), q.data());
#pragma omp parallel for schedule(static)
  for (size_t k = 0; k < nd; ++k) r[k] = b[k] - q[k];
  precondition<D>(n, diag, drag, r.data(), z.data());
  precondition<D>(n, diag, drag, b.data(), q.data());
  const real scale2 = dot(nd, b.data(), q.data());  // b's P^-1 norm: the residual's scale
  for (size_t i = 0; i < n; ++i)
    if (fixed[i])
      for (int d = 0; d < D; ++d) x[i * D + d] = 0, z[i * D + d] = 0;
  p = z;
  real rz = dot(nd, r.data(), z.data());
  const real tol2 = config_.viscous_tolerance * config_.viscous_tolerance;
  int it = 0;
  real res2 = scale2 > 0 ? rz / scale2 : 0.0;
  while (res2 > tol2 && it < config_.viscous_max_iterations) {
    viscous_apply<D>(I, n, self, drag, fixed, p.data(), q.data());
    const real pq = dot(nd, p.data(), q.data());
    const real alpha = pq > 0 ? rz / pq : 0.0;
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nd; ++k) {
      x[k] += alpha * p[k];
      r[k] -= alpha * q[k];
    }
    precondition<D>(n, diag, drag, r.data(), z.data());
    const real rz_new = dot(nd, r.data(), z.data());
    const real beta = rz > 0 ? rz_new / rz : 0.0;
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < nd; ++k) p[k] = z[k] + beta * p[k];
    rz = rz_new;
    res2 = rz / scale2;
    ++it;
  }
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i)
    if (!fixed[i])
      for (int d = 0; d < D; ++d) fluid_.vel[d][i] = x[i * D + d];
  const real res = std::sqrt(res2);
  record_.stats.viscous_iterations = it;
  record_.stats.viscous_residual = res;
  auto& s = record_.viscous;
  ++s.solves;
  s.iterations += it;
  s.max_iterations = std::max<long>(s.max_iterations, it);
  s.max_residual = std::max(s.max_residual, res);
  if (res2 > tol2) ++s.unconverged;
}

template bool Solver<2>::implicit_viscosity() const;
template bool Solver<3>::implicit_viscosity() const;
template void Solver<2>::implicit_viscous_step(real);
template void Solver<3>::implicit_viscous_step(real);

}  // namespace runout
