#include "progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace runout {

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)), tty_(isatty(STDERR_FILENO) != 0) {}

void ProgressBar::update(const RunProgress& p) {
  const double frac = p.duration > 0 ? std::min(1.0, static_cast<double>(p.time / p.duration)) : 0.0;
  const double steps_per_s = p.wall_seconds > 0 ? p.steps / p.wall_seconds : 0.0;
  const double eta = frac > 1e-9 ? p.wall_seconds * (1.0 - frac) / frac : 0.0;
  const int decile = static_cast<int>(frac * 10);
  if (!tty_ && decile == last_decile_) return;
  last_decile_ = decile;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(std::round(frac * kWidth));
  char bar[kWidth + 1];
  for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '.';
  bar[kWidth] = 0;
  std::fprintf(stderr, "%s%s [%s] %5.1f%%  t=%.4g/%.4g s  %.0f steps/s  %zu particles  ETA %.0f s%s",
               tty_ ? "\r" : "", label_.c_str(), bar, 100 * frac, static_cast<double>(p.time),
               static_cast<double>(p.duration), steps_per_s, p.particles, eta, tty_ ? "   " : "\n");
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (tty_ && drawn_) std::fputc('\n', stderr);
}

}  // namespace runout
