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
  return impl_->boundary_fixed + (wall_source_ ? wall_source_->total() : 0);
}

template <int D>
bool Solver<D>::wall_tiles_missing(real reach) const {
  const auto& I = *impl_;
  const size_t n = fluid_.size();
  const WallTileGrid& g = I.tiles;
  const char* live = I.tile_live.data();
  bool missing = false;
#pragma omp parallel for schedule(static) reduction(|| : missing)
  for (size_t i = 0; i < n; ++i)
    for_tiles_near<D>(g, fluid_.position(i), reach, [&](int64_t t) { missing = missing || !live[t]; });
  return missing;
}

template <int D>
bool Solver<D>::wall_tiles_known_alive(real need) const {
  const auto& I = *impl_;
  const size_t n = fluid_.size();
  if (I.tile_check_reach < 0 || I.tile_check_pos[0].size() != n) return false;
  real moved2 = 0;
#pragma omp parallel for schedule(static) reduction(max : moved2)
  for (size_t i = 0; i < n; ++i) {
    real dd = 0;
    for (int d = 0; d < D; ++d) {
      const real u = fluid_.pos[d][i] - I.tile_check_pos[d][i];
      dd += u * u;
    }
    moved2 = std::max(moved2, dd);
  }
  return std::sqrt(moved2) + need <= I.tile_check_reach;
}

template <int D>
void Solver<D>::remember_wall_check(real reach) {
  auto& I = *impl_;
  for (int d = 0; d < D; ++d) I.tile_check_pos[d] = fluid_.pos[d];
  I.tile_check_reach = reach;
}

// The step's check, then a rebuild if a tile within reach is not alive. The check is skipped while the flow
// has not moved out of what the last one verified; one that finds every tile alive a little farther out
// (half the lay-ahead) is remembered, so the next checks are skipped until the flow moves that far. Rebuilds
// happen at the same steps either way.
template <int D>
void Solver<D>::refresh_wall_tiles(bool force) {
  auto& I = *impl_;
  const size_t n = fluid_.size();
  const real h = config_.smoothing_length;
  const real need = 2.0 * h + config_.cfl * h * std::max<real>(1.0, 2.0 * stats_.max_speed / config_.speed_of_sound);
  if (!force) {
    if (wall_tiles_known_alive(need)) return;
    const real verified = need + 0.5 * kLayAhead * config_.dp;
    if (!wall_tiles_missing(verified)) {
      remember_wall_check(verified);
      return;
    }
    I.tile_check_reach = -1;
    if (!wall_tiles_missing(need)) return;
  }
  if (++I.mark_stamp == 0) {
    std::fill(I.tile_mark.begin(), I.tile_mark.end(), 0u);
    I.mark_stamp = 1;
  }
  std::vector<int64_t> wanted;
  for (size_t i = 0; i < n; ++i)
    for_tiles_near<D>(I.tiles, fluid_.position(i), need + kLayAhead * config_.dp, [&](int64_t t) {
      if (I.tile_mark[t] == I.mark_stamp) return;
      I.tile_mark[t] = I.mark_stamp;
      wanted.push_back(t);
    });
  std::sort(wanted.begin(), wanted.end());

  // Drop the particles of tiles no longer wanted; those kept keep their state (a DBC wall's density).
  std::vector<char> keep(boundary_.size());
  for (size_t b = 0; b < keep.size(); ++b) keep[b] = I.boundary_tile[b] < 0 || I.tile_mark[I.boundary_tile[b]] == I.mark_stamp;
  keep_boundary(keep);
  for (int64_t t : I.live_tiles)
    if (I.tile_mark[t] != I.mark_stamp) I.tile_live[t] = 0;

  for (int64_t t : wanted)
    if (!I.tile_live[t]) lay_tile(t);
  I.live_tiles = std::move(wanted);
  sort_boundary();
  ++boundary_generation_;
  boundary_peak_ = std::max(boundary_peak_, boundary_.size());
  remember_wall_check(need + kLayAhead * config_.dp);
  if (max_particles_ > 0 && static_cast<long>(n + boundary_.size()) > max_particles_) {
    std::ostringstream s;
    s << fmt_time(time_) << ": " << boundary_.size() << " wall particles alive near " << n
      << " flow particles, over limits.max_particles = " << max_particles_;
    throw SimulationError(s.str());
  }
}

template <int D>
void Solver<D>::keep_boundary(const std::vector<char>& keep) {
  auto& I = *impl_;
  for (int d = 0; d < D; ++d)
    compact(boundary_.pos[d], keep), compact(boundary_.vel[d], keep), compact(boundary_normal_[d], keep);
  compact(boundary_.rho, keep), compact(boundary_.mass, keep), compact(boundary_.material, keep);
  compact(boundary_.tag, keep), compact(boundary_.id, keep), compact(I.boundary_tile, keep);
  compact(I.boundary_rank, keep), compact(boundary_rho_saved_, keep), compact(boundary_pressure_, keep);
}

template <int D>
void Solver<D>::restore_wall_tiles(const std::vector<int64_t>& live) {
  auto& I = *impl_;
  std::vector<char> fixed(boundary_.size());
  for (size_t b = 0; b < fixed.size(); ++b) fixed[b] = I.boundary_tile[b] < 0;
  keep_boundary(fixed);
  std::fill(I.tile_live.begin(), I.tile_live.end(), 0);
  for (int64_t t : live) {
    if (t < 0 || t >= static_cast<int64_t>(I.tile_live.size())) throw std::runtime_error("checkpoint: a wall tile out of range");
    lay_tile(t);
  }
  I.live_tiles = live;
  I.tile_check_reach = -1;  // the flow is the checkpoint's: checked afresh at the next step
  sort_boundary();
}

template <int D>
void Solver<D>::lay_tile(int64_t t) {
  auto& I = *impl_;
  I.tile_live[t] = 1;
  std::vector<Vec<D>> pos, normals;
  std::vector<uint32_t> tags;
  wall_source_->lay(t, pos, normals, tags);
  const real bmass = config_.boundary_density * std::pow(config_.dp, D);
  const uint64_t first = I.boundary_fixed + wall_source_->first_index(t);
  for (size_t k = 0; k < pos.size(); ++k) {
    boundary_.add(pos[k], config_.boundary_density, bmass, 0, tags[k]);
    for (int d = 0; d < D; ++d) boundary_normal_[d].push_back(normals[k][d]);
    boundary_.id.back() = static_cast<uint32_t>(first + k);
    I.boundary_tile.push_back(t);
    I.boundary_rank.push_back(first + k);
    boundary_rho_saved_.push_back(config_.boundary_density);
    boundary_pressure_.push_back(0.0);
  }
}

// Sorts the boundary by cell (ties by rank) and indexes its cells.
template <int D>
void Solver<D>::sort_boundary() {
  auto& I = *impl_;
  const size_t nb = boundary_.size();
  std::vector<std::tuple<uint64_t, uint64_t, uint32_t>> order(nb);
#pragma omp parallel for schedule(static)
  for (size_t b = 0; b < nb; ++b)
    order[b] = {Impl::pack(I.coords(boundary_.position(b))), I.boundary_rank[b], static_cast<uint32_t>(b)};
  std::sort(order.begin(), order.end());
  auto permute = [&](auto& v) {
    auto out = v;
    for (size_t k = 0; k < nb; ++k) out[k] = v[std::get<2>(order[k])];
    v.swap(out);
  };
  for (int d = 0; d < D; ++d) permute(boundary_.pos[d]), permute(boundary_.vel[d]), permute(boundary_normal_[d]);
  permute(boundary_.rho), permute(boundary_.mass), permute(boundary_.material), permute(boundary_.tag);
  permute(boundary_.id), permute(I.boundary_tile), permute(I.boundary_rank), permute(boundary_rho_saved_);
  permute(boundary_pressure_);
  I.bcell_key.clear();
  I.bcell_begin.clear();
  for (size_t k = 0; k < nb; ++k) {
    const uint64_t key = std::get<0>(order[k]);
    if (I.bcell_key.empty() || I.bcell_key.back() != key) {
      I.bcell_key.push_back(key);
      I.bcell_begin.push_back(static_cast<uint32_t>(k));
    }
  }
  I.bcell_begin.push_back(static_cast<uint32_t>(nb));
  I.bcell_stamp.assign(I.bcell_key.size(), 0);
  boundary_drho_.assign(nb, 0.0);
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
