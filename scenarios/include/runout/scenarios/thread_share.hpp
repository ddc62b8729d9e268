#pragma once
// The machine's cores divided among the runs of one process that run at once (a sweep's --jobs, the service's
// workers): each run's OpenMP team is cores / running (at least one), read again between steps, so the process
// puts no more threads on the machine than it has cores while every run has a core, and a run left alone takes
// them all (docs/performance.md, "Runs that share a machine").
#include <atomic>
#include <functional>

namespace runout {

class ThreadShare {
 public:
  explicit ThreadShare(int cores);
  int cores() const { return cores_; }
  int running() const { return running_.load(); }
  int share() const;  // the threads one run may use now

  // Held while one run runs: a run counts from its construction to its destruction.
  class Lease {
   public:
    explicit Lease(ThreadShare& s) : s_(&s) { ++s_->running_; }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease() { --s_->running_; }
    // What RunOptions::threads_now calls.
    std::function<int()> threads_now() const {
      return [s = s_] { return s->share(); };
    }

   private:
    ThreadShare* s_;
  };

 private:
  int cores_;
  std::atomic<int> running_{0};
};

}  // namespace runout
