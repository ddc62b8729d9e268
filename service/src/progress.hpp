#pragma once
// A one-line progress bar on stderr: simulated time, steps/s and ETA. Redraws in place on a terminal,
// prints a plain line every 10% otherwise (CI logs).
#include "runout/scenarios/run.hpp"

namespace runout {

class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  void update(const RunProgress& p);
  void finish();

 private:
  std::string label_;
  bool tty_;
  int last_decile_ = -1;
  bool drawn_ = false;
};

}  // namespace runout
