#include "io/mpi/simulation_fields.hpp"

#include "core/errors.hpp"
#include "io/mpi/state_fields.hpp"

#include <type_traits>

namespace fabrica {
namespace {

// The parts that are lists of their own, written and read by their functions.
void part(FieldWriter& w, const ContactLawParams& l) { write_law(w, l); }
void part(FieldReader& r, ContactLawParams& l) { l = read_law(r); }
void part(FieldWriter& w, const Materials& m) { write_materials(w, m); }
void part(FieldReader& r, Materials& m) { m = read_materials(r); }
void part(FieldWriter& w, const MacroState& m) { write_macro(w, m); }
void part(FieldReader& r, MacroState& m) { m = read_macro(r); }

// Whether an optional field is there: the writer writes it when 'present', a reader reads it
// when the file's next field is it.
bool optional(const FieldWriter&, const OptionalField&, bool present) { return present; }
bool optional(const FieldReader& r, const OptionalField& f, bool) { return r.next_is(f.name); }

// A bool as u8 (0 or 1).
template <class Io, class B>
void flag(Io& io, const char* name, B& b) {
  std::uint8_t v = b ? 1 : 0;
  io.field(name, v);
  if constexpr (!std::is_const_v<B>) b = v != 0;
}

// A count (of type Count) named 'name', then each(element) for every element of 'v'. A reader
// checks the count with check(n) before it reads the elements, one at a time (a corrupt count
// runs out of bytes instead of memory).
template <class Count, class Io, class V, class Check, class Each>
void counted(Io& io, const char* name, V& v, Check check, Each each) {
  Count n = Count(v.size());
  io.field(name, n);
  if constexpr (std::is_const_v<V>) {
    for (auto& e : v) each(e);
  } else {
    check(n);
    v.clear();
    for (Count k = 0; k < n; ++k) each(v.emplace_back());
  }
}

// The bounds a reader checks, and the names its messages give.
struct Limits {
  const std::string& where;  // "PATH: section PREFIX"
  std::int32_t ranks;        // of the writer
  void refuse(const std::string& what) const { throw InputError(where + what); }
};

template <class Io, class W>
void wall_fields(Io& io, W& w, bool materials) {
  io.field("wall.point", w.point);
  io.field("wall.normal", w.normal);
  io.field("wall.velocity", w.velocity);
  flag(io, "wall.own_law", w.own_law);
  if (w.own_law) part(io, w.law);
  io.field("wall.servo_pressure", w.servo_pressure);
  io.field("wall.servo_relaxation", w.servo_relaxation);
  io.field("wall.servo_max_speed", w.servo_max_speed);
  if (optional(io, kWallMaterialField, materials)) io.field("wall.material", w.material);
}

template <class Io, class D>
void driven_fields(Io& io, D& d, const Limits& lim) {
  io.field("driven.first", d.first);
  io.field("driven.last", d.last);
  counted<std::uint64_t>(
      io, "driven.ids", d.ids,
      [&](std::uint64_t n) {
        if (n > (std::uint64_t(1) << 40)) lim.refuse(".global: corrupted (driven id count)");
      },
      [&](auto& id) { io.field("driven.id", id); });
  io.field("driven.velocity", d.velocity);
  io.field("driven.spin", d.spin);
}

template <class Io, class R>
void decomposition_fields(Io& io, R& dec, const Limits& lim) {
  io.field("decomposition_lengths", dec.lengths);
  counted<std::int64_t>(
      io, "decomposition_cuts", dec.cuts,
      [&](std::int64_t cuts) {
        if (cuts < 0 || cuts > 3 * std::int64_t(lim.ranks))
          lim.refuse(": decomposition_cuts = " + std::to_string(cuts) + ", expected 0 to " +
                     std::to_string(3 * lim.ranks) + " (three axes of at most " + std::to_string(lim.ranks) + " runs)");
      },
      [&](auto& cut) { io.field("decomposition_cut", cut); });
  io.field("decomposition_since_check", dec.since_check);
}

// A sheared cell's state (kCellMatrixField): written when 'g' is of a sheared cell, read when the
// file names it.
template <class Io, class G>
void sheared_cell_fields(Io& io, G& g) {
  if (!optional(io, kCellMatrixField, g.cell_sheared)) return;
  io.field(kCellMatrixField.name, g.cell_matrix);
  io.field(kCellVelocityGradientField.name, g.cell_velocity_gradient);
  io.field(kCellStrainField.name, g.cell_strain);
  if constexpr (!std::is_const_v<G>) g.cell_sheared = true;
}

template <class Io, class E>
void energy_fields(Io& io, E& e) {
  io.field("energy.e0", e.e0);
  io.field("energy.work", e.work);
  io.field("energy.vol_strain", e.vol_strain);
  io.field("energy.stress_prev", e.stress_prev);
  io.field("energy.wall_work", e.wall_work);
  io.field("energy.drive_work", e.drive_work);
}

// The list, in the file's order ('g' const for writing).
template <class Io, class G>
void simulation_global_fields(Io& io, G& g, const Limits& lim) {
  io.field("particle_record", g.particle_record);
  io.field("contact_record", g.contact_record);
  io.field("cell.lengths", g.cell_lengths);
  io.field("cell.strain_rate", g.cell_strain_rate);
  sheared_cell_fields(io, g);
  auto& par = g.params;
  part(io, par.law);
  io.field("dt", par.dt);
  io.field("skin", par.skin);
  io.field("gravity", par.gravity);
  io.field("local_damping", par.local_damping);
  const bool materials = !par.materials.empty();
  counted<std::uint64_t>(
      io, "walls", par.walls,
      [&](std::uint64_t n) {
        if (n > 1000000) lim.refuse(".global: corrupted (wall count)");
      },
      [&](auto& w) { wall_fields(io, w, materials); });
  counted<std::uint64_t>(
      io, "driven", par.driven,
      [&](std::uint64_t n) {
        if (n > 1000000) lim.refuse(".global: corrupted (driven set count)");
      },
      [&](auto& d) { driven_fields(io, d, lim); });
  flag(io, "spatial_sort", par.spatial_sort);
  if (optional(io, kMaterialsField, materials)) part(io, par.materials);
  io.field("step", g.step);
  io.field("rebuilds", g.rebuilds);
  io.field("time", g.time);
  part(io, g.macro);
  decomposition_fields(io, g.decomposition, lim);
  energy_fields(io, g.energy);
}

}  // namespace

SimulationGlobal simulation_global(const Simulation& sim) {
  SimulationGlobal g;
  g.params = sim.params();
  g.particle_record = particle_record_schema(!g.params.materials.empty());
  g.contact_record = contact_record_schema(g.params.twisting());
  g.cell_lengths = sim.cell().lengths();
  g.cell_strain_rate = sim.cell().strain_rate();
  if (const PeriodicCell& c = sim.cell(); c.sheared()) {
    g.cell_sheared = true;
    g.cell_matrix = c.matrix();
    g.cell_velocity_gradient = c.velocity_gradient();
    g.cell_strain = c.strain();
  }
  g.step = sim.step_count();
  g.rebuilds = sim.rebuild_count();
  g.time = sim.time();
  g.macro = sim.macro();
  g.decomposition = sim.domain().decomposition_record();
  g.energy = sim.energy_account();
  return g;
}

PeriodicCell cell_of(const SimulationGlobal& g) {
  PeriodicCell cell(g.cell_lengths);
  if (g.cell_sheared) cell.restore_sheared(g.cell_matrix, g.cell_velocity_gradient, g.cell_strain);
  else cell.set_strain_rate(g.cell_strain_rate);
  return cell;
}

void write_simulation_global(FieldWriter& w, const SimulationGlobal& g) {
  const std::string none;
  simulation_global_fields(w, g, Limits{none, 0});
}

SimulationGlobal read_simulation_global(FieldReader& r, const std::string& where, std::int32_t writer_ranks) {
  SimulationGlobal g;
  simulation_global_fields(r, g, Limits{where, writer_ranks});
  r.done();
  const SimulationParams& par = g.params;
  for (const Wall& w : par.walls)
    if (w.material >= std::int32_t(par.materials.size()))
      throw InputError(where + ".global: wall.material = " + std::to_string(w.material) + " of " +
                       std::to_string(par.materials.size()) + " materials (corrupted)");
  return g;
}

}  // namespace fabrica
