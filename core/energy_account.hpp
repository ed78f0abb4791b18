// The energy account of a Simulation: the energy put into the system since its construction, as
// MacroState::energy_input reports it (the terms are explained at Simulation::boundary_work()).
// EnergyBook keeps it from step to step; EnergyAccount is its record, the fields a checkpoint
// stores (io/mpi/simulation_fields.cpp), so that a restarted run keeps one unbroken account.
#pragma once
#include "core/types.hpp"

#include <optional>

namespace fabrica {

// The record; the field names are those of the checkpoint format.
struct EnergyAccount {
  real_t e0 = 0;    // kinetic + elastic energy at construction [J]
  real_t work = 0;  // boundary work up to the end of the last step [J]
  // vol_strain = (V, known, 0): the cell volume [m^3] at the end of the last step whose stress
  // is known (known = 1), or known = 0 when the last step neither strained the cell nor measured.
  Vec3 vol_strain = Vec3::Zero();
  Mat3 stress_prev = Mat3::Zero();  // that stress [Pa] (its diagonal is used)
  real_t gravity_work_local = 0;    // work of gravity on this rank's particles [J]
  real_t wall_work = 0;             // work of the moving walls on all particles [J] (global)
  real_t drive_work = 0;            // work of the drive of the driven particles [J] (global)
};

class EnergyBook {
 public:
  EnergyBook() = default;
  explicit EnergyBook(const EnergyAccount& saved);
  EnergyAccount record() const;

  void open(real_t e0) { e0_ = e0; }  // the kinetic and elastic energy at construction
  real_t e0() const { return e0_; }
  real_t boundary_work() const { return work_; }
  real_t gravity_work_local() const { return gravity_work_local_; }
  real_t wall_work() const { return wall_work_; }
  real_t drive_work() const { return drive_work_; }
  // e0 + the boundary work + 'gravity_work' (the reduced one) + the walls' and the drive's work.
  real_t input(real_t gravity_work) const { return e0_ + work_ + gravity_work + wall_work_ + drive_work_; }

  void add_gravity_work(real_t w) { gravity_work_local_ += w; }  // this rank's particles
  void add_wall_work(real_t w) { wall_work_ += w; }              // global (reduced)
  void add_drive_work(real_t w) { drive_work_ += w; }            // global (reduced)
  // The end of a step whose stress is known (it measured, or strained the cell): adds its
  // boundary work, by its strain increment edot dt and the diagonal stress at its end and at its
  // start (the end's when the start is unknown), and remembers the end for the next step.
  void close_step(real_t volume, const Vec3& strain_increment, const Vec3& stress_end);
  // The same in a sheared cell: by the increment D dt of the rate of deformation and the full
  // stress (the work -V sigma : D dt, compression positive).
  void close_step(real_t volume, const Mat3& strain_increment, const Mat3& stress_end);
  // The end of a step that neither strained the cell nor measured: its stress is unknown.
  void close_step_unknown() { last_.reset(); }

 private:
  real_t e0_ = 0;    // kinetic + elastic energy at construction [J]
  real_t work_ = 0;  // boundary work up to the end of the last step [J]
  struct Known {
    Mat3 stress;    // stress [Pa] (an orthorhombic cell's: its diagonal alone)
    real_t volume;  // cell volume [m^3]
  };
  std::optional<Known> last_;      // at the end of the last step, if it knows its stress
  real_t gravity_work_local_ = 0;  // work of gravity on the owned particles [J]
  real_t wall_work_ = 0;           // work of the moving walls [J] (global: reduced each step)
  real_t drive_work_ = 0;          // work of the drive [J] (global: reduced each step)
};

}  // namespace fabrica
