// Wall particles near the flow (wall_source.hpp): which of the wall source's tiles are alive, and the boundary
// arrays rebuilt, sorted by cell, when that changes.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <tuple>

#include "impl.hpp"

namespace runout {
namespace {

// A fluid particle needs every wall particle within the kernel support 2h at both evaluations of a step, and
// moves at most v dt <= Mach cfl h in one (dt <= cfl h / c0): the tiles within 2h + cfl h max(1, 2 Mach) of it
// must be alive when the step starts (Mach from the last step, doubled against its growth in one step). A
// rebuild lays those within that reach + dp / 2, so the next one is due once the flow has gone about dp / 2
// onto new ground, not every step.
constexpr real kLayAhead = 0.5;  // [dp]

// How far x lies outside [c - spread, c + spread] (0 inside).
inline real gap(real x, real c, real spread) { return std::max<real>(0, std::abs(x - c) - spread); }

// f(t) for every tile within `reach` of p: the columns whose particles lie within reach horizontally and, where
// the columns are cut in depth, the slabs within what is left of it vertically (a sphere about p, not its box).
template <int D, class F>
void for_tiles_near(const WallTileGrid& g, const Vec<D>& p, real reach, F&& f) {
  auto range = [&](real x, real origin, int64_t n, int64_t& lo, int64_t& hi) {
    const real a = std::floor((x - reach - origin) / g.size), b = std::floor((x + reach - origin) / g.size);
    lo = a < 0 ? 0 : static_cast<int64_t>(std::min<real>(a, static_cast<real>(n)));
    hi = b >= static_cast<real>(n) ? n - 1 : static_cast<int64_t>(std::max<real>(b, -1.0));
  };
  int64_t x0, x1, y0 = 0, y1 = 0;
  range(p[0], g.x0, g.nx, x0, x1);
  if constexpr (D == 3) range(p[1], g.y0, g.ny, y0, y1);
  const real reach2 = reach * reach, spread = g.spread * g.size;
  for (int64_t iy = y0; iy <= y1; ++iy) {
    const real gy = D == 3 ? gap(p[1], g.y0 + (static_cast<real>(iy) + 0.5) * g.size, spread) : real(0);
    for (int64_t ix = x0; ix <= x1; ++ix) {
      const real gx = gap(p[0], g.x0 + (static_cast<real>(ix) + 0.5) * g.size, spread), across2 = gx * gx + gy * gy;
      if (across2 > reach2) continue;
      const int64_t k = iy * g.nx + ix;
      if (!(g.slab > 0)) {
        f(k);
        continue;
      }
      // Slab s spans [top - s slab - extent, top - s slab]: those meeting [z - up, z + up].
      const real up = std::sqrt(reach2 - across2), depth = g.column_top[k] - p[D - 1];
      const int64_t n = g.column_first[k + 1] - g.column_first[k];
      const int64_t s0 = std::max<int64_t>(0, static_cast<int64_t>(std::ceil((depth - up - g.slab_extent) / g.slab)));
      const int64_t s1 = std::min<int64_t>(n - 1, static_cast<int64_t>(std::floor((depth + up) / g.slab)));
      for (int64_t s = s0; s <= s1; ++s) f(g.column_first[k] + s);
    }
  }
}

// Keeps the entries of v whose keep[k] is set, in order.
template <class T>
void compact(std::vector<T>& v, const std::vector<char>& keep) {
  size_t w = 0;
  for (size_t k = 0; k < v.size(); ++k)
    if (keep[k]) v[w++] = v[k];
  v.resize(w);
}

}  // namespace

template <int D>
uint64_t Solver<D>::boundary_described() const {
  return impl_->tiles.fixed + (wall_source_ ? wall_source_->total() : 0);
}

template <int D>
bool Solver<D>::wall_tiles_missing(real reach) const {
  const size_t n = fluid_.size();
  const WallTileGrid& g = impl_->tiles.grid;
  const char* live = impl_->tiles.live.data();
  bool missing = false;
#pragma omp parallel for schedule(static) reduction(|| : missing)
  for (size_t i = 0; i < n; ++i)
    for_tiles_near<D>(g, fluid_.position(i), reach, [&](int64_t t) { missing = missing || !live[t]; });
  return missing;
}

template <int D>
bool Solver<D>::wall_tiles_known_alive(real need) const {
  const auto& tiles = impl_->tiles;
  const size_t n = fluid_.size();
  if (tiles.check_reach < 0 || tiles.check_pos[0].size() != n) return false;
  real moved2 = 0;
#pragma omp parallel for schedule(static) reduction(max : moved2)
  for (size_t i = 0; i < n; ++i) {
    real dd = 0;
    for (int d = 0; d < D; ++d) {
      const real u = fluid_.pos[d][i] - tiles.check_pos[d][i];
      dd += u * u;
    }
    moved2 = std::max(moved2, dd);
  }
  return std::sqrt(moved2) + need <= tiles.check_reach;
}

template <int D>
void Solver<D>::remember_wall_check(real reach) {
  auto& tiles = impl_->tiles;
  for (int d = 0; d < D; ++d) tiles.check_pos[d] = fluid_.pos[d];
  tiles.check_reach = reach;
}

// The step's check, then a rebuild if a tile within reach is not alive. The check is skipped while the flow
// has not moved out of what the last one verified; one that finds every tile alive a little farther out
// (half the lay-ahead) is remembered, so the next checks are skipped until the flow moves that far. Rebuilds
// happen at the same steps either way.
template <int D>
void Solver<D>::refresh_wall_tiles(bool force) {
  auto& tiles = impl_->tiles;
  const size_t n = fluid_.size();
  const real h = config_.smoothing_length;
  const real mach = record_.stats.max_speed / config_.speed_of_sound;
  const real need = 2.0 * h + config_.cfl * h * std::max<real>(1.0, 2.0 * mach);
  if (!force) {
    if (wall_tiles_known_alive(need)) return;
    const real verified = need + 0.5 * kLayAhead * config_.dp;
    if (!wall_tiles_missing(verified)) {
      remember_wall_check(verified);
      return;
    }
    tiles.check_reach = -1;
    if (!wall_tiles_missing(need)) return;
  }
  if (++tiles.mark_stamp == 0) {
    std::fill(tiles.mark.begin(), tiles.mark.end(), 0u);
    tiles.mark_stamp = 1;
  }
  std::vector<int64_t> wanted;
  for (size_t i = 0; i < n; ++i)
    for_tiles_near<D>(tiles.grid, fluid_.position(i), need + kLayAhead * config_.dp, [&](int64_t t) {
      if (tiles.mark[t] == tiles.mark_stamp) return;
      tiles.mark[t] = tiles.mark_stamp;
      wanted.push_back(t);
    });
  std::sort(wanted.begin(), wanted.end());

  // Drop the particles of tiles no longer wanted; those kept keep their state (a DBC wall's density).
  std::vector<char> keep(boundary_.size());
  for (size_t b = 0; b < keep.size(); ++b)
    keep[b] = tiles.of_wall[b] < 0 || tiles.mark[tiles.of_wall[b]] == tiles.mark_stamp;
  keep_boundary(keep);
  for (int64_t t : tiles.alive)
    if (tiles.mark[t] != tiles.mark_stamp) tiles.live[t] = 0;

  for (int64_t t : wanted)
    if (!tiles.live[t]) lay_tile(t);
  tiles.alive = std::move(wanted);
  sort_boundary();
  ++boundary_generation_;
  boundary_peak_ = std::max(boundary_peak_, boundary_.size());
  remember_wall_check(need + kLayAhead * config_.dp);
  if (max_particles_ > 0 && static_cast<long>(n + boundary_.size()) > max_particles_) {
    std::ostringstream s;
    s << fmt_time(record_.time) << ": " << boundary_.size() << " wall particles alive near " << n
      << " flow particles, over limits.max_particles = " << max_particles_;
    throw SimulationError(s.str());
  }
}

// Every array that holds one entry per wall particle, in the boundary's order: what dropping or sorting wall
// particles must carry along.
template <int D>
template <class F>
void Solver<D>::for_each_wall_array(F&& f) {
  auto& tiles = impl_->tiles;
  for (int d = 0; d < D; ++d) f(boundary_.pos[d]), f(boundary_.vel[d]), f(wall_fields_.normal[d]);
  f(boundary_.rho), f(boundary_.mass), f(boundary_.material), f(boundary_.tag), f(boundary_.id);
  f(tiles.of_wall), f(tiles.rank), f(saved_.boundary_rho), f(wall_fields_.pressure), f(wall_fields_.drho);
}

template <int D>
void Solver<D>::keep_boundary(const std::vector<char>& keep) {
  for_each_wall_array([&](auto& v) { compact(v, keep); });
}

template <int D>
void Solver<D>::restore_wall_tiles(const std::vector<int64_t>& live) {
  auto& tiles = impl_->tiles;
  std::vector<char> fixed(boundary_.size());
  for (size_t b = 0; b < fixed.size(); ++b) fixed[b] = tiles.of_wall[b] < 0;
  keep_boundary(fixed);
  std::fill(tiles.live.begin(), tiles.live.end(), 0);
  for (int64_t t : live) {
    if (t < 0 || t >= static_cast<int64_t>(tiles.live.size())) throw std::runtime_error("checkpoint: a wall tile out of range");
    lay_tile(t);
  }
  tiles.alive = live;
  tiles.check_reach = -1;  // the flow is the checkpoint's: checked afresh at the next step
  sort_boundary();
}

template <int D>
void Solver<D>::lay_tile(int64_t t) {
  auto& tiles = impl_->tiles;
  tiles.live[t] = 1;
  std::vector<Vec<D>> pos, normals;
  std::vector<uint32_t> tags;
  wall_source_->lay(t, pos, normals, tags);
  const real bmass = config_.boundary_density * std::pow(config_.dp, D);
  const uint64_t first = tiles.fixed + wall_source_->first_index(t);
  for (size_t k = 0; k < pos.size(); ++k) {
    boundary_.add(pos[k], config_.boundary_density, bmass, 0, tags[k]);
    for (int d = 0; d < D; ++d) wall_fields_.normal[d].push_back(normals[k][d]);
    boundary_.id.back() = static_cast<uint32_t>(first + k);
    tiles.of_wall.push_back(t);
    tiles.rank.push_back(first + k);
    saved_.boundary_rho.push_back(config_.boundary_density);
    wall_fields_.pressure.push_back(0.0);
    wall_fields_.drho.push_back(0.0);
  }
}

// Sorts the boundary by cell (ties by rank) and indexes its cells.
template <int D>
void Solver<D>::sort_boundary() {
  auto& cells = impl_->cells;
  auto& tiles = impl_->tiles;
  const size_t nb = boundary_.size();
  std::vector<std::tuple<uint64_t, uint64_t, uint32_t>> order(nb);
#pragma omp parallel for schedule(static)
  for (size_t b = 0; b < nb; ++b)
    order[b] = {CellIndex<D>::pack(cells.coords(boundary_.position(b))), tiles.rank[b], static_cast<uint32_t>(b)};
  std::sort(order.begin(), order.end());
  auto permute = [&](auto& v) {
    auto out = v;
    for (size_t k = 0; k < nb; ++k) out[k] = v[std::get<2>(order[k])];
    v.swap(out);
  };
  for_each_wall_array(permute);
  cells.bcell_key.clear();
  cells.bcell_begin.clear();
  for (size_t k = 0; k < nb; ++k) {
    const uint64_t key = std::get<0>(order[k]);
    if (cells.bcell_key.empty() || cells.bcell_key.back() != key) {
      cells.bcell_key.push_back(key);
      cells.bcell_begin.push_back(static_cast<uint32_t>(k));
    }
  }
  cells.bcell_begin.push_back(static_cast<uint32_t>(nb));
  cells.bcell_stamp.assign(cells.bcell_key.size(), 0);
  wall_fields_.drho.assign(nb, 0.0);
}

template uint64_t Solver<2>::boundary_described() const;
template uint64_t Solver<3>::boundary_described() const;
template void Solver<2>::refresh_wall_tiles(bool);
template void Solver<3>::refresh_wall_tiles(bool);
template bool Solver<2>::wall_tiles_missing(real) const;
template bool Solver<3>::wall_tiles_missing(real) const;
template bool Solver<2>::wall_tiles_known_alive(real) const;
template bool Solver<3>::wall_tiles_known_alive(real) const;
template void Solver<2>::remember_wall_check(real);
template void Solver<3>::remember_wall_check(real);
template void Solver<2>::sort_boundary();
template void Solver<2>::lay_tile(int64_t);
template void Solver<2>::keep_boundary(const std::vector<char>&);
template void Solver<3>::keep_boundary(const std::vector<char>&);
template void Solver<2>::restore_wall_tiles(const std::vector<int64_t>&);
template void Solver<3>::restore_wall_tiles(const std::vector<int64_t>&);
template void Solver<3>::lay_tile(int64_t);
template void Solver<3>::sort_boundary();

}  // namespace runout
