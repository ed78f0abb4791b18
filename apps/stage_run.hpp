// One simulation through loading stages (io/serial/stage_spec.hpp), one at a time: each step, the
// control law's strain rates (apps/stage_control.hpp) at every servo interval, the end
// conditions (apps/stage_end.hpp), the series rows, the fabric rows, the HDF5 output and the
// run's energy account. Every rank runs the same control flow; every decision is taken from
// reduced (identical) values. StageRun::run is the one loop of every driver: the stage list
// (apps/stage_driver.hpp), the triaxial test (apps/triaxial.hpp) and the plain run
// (apps/plain_run.hpp), whose measurements and rows are its own (the virtual members below).
#pragma once
#include "apps/fabric_output.hpp"
#include "apps/stage_control.hpp"
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"

#include <cstdint>
#include <functional>
#include <limits>
#include <ostream>
#include <string>

namespace fabrica {

class RunOutput;
class StageRecord;

struct StageResult {
  std::int64_t steps = 0;
  MacroState state;
  Vec3 strain = Vec3::Zero();  // the series' strains at the end (eps_i = ln(l_i0 / l_i))
  // With track_peak, over every row of the series (the output instants and the stage's last
  // row): the largest q/p and eps1 there, and the largest relative error of the stress axes'
  // stresses, max |sigma_kk - target_k| / target_k.
  real_t peak_q_p = 0;
  real_t peak_eps1 = 0;
  real_t max_lateral_error = 0;
  real_t max_energy_error = 0;  // over the stage, relative to the energy put in (energy_in)
  Vec3 gamma = Vec3::Zero();    // the series' engineering shear strains 12, 13, 23 at the end
};

// Where a run is inside a stage, with the run's own account: what a checkpoint saves to resume
// the stage bit for bit (apps/stage_cursor.hpp writes it as named fields).
struct StageCursor {
  std::int32_t stage = 0;  // index in the run's list of stages
  std::int64_t k = 0;      // steps of the stage done
  ControlState control;
  real_t last_servo = 0;         // s, time of the last servo update
  StageResult result;            // so far
  Vec3 l0 = Vec3::Zero();        // the series' strain reference
  Vec3 stage_l0 = Vec3::Zero();  // the stage's strain reference (end conditions)
  real_t input_positive = 0;     // J, energy_in() less the initial energy
  real_t input_seen = 0;         // J, boundary + gravity work at the last measurement
  // Once the cell is sheared (zero before; apps/stage_cursor.cpp writes them only then): the
  // cell lengths when it became sheared, and the cell's strain() at the series' and the stage's
  // strain references.
  Vec3 sheared_lengths = Vec3::Zero();
  Mat3 e0 = Mat3::Zero();
  Mat3 stage_e0 = Mat3::Zero();
};

class StageRun {
 public:
  // With a parent (the run 'sim' was copied from), strains and the energy account continue.
  // 'series': rank 0's stream of rows (others pass null); 'log': progress lines (or null).
  StageRun(const Scene& scene, Simulation& sim, real_t mean_diameter, real_t density, std::ostream* series,
           std::ostream* log, const StageRun* parent = nullptr);
  virtual ~StageRun() = default;

  // Runs stage 'st' (index 'index' of the run's list, for the cursor) to its end; with
  // 'resume' from a checkpoint's cursor (the simulation restored from it: the stage's contact
  // parameters are not applied again).
  StageResult run(const StageSpec& st, std::int32_t index, const StageCursor* resume = nullptr);
  // Called at the end of every step of a stage that does not end there (to take checkpoints).
  void on_step(std::function<void(const StageCursor&)> hook) { hook_ = std::move(hook); }
  // Called on every rank after every series row (to check and agree that it was written).
  void on_row(std::function<void()> check) { row_check_ = std::move(check); }

  real_t boundary_work() const { return sim_.boundary_work(); }
  // The total energy put in [J]: the simulation's initial energy plus every positive increment
  // of the boundary and gravity work between two measurements. It never decreases, so it can
  // normalise the energy error of a specimen that unloads (the net work may pass through zero).
  real_t energy_in() const { return sim_.energy_account().e0 + in_pos_; }
  // The run's account (strain reference, energy put in) in the fields of a cursor, and its
  // restoration (the parent of the cases, on a restart).
  StageCursor account() const;
  void set_account(const StageCursor& a);

  // Fabric analysis ([fabric] enabled, at the rows the stage's 'fabric' says), on every rank
  // (collective); rows go to 'out' (rank 0's streams; others pass null or nothing). Wall
  // seconds spent in it (records, analysis, output) so far:
  void set_fabric_output(const FabricStreams* out) { fabric_out_ = out; }
  double fabric_seconds() const { return fabric_seconds_; }
  // Optional HDF5 output (io/mpi/run_output.hpp): the series rows and the snapshots (every
  // [run] snapshot_every steps and at the end of each stage) go to case 'case_name' of 'out'.
  void set_output(RunOutput* out, std::string case_name) {
    output_ = out;
    case_ = std::move(case_name);
  }
  // While set, every series, fabric and HDF5 series row is also kept in 'r' (to be written
  // again for another case: apps/stage_record.hpp); null stops it.
  void record(StageRecord* r) { record_ = r; }

 protected:
  // What a step of a stage measures and writes; a driver with rows of its own overrides them
  // (apps/plain_run.cpp). Here those of the stage series: a row every [run] output_every steps
  // of the stage ('k' counts them from 1)...
  virtual bool row_due(const StageSpec& st, std::int64_t k) const;
  // ... a measurement there, at every servo interval and at the step an end.steps names ...
  virtual bool measures(const StageSpec& st, std::int64_t k, bool at_row) const;
  // ... its series row, fabric rows ([fabric], as the stage says) and [fields] instant ...
  virtual void rows(const StageSpec& st, std::int64_t k, const MacroState& m, const Vec3& eps, const Vec3& gamma);
  // ... and at the stage's end (its last measurement; 'at_row': rows() wrote that one's row) its
  // last row and the fabric analysis of its end.
  virtual void end_rows(const StageSpec& st, std::int64_t k, const MacroState& m, const Vec3& eps, const Vec3& gamma,
                        bool at_row);
  // Stops the run when stage 'st' has not ended after its max_steps (every rank alike).
  [[noreturn]] virtual void unended(const StageSpec& st, const StageResult& res, const StageControl& c) const;

  const Scene& scene_;
  Simulation& sim_;

 private:
  void apply_contact(const StageSpec& st);
  // A series row; 'localisation': the field instant's localisation index, the last column when
  // [fields] keeps the strain increment (kNoLocalisation, NaN, at a row without one).
  void row(const StageSpec& st, const MacroState& m, const Vec3& eps, const Vec3& gamma, real_t localisation);
  void fabric_row(const StageSpec& st, const Vec3& eps);
  // The strains eps_k = ln(l0_k / l_k) from the reference lengths l0 (reference()). A sheared
  // cell's lengths are the diagonal of its matrix, not its stretches: its strains are those of
  // the cell's strain() (the integral of D) from the lengths it had when it became sheared.
  Vec3 strain(const Vec3& l0) const;
  Vec3 reference() const;  // the lengths a strain is measured from, now
  // The engineering shear strains 12, 13, 23 since the cell's strain() was e0.
  Vec3 shear_strain(const Mat3& e0) const;
  // The rates for measurement 'm' (collective: the specimen's stiffness is reduced).
  Vec3 update(StageControl& c, const StageSpec& st, const MacroState& m, const Vec3& eps, real_t elapsed);
  // The full velocity gradient for measurement 'm' (shear stages, sheared cells), set on the
  // cell; returns its diagonal.
  Vec3 update_gradient(StageControl& c, const StageSpec& st, const MacroState& m, const Vec3& eps, const Vec3& gamma,
                       real_t elapsed, real_t stage_time);
  // The cell's rates after a measurement, through update() or update_gradient().
  Vec3 drive(StageControl& c, const StageSpec& st, const MacroState& m, const Vec3& eps, const Vec3& gamma,
             real_t elapsed, real_t stage_time);
  bool warn_cap(const StageSpec& st, const StageControl& c, const MacroState& m, const Vec3& rates);
  void progress(const StageSpec& st, const MacroState& m, const Vec3& eps, const Vec3& gamma, double secs,
                std::int64_t steps);
  void track(StageResult& res, const StageControl& c, const MacroState& m, const Vec3& eps) const;
  // (energy put in - stored - dissipated) / energy_in(), from the simulation's one account.
  real_t energy_error(const MacroState& m) const;
  void track_input(const MacroState& m);  // at every measurement: energy_in() grows

  real_t d_mean_, density_;
  std::ostream* series_;
  std::ostream* log_;
  bool shear_out_;          // the run shears: the series' shear columns, fabric's principal columns
  std::string header_;      // the series' header line
  Vec3 l0_;                 // cell lengths at the start of the current strain reference
  Vec3 ls_ = Vec3::Zero();  // cell lengths when it became sheared (zero before)
  Mat3 e0_ = Mat3::Zero();  // the cell's strain() at the current strain reference
  real_t in_pos_ = 0;       // J, sum of the positive increments of input_seen_
  real_t input_seen_ = 0;   // J, boundary + gravity work at the last measurement
  std::function<void(const StageCursor&)> hook_;
  std::function<void()> row_check_;
  const FabricStreams* fabric_out_ = nullptr;
  double fabric_seconds_ = 0;
  RunOutput* output_ = nullptr;
  std::string case_;
  StageRecord* record_ = nullptr;
};

// With 'shear' (a run whose stages shear the cell) the shear columns follow the others:
// gamma_12, gamma_13, gamma_23, sigma_1, sigma_2, sigma_3, n1, n2, n3, theta_12 (docs/output.md);
// with 'localisation' ([fields] keeps the strain increment: FieldsSpec::localisation) the column
// localisation ends the row, NaN (`nan` in the CSV) at rows without a field instant that has a
// strain increment.
void write_series_header(std::ostream& out, bool shear = false, bool localisation = false);

// The series' localisation at a row without a field instant that has a strain increment.
inline constexpr real_t kNoLocalisation = std::numeric_limits<real_t>::quiet_NaN();

}  // namespace fabrica
