#pragma once
// The OpenMP team a run uses: opt.threads_now when set (a ThreadShare's lease), else opt.threads (0: OpenMP's
// default). Applied between steps only, never inside a pass; it records the smallest and largest team the run
// had, for metrics.json (a run whose team changed is no speed sample for the cost model).
#include <omp.h>

#include <algorithm>

#include "runout/scenarios/run.hpp"

namespace runout {

class RunThreads {
 public:
  void follow(const RunOptions& opt) {
    const int n = opt.threads_now ? opt.threads_now() : opt.threads;
    if (n > 0 && n != omp_get_max_threads()) omp_set_num_threads(n);
    const int now = omp_get_max_threads();
    least_ = least_ > 0 ? std::min(least_, now) : now;
    most_ = std::max(most_, now);
  }
  int least() const { return least_; }
  int most() const { return most_; }

 private:
  int least_ = 0, most_ = 0;
};

// metrics.json's "threads" (the largest team) and, when the team changed during the run, "threads_least".
template <class Json>
void add_thread_metrics(Json& m, const RunThreads& team) {
  m["threads"] = team.most();
  if (team.least() != team.most()) m["threads_least"] = team.least();
}

}  // namespace runout
