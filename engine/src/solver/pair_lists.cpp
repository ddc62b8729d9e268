// Pair lists: each evaluation first lists, for every fluid particle i, its fluid neighbours j > i in the half
// stencil (the own column with higher indices, and the columns "after" it), so each fluid pair is listed once,
// then all its wall neighbours. The passes (passes.hpp) walk these lists.
#include "impl.hpp"

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

}  // namespace

// The listing test is branch-free: the store is unconditional and the cursor advances by the test's outcome,
// so the ~3/4 of candidates outside the support cost no mispredicted branch.
template <int D>
void Solver<D>::build_pair_lists(real support) {
  auto& I = *impl_;
  constexpr int kNb = Impl::kNb, kHalf = Impl::kHalf;
  const size_t n = fluid_.size(), ncells = I.fcell_key.size();
  const real support2 = support * support;
  std::array<const real*, D> P, BP;
  for (int d = 0; d < D; ++d) P[d] = fluid_.pos[d].data(), BP[d] = boundary_.pos[d].data();
  const int nthreads = omp_get_max_threads();
  I.list_buf.resize(nthreads);
  I.list_off.resize(n);
  I.list_nf.resize(n);
  I.list_nb.resize(n);
  I.list_thread.resize(n);
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
          // Block 0 is the particle's own column: only the higher indices (the pair's other half is listed by
          // the lower-index particle).
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
}

template void Solver<2>::build_pair_lists(real);
template void Solver<3>::build_pair_lists(real);

}  // namespace runout
