// The solver's state for a checkpoint (solver.hpp, save_state / load_state). What a step reads of the past is
// saved: the particles in their current order (the cell sort breaks ties by it), the integrator's previous
// values (Verlet), the wall tiles alive and every wall particle's density, the balances and the last step's
// statistics (the wall tiles' reach uses its speed) and the implicit viscous solves' counts. Everything else a
// step recomputes.
#include <stdexcept>

#include "impl.hpp"

namespace runout {
namespace {

template <int D>
void write_particles(StateWriter& out, const ParticleArrays<D>& p) {
  for (int d = 0; d < D; ++d) out.values(p.pos[d]), out.values(p.vel[d]);
  out.values(p.rho), out.values(p.mass), out.values(p.material), out.values(p.tag), out.values(p.id);
}

template <int D>
void read_particles(StateReader& in, ParticleArrays<D>& p) {
  for (int d = 0; d < D; ++d) in.values(p.pos[d]), in.values(p.vel[d]);
  in.values(p.rho), in.values(p.mass), in.values(p.material), in.values(p.tag), in.values(p.id);
  const size_t n = p.rho.size();
  bool same = p.mass.size() == n && p.material.size() == n && p.tag.size() == n && p.id.size() == n;
  for (int d = 0; d < D; ++d) same = same && p.pos[d].size() == n && p.vel[d].size() == n;
  if (!same) in.fail("has particle arrays of different lengths");
}

// What must match between the setup that wrote a checkpoint and the one reading it.
template <int D>
void check_same_setup(StateReader& in, const SolverConfig& c, size_t materials, uint64_t described, bool source,
                      int64_t tiles) {
  const auto mismatch = [&](const char* what) { in.fail(std::string("is of another setup: its ") + what + " differs"); };
  if (in.value<int>() != D) mismatch("dimension");
  if (in.value<real>() != c.dp) mismatch("dp");
  if (in.value<real>() != c.smoothing_length) mismatch("smoothing length");
  if (in.value<real>() != c.speed_of_sound) mismatch("speed of sound");
  if (in.value<int>() != static_cast<int>(c.integrator)) mismatch("integrator");
  if (in.value<real>() != c.neighbour_skin) mismatch("neighbour skin");
  if (in.value<uint64_t>() != materials) mismatch("material count");
  if (in.value<uint64_t>() != described) mismatch("wall particle count");
  if (in.value<int>() != static_cast<int>(source)) mismatch("wall source (walls laid near the flow or whole)");
  if (in.value<int64_t>() != tiles) mismatch("wall tile count (how the wall source is cut)");
}

// The run's clock, record and balances, in the checkpoint's order: one list for writing (StateWriter, const
// parts) and reading (StateReader).
template <class IO, class Record, class Balances, class Id>
void transfer_record(IO& io, Record& r, Balances& b, Id& next_id) {
  io.value(r.time), io.value(r.steps), io.value(r.max_mach), io.value(r.min_dt_seen), io.value(r.stats);
  io.value(r.viscous);
  io.values(b.mass.initial), io.values(b.mass.current), io.values(b.mass.outflow), io.values(b.mass.inflow);
  io.value(b.potential_initial), io.value(b.potential_outflow), io.value(b.kinetic_inflow), io.value(next_id);
}

}  // namespace

template <int D>
void Solver<D>::save_state(StateWriter& out) const {
  const auto& I = *impl_;
  const auto& pairs = I.pairs;
  out.label("solver");
  out.value<int>(D), out.value(config_.dp), out.value(config_.smoothing_length), out.value(config_.speed_of_sound);
  out.value<int>(static_cast<int>(config_.integrator)), out.value(config_.neighbour_skin);
  out.value<uint64_t>(materials_.size()), out.value<uint64_t>(boundary_described());
  out.value<int>(wall_source_ ? 1 : 0), out.value<int64_t>(wall_source_ ? I.tiles.grid.count() : 0);
  transfer_record(out, record_, balance_, next_id_);
  out.value<uint64_t>(boundary_peak_), out.value(boundary_generation_);
  out.label("fluid");
  write_particles(out, fluid_);
  for (int d = 0; d < D; ++d) out.values(saved_.pos[d]), out.values(saved_.vel[d]);
  out.values(saved_.rho);
  out.label("walls");
  out.values(I.tiles.alive);
  out.values(boundary_.id), out.values(boundary_.rho), out.values(saved_.boundary_rho);
  // The Verlet list's candidates are remade from where the fluid stood at the last sort (the particles are still
  // in that sort's order), so a resumed run reuses them exactly when the uninterrupted one would.
  out.label("neighbours");
  out.value(pairs.neighbour_rebuilds);
  const bool kept = pairs.candidates_valid && pairs.fluid_at_sort == fluid_.size();
  out.value<int>(kept ? 1 : 0);
  if (kept)
    for (int d = 0; d < D; ++d) out.values(pairs.pos_at_sort[d]);
}

// The cells and candidates of the last sort, at the positions it saw.
template <int D>
void Solver<D>::restore_neighbour_candidates() {
  auto& pairs = impl_->pairs;
  for (int d = 0; d < D; ++d) std::swap(fluid_.pos[d], pairs.pos_at_sort[d]);
  sort_and_build_cells();  // the particles are in this sort's order already: it indexes the cells again
  const real support = 2.0 * config_.smoothing_length;
  scan_cells_for_pairs(support + neighbour_skin(), true);
  for (int d = 0; d < D; ++d) std::swap(fluid_.pos[d], pairs.pos_at_sort[d]);
  pairs.fluid_at_sort = fluid_.size();
  pairs.generation_at_sort = boundary_generation_;
  pairs.candidates_valid = true;
}

template <int D>
void Solver<D>::load_state(StateReader& in) {
  in.expect("solver");
  check_same_setup<D>(in, config_, materials_.size(), boundary_described(), wall_source_ != nullptr,
                      wall_source_ ? impl_->tiles.grid.count() : 0);
  transfer_record(in, record_, balance_, next_id_);
  boundary_peak_ = in.value<uint64_t>();
  in.value(boundary_generation_);
  in.expect("fluid");
  read_particles(in, fluid_);
  for (int d = 0; d < D; ++d) in.values(saved_.pos[d]), in.values(saved_.vel[d]);
  in.values(saved_.rho);
  for (int d = 0; d < D; ++d)
    if (saved_.pos[d].size() < fluid_.size() || saved_.vel[d].size() < fluid_.size())
      in.fail("is short of saved positions");
  if (saved_.rho.size() < fluid_.size()) in.fail("is short of saved densities");
  outflow_marked_.clear();

  in.expect("walls");
  std::vector<int64_t> live;
  in.values(live);
  if (wall_source_) restore_wall_tiles(live);
  else if (!live.empty()) in.fail("has wall tiles for a setup without a wall source");
  std::vector<uint32_t> ids;
  in.values(ids);
  if (ids != boundary_.id) in.fail("holds other wall particles than this setup lays");
  in.values(boundary_.rho), in.values(saved_.boundary_rho);
  if (boundary_.rho.size() != ids.size() || saved_.boundary_rho.size() != ids.size())
    in.fail("has wall densities of the wrong length");

  in.expect("neighbours");
  auto& pairs = impl_->pairs;
  in.value(pairs.neighbour_rebuilds);
  pairs.candidates_valid = false;
  if (in.value<int>() == 1) {
    for (int d = 0; d < D; ++d) {
      in.values(pairs.pos_at_sort[d]);
      if (pairs.pos_at_sort[d].size() != fluid_.size()) in.fail("has neighbour-list positions of the wrong length");
    }
    restore_neighbour_candidates();
  }
}

template void Solver<2>::save_state(StateWriter&) const;
template void Solver<3>::save_state(StateWriter&) const;
template void Solver<2>::load_state(StateReader&);
template void Solver<3>::load_state(StateReader&);
template void Solver<2>::restore_neighbour_candidates();
template void Solver<3>::restore_neighbour_candidates();

}  // namespace runout
