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

  // Cells `support` wide (the base kernel's); a periodic axis splits its period into whole cells. A particle
  // whose kernel is wider searches more cells (`reach`); a periodic axis gives each cell an image shift, so a
  // kernel wider than the period sums every image.
  void configure(real support, const Config& c) {
    for (int d = 0; d < 2; ++d) {
      periodic[d] = c.periodic[d];
      if (periodic[d]) {
        period[d] = c.domain_max[d] - c.domain_min[d];
        count[d] = std::max<int64_t>(1, static_cast<int64_t>(std::floor(period[d] / support)));
        cell[d] = period[d] / static_cast<real>(count[d]);
        origin[d] = c.domain_min[d];
      } else {
        cell[d] = support;
      }
    }
  }

  // Cells each way along axis d that a kernel of support `s` needs.
  int64_t reach(real s, int d) const { return std::max<int64_t>(1, static_cast<int64_t>(std::ceil(s / cell[d]))); }

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

  struct Range {
    uint32_t begin, end;
    real sx, sy;  // image shift: the neighbour sits at (x_j + sx, y_j + sy)
  };
  // The particle ranges of the cells within (kx, ky) cells of cell (cx, cy), with their image shifts, in the
  // order of their keys within each row of cells.
  void neighbour_ranges(int64_t cx, int64_t cy, int64_t kx, int64_t ky, std::vector<Range>& out) const {
    out.clear();
    if (!periodic[0]) return row_ranges(cx, cy, kx, ky, out);
    for (int64_t oy = -ky; oy <= ky; ++oy)
      for (int64_t ox = -kx; ox <= kx; ++ox) {
        int64_t c[2] = {cx + ox, cy + oy};
        real shift[2] = {0, 0};
        bool inside = true;
        for (int d = 0; d < 2; ++d) {
          if (periodic[d]) {
            const int64_t w = c[d] >= 0 ? c[d] / count[d] : -((-c[d] + count[d] - 1) / count[d]);  // floor division
            c[d] -= w * count[d];
            shift[d] = static_cast<real>(w) * period[d];
          } else if (c[d] < 0 || c[d] >= count[d]) {
            inside = false;
          }
        }
        if (!inside) continue;
        const uint64_t k = key(c[0], c[1]);
        const auto it = std::lower_bound(keys.begin(), keys.end(), k);
        if (it == keys.end() || *it != k) continue;
        const size_t ci = static_cast<size_t>(it - keys.begin());
        out.push_back({begin[ci], begin[ci + 1], shift[0], shift[1]});
      }
  }

  // Without a periodic x axis a row's cells cx - kx .. cx + kx are consecutive keys, and their particles one
  // consecutive range of the sorted order: one search and one range a row. A kernel grown to several cells on a
  // sparse flow (adaptive smoothing) would otherwise search every cell of its square, most of them empty.
  void row_ranges(int64_t cx, int64_t cy, int64_t kx, int64_t ky, std::vector<Range>& out) const {
    const int64_t x0 = std::max<int64_t>(0, cx - kx), x1 = std::min<int64_t>(count[0] - 1, cx + kx);
    if (x0 > x1) return;
    for (int64_t oy = -ky; oy <= ky; ++oy) {
      int64_t y = cy + oy;
      real shift = 0;
      if (periodic[1]) {
        const int64_t w = y >= 0 ? y / count[1] : -((-y + count[1] - 1) / count[1]);  // floor division
        y -= w * count[1];
        shift = static_cast<real>(w) * period[1];
      } else if (y < 0 || y >= count[1]) {
        continue;
      }
      const auto first = std::lower_bound(keys.begin(), keys.end(), key(x0, y));
      const auto last = std::upper_bound(first, keys.end(), key(x1, y));
      if (first == last) continue;
      out.push_back({begin[static_cast<size_t>(first - keys.begin())], begin[static_cast<size_t>(last - keys.begin())],
                     0, shift});
    }
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
