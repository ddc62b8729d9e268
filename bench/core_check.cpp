// Whether this machine's cores are independent before two-thread scaling is read: three loops, each run by one
// thread and then by two threads each doing the same work, so equal times mean the second core costs the first
// nothing (a core shared with an SMT sibling or a busy neighbour shows up as a longer two-thread time):
//   compute  a dependent floating-point recurrence (no memory),
//   stream   each thread sweeps its own 64 MB (memory bandwidth),
//   cache    each thread sweeps its own 200 KB many times (its private cache).
// Usage: build/bench/bench_core_check (docs/performance.md, "Two threads on a catchment step").
#include <omp.h>

#include <cstdio>
#include <vector>

namespace {

template <class Body>
double seconds_with(int threads, Body&& body) {
  double sink = 0;
  const double t0 = omp_get_wtime();
#pragma omp parallel num_threads(threads) reduction(+ : sink)
  sink += body(omp_get_thread_num());
  const double t = omp_get_wtime() - t0;
  if (sink == 42.0) std::printf("%g\n", sink);  // keeps the work
  return t;
}

double compute(int t) {
  double x = 1.0 + t * 1e-9;
  for (long i = 0; i < 400000000L; ++i) {
    x = x * 1.0000001 + 1e-9;
    if (x > 2) x -= 1;
  }
  return x;
}

std::vector<std::vector<double>> big(2, std::vector<double>(8000000, 1.0)), small(2, std::vector<double>(25000, 1.0));

double sweep(std::vector<double>& v, int repeats) {
  double s = 0;
  for (int r = 0; r < repeats; ++r)
    for (double& x : v) {
      x = x * 0.999 + 1.0;
      s += x;
    }
  return s;
}

}  // namespace

int main() {
  std::printf("%-8s %10s %10s %8s\n", "loop", "1 thread", "2 threads", "ratio");
  auto row = [](const char* name, auto&& body) {
    const double one = seconds_with(1, body), two = seconds_with(2, body);
    std::printf("%-8s %9.3fs %9.3fs %8.2f\n", name, one, two, two / one);
  };
  row("compute", compute);
  row("stream", [](int t) { return sweep(big[t], 20); });
  row("cache", [](int t) { return sweep(small[t], 40000); });
  return 0;
}
