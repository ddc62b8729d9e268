#include "impl.hpp"
#include "runout/engine/eos.hpp"
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace runout {

namespace {

// |x - q_k|^2 for a contiguous run of particles (SoA): a plain vector loop.
void distances_squared3(const real* __restrict a, const real* __restrict b, const real* __restrict c, real xa, real xb,
                        real xc, uint32_t m, real* __restrict out) {
  for (uint32_t k = 0; k < m; ++k) {
    const real da = xa - a[k], db = xb - b[k], dc = xc - c[k];
    out[k] = da * da + db * db + dc * dc;
  }
}
void distances_squared2(const real* __restrict a, const real* __restrict b, real xa, real xb, uint32_t m,
                        real* __restrict out) {
  for (uint32_t k = 0; k < m; ++k) {
    const real da = xa - a[k], db = xb - b[k];
    out[k] = da * da + db * db;
  }
}

// Pair geometry of list entries [q0, q1) of a particle at x with density rho_i (no periodic axes): separations,
// r^2, r, inv = 1 / (r (r^2 + eta^2) (rho_i + rho_j)) and F. A vector loop (gathers).
template <int D, class Kernel>
void pair_geometry(const Kernel& kernel, const uint32_t* __restrict list, uint32_t q0, uint32_t q1,
                   const real* __restrict qa, const real* __restrict qb, const real* __restrict qc,
                   const real* __restrict rhoq, real xa, real xb, real xc, real rhoi, real eta2, real* __restrict da,
                   real* __restrict db, real* __restrict dc, real* __restrict r2o, real* __restrict ro,
                   real* __restrict invo, real* __restrict Fo) {
  for (uint32_t q = q0; q < q1; ++q) {
    const uint32_t j = list[q];
    const real a = xa - qa[j], b = xb - qb[j];
    real r2 = a * a + b * b;
    da[q] = a;
    db[q] = b;
    if constexpr (D == 3) {
      const real c = xc - qc[j];
      r2 += c * c;
      dc[q] = c;
    }
    const real r = std::sqrt(r2), e = r2 + eta2, rs = rhoi + rhoq[j];
    const real inv = 1.0 / (r * e * rs);
    r2o[q] = r2;
    ro[q] = r;
    invo[q] = inv;
    Fo[q] = kernel.grad_factor_in_support(r, inv * e * rs);
  }
}

// One particle's pair list, worked out before its force loop (see prepare() in evaluate).
template <int D>
struct PairGeometry {
  std::array<std::vector<real>, D> dx;
  std::vector<real> r2, r, inv, F;
  void ensure(size_t n) {
    if (r2.size() >= n) return;
    const size_t m = std::max<size_t>({n, 2 * r2.size(), 256});
    for (auto& v : dx) v.resize(m);
    r2.resize(m);
    r.resize(m);
    inv.resize(m);
    F.resize(m);
  }
};

}  // namespace

// The interaction kernels. Templated on the kernel and on whether the stress term exists, so the pair
// loops carry no runtime model switches.
//
// Pairs: each evaluation first lists, for every fluid particle i, its fluid neighbours j > i in the half
// stencil (the own column with higher indices, and the columns "after" it), so each fluid pair is listed
// once, then all its boundary neighbours. The listing test is branch-free. The passes then walk the lists and
// apply each pair's term to both particles (the terms are antisymmetric or symmetric in i and j); the j side
// and the boundary side go to per-thread accumulators, summed after the pass, so no two threads write the
// same memory and no pair is evaluated twice.
template <int D>
void Solver<D>::evaluate(bool compute_dt) {
  auto& I = *impl_;
  constexpr int kNb = Impl::kNb;
  constexpr int kHalf = Impl::kHalf;
  const size_t n = fluid_.size();
  const size_t ncells = I.fcell_key.size();
  const real h = config_.smoothing_length;
  const real c0 = config_.speed_of_sound;
  const real gam = config_.eos_gamma;
  const real eta2 = 0.01 * h * h;
  const real alpha = config_.artificial_viscosity;
  const bool ddt_on = config_.density_diffusion != DensityDiffusion::none && config_.density_diffusion_delta > 0;
  const real ddt_coef = ddt_on ? 2.0 * config_.density_diffusion_delta * h * c0 : 0.0;
  const bool fourtakas = config_.density_diffusion == DensityDiffusion::fourtakas;
  Vec<D> g;
  for (int d = 0; d < D; ++d) g[d] = config_.gravity[d];
  const real inv_c0_sq = 1.0 / (c0 * c0);
  const real contact2 = kWallContact * kWallContact * config_.dp * config_.dp;
  // Slip speed below which basal Coulomb friction is proportional to the slip (regularisation).
  const real v_slip = 0.01 * std::sqrt(9.81 * config_.dp);
  const int nthreads = omp_get_max_threads();

  bool viscous = false;
  for (const auto& r : rheologies_) viscous = viscous || !r->is_inviscid();

  // Equation of state (Tait), per material for fluid; boundary particles use the boundary density.
  std::vector<TaitEOS> eos(materials_.size());
  std::vector<real> rho0(materials_.size()), p_min(materials_.size()), wall_friction(materials_.size());
  for (size_t k = 0; k < materials_.size(); ++k) {
    rho0[k] = materials_[k].density;
    eos[k] = TaitEOS(c0, rho0[k], gam);
    // A cohesionless granular material carries no tension: without this floor a spreading sheet goes into
    // tension, clumps and sinks into the bed's lattice (docs/validation.md, "Thin sheets on terrain").
    p_min[k] = -rheologies_[k]->tensile_strength();
    wall_friction[k] = rheologies_[k]->wall_friction_coefficient();
  }
  I.vol.resize(n);
  I.pt.resize(n);
  I.inv_rho.resize(n);
  I.neighbour_pack.resize(Impl::kPackStride * n);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    const int k = fluid_.material[i];
    const real r = fluid_.rho[i];
    pressure_[i] = std::max(eos[k].pressure(r), p_min[k]);
    I.inv_rho[i] = 1.0 / r;
    I.vol[i] = fluid_.mass[i] * I.inv_rho[i];
    I.pt[i] = pressure_[i] * I.inv_rho[i] * I.inv_rho[i];
    real* pk = I.neighbour_pack.data() + Impl::kPackStride * i;
    for (int d = 0; d < D; ++d) pk[d] = fluid_.vel[d][i];
    pk[Impl::kPackRho] = r;
    pk[Impl::kPackVol] = I.vol[i];
    pk[Impl::kPackPt] = I.pt[i];
    pk[Impl::kPackPm] = pressure_[i];
    pk[Impl::kPackInvRho] = I.inv_rho[i];
  }
  const real rho0_b = config_.boundary_density;
  const TaitEOS eos_b(c0, rho0_b, gam);
  const size_t nact = I.active_bcells.size();
  const size_t nslots = I.active_boundary_count;
  const bool extrapolated = config_.boundary_pressure == BoundaryPressure::extrapolated;
  if (!extrapolated) {
#pragma omp parallel for schedule(static)
    for (size_t a = 0; a < nact; ++a) {
      const uint32_t cb = I.active_bcells[a];
      for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b)
        boundary_pressure_[b] = eos_b.pressure(boundary_.rho[b]);
    }
  }

  real max_acc = 0, max_visc_term = 0, max_nu = 0;

  I.list_buf.resize(nthreads);
  I.list_off.resize(n);
  I.list_nf.resize(n);
  I.list_nb.resize(n);
  I.list_thread.resize(n);
  I.acc_f.resize(nthreads);
  I.acc_b.resize(nthreads);
  I.bvol.resize(boundary_.size());
  I.bpt.resize(boundary_.size());

  // kViscous: the scene has a stress term (pass 1 measures the velocity gradient first); without one,
  // continuity and momentum share a single pass over the pairs.
  auto interact = [&]<bool kViscous>(auto kernel) {
    const real support2 = kernel.support() * kernel.support();
    // Raw pointers held in locals: the compiler need not reload them after every accumulator store.
    std::array<const real*, D> P, V, BP;
    for (int d = 0; d < D; ++d) {
      P[d] = fluid_.pos[d].data();
      V[d] = fluid_.vel[d].data();
      BP[d] = boundary_.pos[d].data();
    }
    const real* mass = fluid_.mass.data();
    const real* rho = fluid_.rho.data();
    const uint16_t* mat = fluid_.material.data();
    const real* press = pressure_.data();
    const real* bmass = boundary_.mass.data();
    const real* brho = boundary_.rho.data();
    const real* bpress = boundary_pressure_.data();
    const uint32_t* bslot = I.bslot.data();
    const real* vol = I.vol.data();
    const real* pt = I.pt.data();
    const real* inv_rho = I.inv_rho.data();
    const real* pack = I.neighbour_pack.data();
    constexpr int kPS = Impl::kPackStride, kPRho = Impl::kPackRho, kPVol = Impl::kPackVol, kPPt = Impl::kPackPt,
                  kPPm = Impl::kPackPm, kPInvRho = Impl::kPackInvRho;
    const real* bvol = I.bvol.data();
    const real* bpt = I.bpt.data();
    // Periodic axes: pair separations take the nearest image (the period is >= 5 h, so it is unique).
    const Vec<D> period = I.period;
    bool any_periodic = false;
    for (int d = 0; d < D; ++d) any_periodic = any_periodic || period[d] > 0;

    // Pair lists. The store is unconditional and the cursor advances by the test's outcome: no branch to
    // mispredict on the ~3/4 of candidates that fall outside the support.
#pragma omp parallel
    {
      const int t = omp_get_thread_num();
      auto& buf = I.list_buf[t];
      size_t pos = 0;
      std::vector<real> r2buf;
      // Distances of a contiguous run first (a vector loop), then the branch-free compaction.
      auto scan = [&](const std::array<const real*, D>& Q, const Vec<D>& xs, uint32_t j0, uint32_t j1) {
        if (j1 <= j0) return;
        const uint32_t m = j1 - j0;
        if (buf.size() < pos + m) buf.resize(std::max<size_t>(2 * buf.size(), pos + m + 1024));
        if (r2buf.size() < m) r2buf.resize(std::max<size_t>(m, 2 * r2buf.size()));
        real* __restrict r2s = r2buf.data();
        if constexpr (D == 3)
          distances_squared3(Q[0] + j0, Q[1] + j0, Q[2] + j0, xs[0], xs[1], xs[2], m, r2s);
        else
          distances_squared2(Q[0] + j0, Q[1] + j0, xs[0], xs[1], m, r2s);
        uint32_t* out = buf.data();
        for (uint32_t k = 0; k < m; ++k) {
          out[pos] = j0 + k;
          pos += (r2s[k] < support2) & (r2s[k] >= 1e-24);
        }
      };
#pragma omp for schedule(dynamic, 16)
      for (size_t c = 0; c < ncells; ++c) {
        for (uint32_t i = I.fcell_begin[c]; i < I.fcell_begin[c + 1]; ++i) {
          Vec<D> xi;
          for (int d = 0; d < D; ++d) xi[d] = P[d][i];
          const size_t start = pos;
          for (int k = 0; k < I.fnb_half_n[c]; ++k) {
            const auto& blk = I.fnb_half[c * kHalf + k];
            // Block 0 is the particle's own column: only the higher indices (the pair's other half is listed
            // by the lower-index particle).
            scan(P, xi - I.shifts[blk.shift], k == 0 ? i + 1 : blk.begin, blk.end);
          }
          const size_t nf = pos - start;
          for (int k = 0; k < I.fnb_bound_n[c]; ++k) {
            const auto& blk = I.fnb_bound[c * kNb + k];
            scan(BP, xi - I.shifts[blk.shift], blk.begin, blk.end);
          }
          I.list_thread[i] = static_cast<uint16_t>(t);
          I.list_off[i] = static_cast<uint32_t>(start);
          I.list_nf[i] = static_cast<uint32_t>(nf);
          I.list_nb[i] = static_cast<uint32_t>(pos - start - nf);
        }
      }
    }

    // Runs body(A, Bacc) in a parallel region in which each thread owns accumulators A (nf_fields values per
    // fluid particle, particle-major so one pair's updates share a cache line) and Bacc (nb_fields per active
    // boundary particle), zeroed; then, after the barrier, finish_fluid(sum, i) for every fluid particle with
    // sum(f, i) the total over threads, and finish_boundary(bsum, b, slot) for every active boundary particle.
    auto accumulate = [&](int nf_fields, int nb_fields, auto&& body, auto&& finish_fluid, auto&& finish_boundary) {
#pragma omp parallel reduction(max : max_acc, max_visc_term, max_nu)
      {
        const int t = omp_get_thread_num();
        const int T = omp_get_num_threads();
        auto& A = I.acc_f[t];
        auto& Bacc = I.acc_b[t];
        A.assign(static_cast<size_t>(nf_fields) * n, 0.0);
        Bacc.assign(static_cast<size_t>(nb_fields) * nslots, 0.0);
        body(A.data(), Bacc.data());
        // (the worksharing loop in body ends with a barrier: every thread's accumulators are complete)
        auto fsum = [&](int f, size_t i) {
          real s = 0;
          for (int u = 0; u < T; ++u) s += I.acc_f[u][i * nf_fields + f];
          return s;
        };
        auto bsum = [&](int f, size_t q) {
          real s = 0;
          for (int u = 0; u < T; ++u) s += I.acc_b[u][q * nb_fields + f];
          return s;
        };
#pragma omp for schedule(static)
        for (size_t i = 0; i < n; ++i) finish_fluid(fsum, i);
        if (nb_fields > 0) {
#pragma omp for schedule(static)
          for (size_t a = 0; a < nact; ++a) {
            const uint32_t cb = I.active_bcells[a];
            for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b) finish_boundary(bsum, b, bslot[b]);
          }
        }
      }
    };
    auto list_of = [&](uint32_t i) { return I.list_buf[I.list_thread[i]].data() + I.list_off[i]; };
    // The fluid particles, cell by cell, shared among the threads of the enclosing parallel region.
    auto for_each_fluid = [&](auto&& f) {
#pragma omp for schedule(dynamic, 16)
      for (size_t c = 0; c < ncells; ++c)
        for (uint32_t i = I.fcell_begin[c]; i < I.fcell_begin[c + 1]; ++i) f(i);
    };
    auto state_of = [&](uint32_t i, Vec<D>& xi, Vec<D>& vi) {
      for (int d = 0; d < D; ++d) {
        xi[d] = P[d][i];
        vi[d] = V[d][i];
      }
    };

    // Extrapolated boundary pressure (Adami et al. 2012 with the hydrostatic term):
    // p_b = sum_f (p_f + rho_f g.(x_b - x_f)) W_bf / sum_f W_bf, clamped at 0; density from the EOS.
    if (extrapolated) {
      accumulate(
          0, 2,
          [&](real*, real* Bacc) {
#pragma omp for schedule(dynamic, 16)
            for (size_t c = 0; c < ncells; ++c) {
              for (uint32_t i = I.fcell_begin[c]; i < I.fcell_begin[c + 1]; ++i) {
                const uint32_t* L = list_of(i) + I.list_nf[i];
                for (uint32_t q = 0; q < I.list_nb[i]; ++q) {
                  const uint32_t b = L[q];
                  real r2 = 0, gdx = 0;
                  for (int d = 0; d < D; ++d) {
                    // x_b - x_f up to the periodic image: the same as -(x_i - x_b) from the fluid's side.
                    real dxd = BP[d][b] - P[d][i];
                    if (any_periodic && period[d] > 0) dxd -= period[d] * std::round(dxd / period[d]);
                    r2 += dxd * dxd;
                    gdx += g[d] * dxd;
                  }
                  const real w = kernel.W(std::sqrt(r2));
                  Bacc[2 * bslot[b]] += w;
                  Bacc[2 * bslot[b] + 1] += (press[i] + rho[i] * gdx) * w;
                }
              }
            }
          },
          [](auto&&, size_t) {},
          [&](auto&& bsum, uint32_t b, uint32_t s) {
            const real sw = bsum(0, s), spw = bsum(1, s);
            const real pb = sw > 0 ? std::max(spw / sw, 0.0) : 0.0;
            boundary_pressure_[b] = pb;
            boundary_.rho[b] = eos_b.density(pb);
          });
    }

#pragma omp parallel for schedule(static)
    for (size_t a = 0; a < nact; ++a) {
      const uint32_t cb = I.active_bcells[a];
      for (uint32_t b = I.bcell_begin[cb]; b < I.bcell_begin[cb + 1]; ++b) {
        I.bvol[b] = bmass[b] / brho[b];
        I.bpt[b] = bpress[b] / (brho[b] * brho[b]);
      }
    }

    // Pair geometry in two stages. prepare() runs over a particle's whole list first: separations (periodic
    // image), r, F and one reciprocal per pair, inv = 1 / (r (r^2 + eta^2) (rho_i + rho_j)), from which 1/r,
    // 1/(r^2 + eta^2) and 1/(rho_i + rho_j) follow by products. A short loop of independent square roots and
    // divisions keeps the pipelines full; inside the long force loop their latency stalled it.
    auto prepare = [&](PairGeometry<D>& G, const Vec<D>& xi, real rhoi, const uint32_t* list, uint32_t nfl,
                       uint32_t nbl) {
      G.ensure(nfl + nbl);
      // Restrict-qualified locals: the stores cannot alias the loads, so the loop vectorises (gathers).
      real* __restrict gdx[3] = {G.dx[0].data(), G.dx[D > 1 ? 1 : 0].data(), G.dx[D > 2 ? 2 : 0].data()};
      real* __restrict gr2 = G.r2.data();
      real* __restrict gr = G.r.data();
      real* __restrict ginv = G.inv.data();
      real* __restrict gF = G.F.data();
      auto stage = [&]<bool kPeriodic>(uint32_t q0, uint32_t q1, const std::array<const real*, D> Q,
                                       const real* __restrict rhoQ) {
        const Vec<D> x = xi;
        for (uint32_t q = q0; q < q1; ++q) {
          const uint32_t j = list[q];
          real r2 = 0;
          for (int d = 0; d < D; ++d) {
            real dxd = x[d] - Q[d][j];
            if constexpr (kPeriodic)
              if (period[d] > 0) dxd -= period[d] * std::round(dxd / period[d]);
            gdx[d][q] = dxd;
            r2 += dxd * dxd;
          }
          const real r = std::sqrt(r2), e = r2 + eta2, rs = rhoi + rhoQ[j];
          const real inv = 1.0 / (r * e * rs);
          gr2[q] = r2;
          gr[q] = r;
          ginv[q] = inv;
          gF[q] = kernel.grad_factor_in_support(r, inv * e * rs);
        }
      };
      if (any_periodic) {
        stage.template operator()<true>(0, nfl, P, rho);
        stage.template operator()<true>(nfl, nfl + nbl, BP, brho);
      } else {
        const real xc = D == 3 ? xi[D - 1] : 0.0;
        pair_geometry<D>(kernel, list, 0, nfl, P[0], P[1], P[D - 1], rho, xi[0], xi[1], xc, rhoi, eta2, gdx[0],
                         gdx[1], gdx[2], gr2, gr, ginv, gF);
        pair_geometry<D>(kernel, list, nfl, nfl + nbl, BP[0], BP[1], BP[D - 1], brho, xi[0], xi[1], xc, rhoi, eta2,
                         gdx[0], gdx[1], gdx[2], gr2, gr, ginv, gF);
      }
    };
    // Entry q of the list: dx = x_i - x_j, r2, v_ij and v_ij . dx (fluid j; a wall has v = 0).
    auto fluid_at = [&](const PairGeometry<D>& G, uint32_t q, const Vec<D>& vi, const real* pk, Vec<D>& dx, Vec<D>& vij,
                        real& vdotdx) {
      vdotdx = 0;
      for (int d = 0; d < D; ++d) {
        dx[d] = G.dx[d][q];
        vij[d] = vi[d] - pk[d];
        vdotdx += vij[d] * dx[d];
      }
      return G.r2[q];
    };
    auto wall_at = [&](const PairGeometry<D>& G, uint32_t q, const Vec<D>& vi, Vec<D>& dx, real& vdotdx) {
      vdotdx = 0;
      for (int d = 0; d < D; ++d) {
        dx[d] = G.dx[d][q];
        vdotdx += vi[d] * dx[d];
      }
      return G.r2[q];
    };
    // Density diffusion of one same-material fluid pair: the term for i is -dr F V_j, for j +dr F V_i.
    // Fourtakas et al. (2019) subtract the hydrostatic density difference, linearised:
    // rho0 g.(x_j - x_i) / c0^2 (exact to O((g h / c0^2)^2)).
    auto diffusion_dr = [&](real rhoi, real rhoj, int mi, const Vec<D>& dx) {
      real dr = rhoj - rhoi;
      if (fourtakas) dr += rho0[mi] * g.dot(dx) * inv_c0_sq;
      return dr;
    };

    constexpr int kDiv = 0, kDiff = 1;
    if constexpr (kViscous) {
      // Pass 1: continuity with density diffusion, the velocity gradient L = -sum V_j v_ij (x) grad W, the
      // kernel-averaged pressure for the yield stress, and the boundary's DBC continuity.
      constexpr int kPw = 2, kWw = 3, kL = 4;  // L: D*D fields, row-major
      constexpr int kS1 = kL + D * D;
      accumulate(
          kS1, 1,
          [&](real* A, real* Bacc) {
            PairGeometry<D> G;
            for_each_fluid([&](uint32_t i) {
              Vec<D> xi, vi;
              state_of(i, xi, vi);
              const real rhoi = rho[i], Vi = vol[i], pi = press[i];
              const int mi = mat[i];
              real div = 0, diff = 0, pw = 0, ww = 0;
              Mat<D> L = Mat<D>::Zero();
              const uint32_t* list = list_of(i);
              const uint32_t nfl = I.list_nf[i], nbl = I.list_nb[i];
              prepare(G, xi, rhoi, list, nfl, nbl);
              for (uint32_t q = 0; q < nfl; ++q) {
                const uint32_t j = list[q];
                Vec<D> dx, vij;
                real vdotdx;
                const real* pk = pack + kPS * j;
                fluid_at(G, q, vi, pk, dx, vij, vdotdx);
                const real F = G.F[q], W = kernel.W(G.r[q]);
                const real Vj = pk[kPVol];
                div += Vj * F * vdotdx;
                A[j * kS1 + kDiv] += Vi * F * vdotdx;
                if (ddt_coef > 0 && mat[j] == mi) {
                  const real dr = diffusion_dr(rhoi, pk[kPRho], mi, dx);
                  diff -= dr * F * Vj;
                  A[j * kS1 + kDiff] += dr * F * Vi;
                }
                // L_i -= V_j F v_ij dx^T and L_j -= V_i F v_ji dx_ji^T = V_i F v_ij dx^T.
                for (int a = 0; a < D; ++a)
                  for (int b = 0; b < D; ++b) {
                    const real vd = F * vij[a] * dx[b];
                    L(a, b) -= Vj * vd;
                    A[j * kS1 + (kL + a * D + b)] -= Vi * vd;
                  }
                pw += Vj * W * pk[kPPm];
                ww += Vj * W;
                A[j * kS1 + kPw] += Vi * W * pi;
                A[j * kS1 + kWw] += Vi * W;
              }
              for (uint32_t q = nfl; q < nfl + nbl; ++q) {
                const uint32_t b = list[q];
                Vec<D> dx;
                real vdotdx;
                wall_at(G, q, vi, dx, vdotdx);
                const real F = G.F[q];
                div += bvol[b] * F * vdotdx;
                // No-slip wall, v_b = 0: the same wall velocity the viscous force of pass 2 acts against. (A
                // mirrored v_b = -v_i, needed by the former stress-divergence force for energy consistency,
                // overestimates the wall shear rate: the Bingham Poiseuille plug then ran 9 % fast.)
                L.noalias() -= (bvol[b] * F) * vi * dx.transpose();
                // DBC continuity of b, drho_b/dt = rho_b sum V_f (0 - v_f) . grad_b W = rho_b sum V_f F v_f . dx.
                Bacc[bslot[b]] += Vi * F * vdotdx;
              }
              A[i * kS1 + kDiv] += div;
              A[i * kS1 + kDiff] += diff;
              A[i * kS1 + kPw] += pw;
              A[i * kS1 + kWw] += ww;
              for (int a = 0; a < D; ++a)
                for (int b = 0; b < D; ++b) A[i * kS1 + (kL + a * D + b)] += L(a, b);
            });
          },
          [&](auto&& sum, size_t i) {
            // The kernel-averaged pressure includes the particle itself.
            const real self = mass[i] / rho[i] * kernel.W(0);
            yield_pressure_[i] = (sum(kPw, i) + self * press[i]) / (sum(kWw, i) + self);
            drho_[i] = rho[i] * sum(kDiv, i) + ddt_coef * sum(kDiff, i);
            Mat<D> L;
            for (int a = 0; a < D; ++a)
              for (int b = 0; b < D; ++b) L(a, b) = sum(kL + a * D + b, i);
            // Strain rate D = sym(L); deviator with the 3D trace (plane strain in 2D).
            const Mat<D> Ds = 0.5 * (L + L.transpose());
            const real tr3 = Ds.trace() / 3.0;
            Mat<D> Dd = Ds;
            for (int d = 0; d < D; ++d) Dd(d, d) -= tr3;
            real dd = Dd.squaredNorm();
            if constexpr (D == 2) dd += tr3 * tr3;  // the zz component of the plane-strain deviator
            shear_rate_[i] = std::max(std::sqrt(2.0 * dd), config_.shear_rate_floor);
          },
          [&](auto&& bsum, uint32_t b, uint32_t s) { boundary_drho_[b] = brho[b] * bsum(0, s); });

      // Rheology: one call per material batch.
      if (materials_.size() == 1) {
        rheologies_[0]->effective_viscosity(shear_rate_, yield_pressure_, mu_eff_);
        if (wall_friction[0] > 0) {
          std::fill(zero_pressure_.begin(), zero_pressure_.end(), real(0));
          rheologies_[0]->effective_viscosity(shear_rate_, zero_pressure_, mu_wall_);
        }
      } else {
        for (size_t k = 0; k < materials_.size(); ++k) {
          std::vector<uint32_t> idx;
          for (size_t i = 0; i < n; ++i)
            if (fluid_.material[i] == k) idx.push_back(static_cast<uint32_t>(i));
          std::vector<real> gd(idx.size()), p(idx.size()), mu(idx.size());
          for (size_t q = 0; q < idx.size(); ++q) {
            gd[q] = shear_rate_[idx[q]];
            p[q] = yield_pressure_[idx[q]];
          }
          rheologies_[k]->effective_viscosity(gd, p, mu);
          for (size_t q = 0; q < idx.size(); ++q) mu_eff_[idx[q]] = mu[q];
          if (wall_friction[k] > 0) {
            std::fill(p.begin(), p.end(), real(0));
            rheologies_[k]->effective_viscosity(gd, p, mu);
            for (size_t q = 0; q < idx.size(); ++q) mu_wall_[idx[q]] = mu[q];
          }
        }
      }
      const real cap = max_viscosity_;
#pragma omp parallel for schedule(static) reduction(max : max_nu)
      for (size_t i = 0; i < n; ++i) {
        const real mu = std::min(mu_eff_[i], cap);
        mu_eff_[i] = mu;
        mu_wall_[i] = wall_friction[fluid_.material[i]] > 0 ? std::min(mu_wall_[i], cap) : mu;
        max_nu = std::max(max_nu, mu / rho[i]);
        I.neighbour_pack[Impl::kPackStride * i + Impl::kPackPm] = mu;  // pass 2 reads mu_eff where pass 1 read p
      }
    }

    // Pass 2: momentum (pressure, artificial viscosity, rheology stress, gravity); in inviscid scenes also
    // continuity and the boundary's DBC continuity. The rheology stress acts through the Morris et al. (1997)
    // viscous operator with each particle's capped mu_eff from pass 1 (the same for every rheology): a one-step
    // Laplacian stencil, with no odd-even null mode, unlike the divergence of tau = 2 mu_eff D' built from the
    // SPH velocity gradient (alternate particle rows slid past each other). It approximates div(mu_eff grad v)
    // and drops the grad(mu_eff) . (grad v)^T part of div(2 mu_eff D'), which vanishes in simple shear
    // (docs/design.md). Pairwise symmetric and v_ij-parallel, so it conserves momentum and can only dissipate
    // energy.
    constexpr int kAcc = kViscous ? 0 : 2;  // first of D acceleration fields (inviscid: after div and diff)
    constexpr int kS2 = kAcc + D;
    accumulate(
        kS2, kViscous ? 0 : 1,
        [&](real* A, real* Bacc) {
            PairGeometry<D> G;
          for_each_fluid([&](uint32_t i) {
            Vec<D> xi, vi;
            state_of(i, xi, vi);
            const real rhoi = rho[i], mi_mass = mass[i], Vi = vol[i];
            const int mi = mat[i];
            const real pi_term = pt[i];
            const real mui = kViscous ? mu_eff_[i] : 0.0;
            const real mu_wall_i = kViscous ? mu_wall_[i] : 0.0;
            const real friction_i = kViscous ? wall_friction[mi] : 0.0;
            Vec<D> a = Vec<D>::Zero();
            Vec<D> a_wall_push = Vec<D>::Zero();  // the walls' pressure force on the particle, per unit mass
            bool contact = false;                 // closer than kWallContact dp to a wall particle
            Vec<D> wall_normal = Vec<D>::Zero();  // -sum_b V_b grad W: points away from the wall
            real visc_max = 0, div = 0, diff = 0;
            const uint32_t* list = list_of(i);
            const uint32_t nfl = I.list_nf[i], nbl = I.list_nb[i];
            prepare(G, xi, rhoi, list, nfl, nbl);
            for (uint32_t q = 0; q < nfl; ++q) {
              const uint32_t j = list[q];
              Vec<D> dx, vij;
              real vdotdx;
              const real* pk = pack + kPS * j;
              const real r2 = fluid_at(G, q, vi, pk, dx, vij, vdotdx);
              const real rhoj = pk[kPRho], Vj = pk[kPVol], mj = Vj * rhoj;
              const real r = G.r[q], e = r2 + eta2, rs = rhoi + rhoj, inv = G.inv[q];
              const real inv_e = inv * r * rs;
              const real F = G.F[q];
              if constexpr (!kViscous) {
                div += Vj * F * vdotdx;
                A[j * kS2 + kDiv] += Vi * F * vdotdx;
                if (ddt_coef > 0 && mat[j] == mi) {
                  const real dr = diffusion_dr(rhoi, rhoj, mi, dx);
                  diff -= dr * F * Vj;
                  A[j * kS2 + kDiff] += dr * F * Vi;
                }
              }
              real pterm = pi_term + pk[kPPt];
              const real mu_ij = h * vdotdx * inv_e;
              visc_max = std::max(visc_max, std::abs(mu_ij));
              // Monaghan: approaching pairs only, over the mean density; a select, not a branch (the sign is as
              // good as random).
              if (alpha > 0) pterm -= 2.0 * alpha * c0 * std::min(mu_ij, real(0)) * (inv * r * e);
              // a_i = m_j s, a_j = -m_i s with s = -pterm F dx + (Morris) visc v_ij: antisymmetric in i, j.
              Vec<D> s = (-pterm * F) * dx;
              if constexpr (kViscous) {
                // Morris et al. (1997): (mu_i + mu_j) / (rho_i rho_j) (r_ij . grad W) / (r^2 + eta^2) v_ij,
                // r_ij . grad W = F r^2 (F < 0: the pair force opposes v_ij).
                s += ((mui + pk[kPPm]) * inv_rho[i] * pk[kPInvRho] * F * r2 * inv_e) * vij;
              }
              a += mj * s;
              for (int d = 0; d < D; ++d) A[j * kS2 + (kAcc + d)] -= mi_mass * s[d];
            }
            // Boundary neighbours: no-slip (v_b = 0, so v_ij = v_i), DBC or extrapolated pressure; the wall
            // particle takes the fluid particle's viscosity (mu_b = mu_i).
            for (uint32_t q = nfl; q < nfl + nbl; ++q) {
              const uint32_t b = list[q];
              Vec<D> dx;
              real vdotdx;
              const real r2 = wall_at(G, q, vi, dx, vdotdx);
              const real rhob = brho[b], mb = bmass[b];
              const real r = G.r[q], e = r2 + eta2, rs = rhoi + rhob, inv = G.inv[q];
              const real inv_e = inv * r * rs;
              const real F = G.F[q];
              if constexpr (!kViscous) {
                div += bvol[b] * F * vdotdx;
                Bacc[bslot[b]] += Vi * F * vdotdx;  // DBC continuity of b (see pass 1)
              }
              // A wall pushes and never pulls: where a fluid particle's pressure is negative (a liquid may
              // carry tension) the pair term would draw it into the wall's particle lattice.
              real pterm = std::max(pi_term + bpt[b], real(0));
              const real mu_ij = h * vdotdx * inv_e;
              visc_max = std::max(visc_max, std::abs(mu_ij));
              if (alpha > 0) pterm -= 2.0 * alpha * c0 * std::min(mu_ij, real(0)) * (inv * r * e);
              const Vec<D> push = (-mb * pterm * F) * dx;
              a += push;
              a_wall_push += push;
              if constexpr (kViscous) a += (mb * 2.0 * mu_wall_i * inv_rho[i] / rhob * F * r2 * inv_e) * vi;
              contact = contact || r2 < contact2;
              wall_normal -= (bvol[b] * F) * dx;
            }
            if constexpr (kViscous) {
              // Basal friction (friction rheologies): Coulomb against the wall's normal push N, along the
              // tangential velocity, smoothed over a slip speed v_slip so a resting particle is not chattered
              // by sign flips.
              const real push = a_wall_push.norm();
              if (friction_i > 0 && push > 0) {
                const Vec<D> nrm = a_wall_push / push;
                const Vec<D> vt = vi - vi.dot(nrm) * nrm;
                const real vts = vt.norm();
                if (vts > 0) a -= (friction_i * push * -std::expm1(-vts / v_slip) / vts) * vt;
              }
            }
            {
              const real nn = wall_normal.norm();
              for (int d = 0; d < D; ++d) contact_normal_[d][i] = contact && nn > 0 ? wall_normal[d] / nn : 0;
            }
            if constexpr (!kViscous) {
              A[i * kS2 + kDiv] += div;
              A[i * kS2 + kDiff] += diff;
            }
            for (int d = 0; d < D; ++d) A[i * kS2 + (kAcc + d)] += a[d];
            max_visc_term = std::max(max_visc_term, visc_max);
          });
        },
        [&](auto&& sum, size_t i) {
          Vec<D> a;
          for (int d = 0; d < D; ++d) a[d] = sum(kAcc + d, i) + g[d];
          for (int d = 0; d < D; ++d) acc_[d][i] = a[d];
          max_acc = std::max(max_acc, a.squaredNorm());
          if constexpr (!kViscous) drho_[i] = rho[i] * sum(kDiv, i) + ddt_coef * sum(kDiff, i);
        },
        [&](auto&& bsum, uint32_t b, uint32_t s) {
          if constexpr (!kViscous) boundary_drho_[b] = brho[b] * bsum(0, s);
        });
  };

  with_kernel<D>(config_.kernel, h, [&](auto kernel) {
    if (viscous)
      interact.template operator()<true>(kernel);
    else
      interact.template operator()<false>(kernel);
  });
  max_acc = std::sqrt(max_acc);
  // Inlet buffers move at their inlet's velocity with a fixed density: no rates, no wall contact.
  if (!inlets_.empty()) {
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) {
      if (!is_inlet_buffer(fluid_.tag[i])) continue;
      for (int d = 0; d < D; ++d) acc_[d][i] = 0, contact_normal_[d][i] = 0;
      drho_[i] = 0;
    }
  }

  stats_.active_boundary = 0;
  for (uint32_t cb : I.active_bcells) stats_.active_boundary += I.bcell_begin[cb + 1] - I.bcell_begin[cb];

  if (compute_dt) {
    // Monaghan & Kos (1999), thesis eq. 2.27, plus the viscous limit with the capped mu_eff.
    stats_.dt_force = max_acc > 0 ? std::sqrt(h / max_acc) : 1e300;
    stats_.dt_acoustic = h / (c0 + max_visc_term);
    stats_.dt_viscous = max_nu > 0 ? 0.125 * h * h / max_nu : 1e300;
    stats_.dt = std::min(config_.cfl * std::min(stats_.dt_force, stats_.dt_acoustic), stats_.dt_viscous);
    stats_.max_effective_viscosity = 0;
    if (viscous)
      for (size_t i = 0; i < n; ++i) stats_.max_effective_viscosity = std::max(stats_.max_effective_viscosity, mu_eff_[i]);
    if (!(stats_.dt >= config_.min_dt)) {
      std::ostringstream s;
      s << fmt_time(time_) << ": time step " << stats_.dt << " s fell below the floor " << config_.min_dt
        << " s (force limit " << stats_.dt_force << " s, acoustic " << stats_.dt_acoustic << " s, viscous "
        << stats_.dt_viscous << " s)";
      throw SimulationError(s.str(), SimulationError::Cause::dt_floor);
    }
  }
}

template <int D>
void Solver<D>::evaluate_rates() {
  sort_and_build_cells();
  evaluate(false);
}


template void Solver<2>::evaluate(bool);
template void Solver<2>::evaluate_rates();
template void Solver<3>::evaluate(bool);
template void Solver<3>::evaluate_rates();

}  // namespace runout
