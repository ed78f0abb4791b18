// Turns a validated Scene into a ready Simulation: particles (generated or read), cell, and a
// time step checked against the critical estimate. One sequence of steps, each check written
// once, over the ranks that make it (io/serial/setup_ranks.hpp): make_setup(scene) is its
// one-rank case, make_distributed_setup (io/mpi/distributed_setup.hpp) the case of many.
#pragma once
#include "core/contact_list.hpp"
#include "core/region_packing.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"

namespace fabrica {

class SetupRanks;

struct Setup {
  Particles particles;
  PeriodicCell cell;
  SimulationParams params;
  real_t critical_dt = 0;  // s, the estimate of core/timestep.hpp
  // Whole: 'particles' is the whole specimen (make_setup); Share: this rank's part of it
  // (make_distributed_setup, io/mpi/distributed_setup.hpp), to build the Simulation with.
  Holding holding = Holding::Whole;
};

// Throws InputError (file, field, value) for a particle outside the cell, a cell too small for
// the largest sphere, two particles overlapping by more than [run] max_initial_overlap of the
// smaller radius, or a time step above the critical estimate without force_time_step.
// [run] density_scaling multiplies every mass and moment of inertia (before the estimate).
Setup make_setup(const Scene& scene);
// The same steps made by 'ranks' together (collective over them): the particles returned are
// those each rank holds at the end (ranks.holding()); the result and every error are the
// one-rank set-up's on any number of ranks.
Setup make_setup(const Scene& scene, SetupRanks& ranks);

// The pair with the largest overlap relative to the smaller radius (periodic), or ratio 0 and
// ids -1 if no two spheres overlap.
struct OverlapReport {
  real_t ratio = 0, overlap = 0;  // -, m
  GlobalId a = -1, b = -1;
};
OverlapReport largest_overlap(const Particles& p, const PeriodicCell& cell);
// The same over the given pairs of p (owned and ghosts) in a cell of lengths L.
OverlapReport largest_overlap(const Particles& p, const PairList& pairs, const PeriodicCell& cell);

// [particles] placement = "regions": the gradation, the expected cell and its cut into regions
// (from the expected solid volume, so the same before any diameter is drawn), and the cell for
// the real solid volume (checked as make_setup checks a cell; the grid takes its sides).
struct RegionCut {
  RegionSpec spec;
  Vec3 expected;
  RegionGrid grid;
};
RegionCut region_cut(const Scene& scene);
PeriodicCell region_cell(const Scene& scene, RegionCut& cut, real_t solid_volume);

// The InputError of an initial overlap above [run] max_initial_overlap.
std::string overlap_message(const Scene& scene, const OverlapReport& ov);

// Of the read particles p (this rank's, or all), the index of the one with the smallest id
// that lies outside a cell of lengths L, or p.n_owned() if none does; and the InputError that
// refuses particle a, with its coordinate as the data file has it (the cell's corner at lo
// there). The smallest id, so that the same particle is named on any rank count.
std::size_t outside_cell(const Particles& p, const Vec3& L);
[[noreturn]] void refuse_outside_cell(const Scene& scene, const Particles& p, std::size_t a, const Vec3& L,
                                      const Vec3& lo);

// The materials of generated spheres (several materials: each its material by
// generated_material, its mass by the material's density), [run] density_scaling applied to
// the particles, and the contact law, materials, skin, gravity and local damping of the scene
// copied into the parameters (a step of make_setup).
void apply_scene_run(const Scene& scene, Setup& s);
// The atom type of each material of a data-file scene (-1: a wall's material); empty without
// [[material]] tables.
std::vector<std::int64_t> material_types(const Scene& sc);

// The time step the scene asks for, validated against the estimate (used again when the
// contact parameters change between stages).
real_t scene_time_step(const Scene& scene, real_t critical_dt);

}  // namespace fabrica
