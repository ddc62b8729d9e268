#pragma once
// Sums over particles that repeat to the bit at a given thread count. An OpenMP reduction(+) adds the threads'
// partial sums in the order the threads arrive, so a floating-point total (a CG dot product, a section's passed
// volume) differs in its last bits from run to run, and a run with two threads never repeats. Here each thread
// sums a fixed block (a static schedule gives the same blocks every time for the same team size) and the blocks'
// sums are added in thread order. Private to the engine.
#include <omp.h>

#include <array>
#include <cstddef>
#include <vector>

#include "runout/engine/types.hpp"

namespace runout {

// N sums at once: term(k, acc) adds particle k's contributions to acc[0..N-1], for k < n.
template <size_t N, class F>
std::array<real, N> ordered_sums(size_t n, F&& term) {
  std::vector<std::array<real, N>> part(static_cast<size_t>(omp_get_max_threads()), std::array<real, N>{});
#pragma omp parallel
  {
    std::array<real, N> s{};
#pragma omp for schedule(static)
    for (size_t k = 0; k < n; ++k) term(k, s);
    part[static_cast<size_t>(omp_get_thread_num())] = s;
  }
  std::array<real, N> total{};
  for (const auto& p : part)
    for (size_t q = 0; q < N; ++q) total[q] += p[q];
  return total;
}

template <class F>
real ordered_sum(size_t n, F&& term) {
  return ordered_sums<1>(n, [&](size_t k, std::array<real, 1>& s) { s[0] += term(k); })[0];
}

}  // namespace runout
