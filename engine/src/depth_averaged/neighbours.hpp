#pragma once
// The thickness-integrated model's plan cell grid: particles sorted by a cell of at least the kernel support,
// each cell searched with its eight neighbours. The 3D solver's grid (src/solver/cells.cpp) is built into the
// solver's private state around fluid and wall sets and a vertical axis; this one is the same idea in plan,
// small enough to keep apart: a sorted (key, index) array and, per occupied cell, its particle range.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "runout/engine/depth_averaged.hpp"

namespace runout::depth_averaged::detail {

struct PlanCells {
  Vec2 origin = Vec2::Zero(), cell = Vec2::Ones(), period = Vec2::Zero();
  std::array<bool, 2> periodic{false, false};
  std::array<int64_t, 2> count{1, 1};
  std::vector<uint64_t> keys;    // distinct occupied cell keys, ascending
  std::vector<uint32_t> begin;   // particle range of keys[c]: [begin[c], begin[c + 1])
  std::vector<uint32_t> order;   // the sort's permutation: new position k holds old particle order[k]

  // Cell axes: at least `support` wide; a periodic axis splits its period into whole cells (at least three,
  // so a neighbour cell is never counted twice).
  void configure(real support, const Config& c) {
    for (int d = 0; d < 2; ++d) {
      periodic[d] = c.periodic[d];
      if (periodic[d]) {
        period[d] = c.domain_max[d] - c.domain_min[d];
        count[d] = static_cast<int64_t>(std::floor(period[d] / support));
        cell[d] = period[d] / static_cast<real>(count[d]);
        origin[d] = c.domain_min[d];
      } else {
        cell[d] = support;
      }
    }
  }

  int64_t coord(real x, int d) const {
    const int64_t k = static_cast<int64_t>(std::floor((x - origin[d]) / cell[d]));
    return periodic[d] ? std::clamp<int64_t>(k, 0, count[d] - 1) : k;
  }
  uint64_t key(int64_t cx, int64_t cy) const { return static_cast<uint64_t>(cy) * count[0] + cx; }

  // Sorts the particles' positions into cells; fills `order` (apply it to every array) and the ranges.
  void sort(const std::vector<real>& x, const std::vector<real>& y) {
    const size_t n = x.size();
    for (int d = 0; d < 2; ++d) {
      if (periodic[d] || n == 0) continue;
      const auto& v = d == 0 ? x : y;
      const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
      origin[d] = *lo;
      count[d] = static_cast<int64_t>(std::floor((*hi - *lo) / cell[d])) + 1;
    }
    std::vector<std::pair<uint64_t, uint32_t>> kv(n);
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; ++i) kv[i] = {key(coord(x[i], 0), coord(y[i], 1)), static_cast<uint32_t>(i)};
    std::sort(kv.begin(), kv.end());
    order.resize(n);
    keys.clear();
    begin.clear();
    for (size_t k = 0; k < n; ++k) {
      order[k] = kv[k].second;
      if (k == 0 || kv[k].first != kv[k - 1].first) {
        keys.push_back(kv[k].first);
        begin.push_back(static_cast<uint32_t>(k));
      }
    }
    begin.push_back(static_cast<uint32_t>(n));
  }

  // The particle ranges of the (up to) nine cells around cell (cx, cy); returns how many.
  int neighbour_ranges(int64_t cx, int64_t cy, std::array<std::pair<uint32_t, uint32_t>, 9>& out) const {
    int m = 0;
    for (int oy = -1; oy <= 1; ++oy)
      for (int ox = -1; ox <= 1; ++ox) {
        int64_t c[2] = {cx + ox, cy + oy};
        bool inside = true;
        for (int d = 0; d < 2; ++d) {
          if (periodic[d]) c[d] = (c[d] + count[d]) % count[d];
          else if (c[d] < 0 || c[d] >= count[d]) inside = false;
        }
        if (!inside) continue;
        const uint64_t k = key(c[0], c[1]);
        const auto it = std::lower_bound(keys.begin(), keys.end(), k);
        if (it == keys.end() || *it != k) continue;
        const size_t ci = static_cast<size_t>(it - keys.begin());
        out[m++] = {begin[ci], begin[ci + 1]};
      }
    return m;
  }

  // The separation x_i - x_j on the periodic axes' nearest image.
  Vec2 separation(real dx, real dy) const {
    if (periodic[0]) dx -= period[0] * std::round(dx / period[0]);
    if (periodic[1]) dy -= period[1] * std::round(dy / period[1]);
    return Vec2(dx, dy);
  }
  // A position wrapped into a periodic axis' period.
  real wrap(real x, int d) const {
    if (!periodic[d]) return x;
    real s = x - origin[d];
    s -= std::floor(s / period[d]) * period[d];
    if (s >= period[d]) s = 0;
    return origin[d] + s;
  }
};

}  // namespace runout::depth_averaged::detail
