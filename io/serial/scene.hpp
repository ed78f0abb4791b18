// Scene files (TOML). Every key, its unit and its default are documented in docs/scene.md.
// load_scene validates everything before anything runs: an unknown key, a wrong type, a
// non-finite number or a non-physical value is refused with the file, the field and the value.
#pragma once
#include "core/contact_law.hpp"
#include "core/driven.hpp"
#include "core/types.hpp"
#include "core/errors.hpp"
#include "io/serial/stage_spec.hpp"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace fabrica {

// The sphere diameters Fabrica accepts, in metres ([particles] d_min, d_max; data files): a
// nanometre to a kilometre. Outside, a value is taken for a unit slip (or a denormal number,
// whose cube underflows and makes the cell size not a number).
constexpr double kMinDiameter = 1e-9;
constexpr double kMaxDiameter = 1e3;

enum class ParticleSource { Generate, File };

struct GenerateSpec {
  std::int64_t count = 1000;       // N
  real_t fractal_dimension = 1.9;  // D
  real_t d_min = 0.010;            // m
  real_t d_max = 0.060;            // m
  std::uint64_t seed = 1;
  real_t solid_fraction = 0.30;  // of the initial (loose) cloud
  Vec3 aspect = Vec3(2, 1, 1);   // cell length ratios (axis 1 = loading axis)
  // "sequential": one random sequential addition over the whole cell (the study's specimens;
  // every rank makes the whole specimen); "regions": region by region (core/region_packing.hpp),
  // each rank only its share, the same specimen on any rank count. Without the key:
  // sequential below kRegionsFrom spheres, regions from there on.
  enum class Placement { Sequential, Regions } placement = Placement::Sequential;
  static constexpr std::int64_t kRegionsFrom = 200000;
};

// Optional isotropic compression at a constant strain rate until the mean stress reaches a
// target, then relaxation with the cell fixed (a simple preparation stage; the servo-controlled
// consolidation of the triaxial application replaces it).
struct CompressSpec {
  bool enabled = false;
  real_t target_pressure = 100e3;  // Pa
  real_t strain_rate = -1.0;       // 1/s, negative = compression
  std::int64_t max_steps = 1000000;
  real_t friction = 0.0;  // mu_s while compressing (a lower value packs denser)
};

// The periodic triaxial test of shared/spec/reference-problem.md section 4: servo-controlled
// isotropic consolidation, a switch of contact parameters with re-equilibration, then
// conventional triaxial compression along axis 1 with the lateral stresses held by the servo.
// How the servo sets its gains (apps/servo.hpp): from the specimen's measured stiffness, or
// fixed by the scene (the default when servo_gain or servo_integral_gain is given).
struct TriaxialSpec {
  bool enabled = false;
  real_t confining_pressure = 200e3;    // Pa
  real_t consolidation_friction = 1.0;  // mu_s while consolidating (mu_r = 0 then)
  // What each case is sheared from (docs/triaxial.md, "Equilibration protocols"):
  //   Case:   re-equilibrated at [contact] friction and the case's mu_r;
  //   Common: re-equilibrated at [contact] friction and mu_r = 0, the same state for every
  //           case; the case's mu_r from the start of the shear (the default: the study's text);
  //   None:   no re-equilibration: the consolidated state, mu_s and mu_r switched at the start
  //           of the shear.
  enum class Equilibration { Case, Common, None } equilibration = Equilibration::Common;
  ServoMode servo = ServoMode::Stiffness;
  // servo = "stiffness": each servo interval corrects this fraction of the stress error, with
  // the gain derived from the specimen's stiffness (re-measured at every servo update), and the
  // integral fraction of the summed past errors.
  real_t servo_relaxation = 0.5;            // (0, 0.5]
  real_t servo_integral_relaxation = 0.05;  // [0, servo_relaxation]
  // servo = "gains": a PI controller of each servo-controlled axis' strain rate on its relative
  // stress error e = (sigma_ii - target) / target: edot_i = gain e + integral_gain int e dt.
  real_t servo_gain = 4.0;                     // 1/s
  real_t servo_integral_gain = 2000.0;         // 1/s^2
  real_t max_strain_rate = 1.0;                // 1/s, cap of the servo's strain rates
  real_t stress_tolerance = 0.005;             // relative, to end consolidation / re-equilibration
  real_t unbalanced_tolerance = 1e-4;          // unbalanced-force ratio to end them
  std::int64_t servo_interval = 2;             // steps between stress measurements of the servo (5 with
                                               // servo = "gains", the interval its gains were tuned at)
  real_t axial_strain_rate = 0.5;              // 1/s, compression of axis 1 during shear
  real_t axial_strain = 0.25;                  // eps_1 at the end of shear
  real_t preparation_damping = 0.7;            // local damping alpha while consolidating / equilibrating
  real_t shear_damping = 0.0;                  // alpha during shear
  std::int64_t max_stage_steps = 2000000;      // a stage that does not converge ends the run
  std::vector<real_t> rolling_friction_cases;  // a sweep over mu_r (empty: [contact] value)
  // Realisations: the whole test on each of these generated specimens ([particles] seed of
  // each; empty: the one of [particles] seed). From realisations = N (seeds seed, seed + 1, ...)
  // or seeds = [...]; run by apps/ensemble.cpp, each into OUT/seed_<s>/.
  std::vector<std::uint64_t> seeds;
  // Consolidations at these mu_s besides consolidation_friction's (the study's figure 2(b): void
  // ratio and Z against the consolidation friction), each into OUT/seed_<s>_consolidation_<mu>/;
  // the cases shear the one of consolidation_friction. apps/ensemble.cpp.
  std::vector<real_t> consolidation_friction_cases;
  bool consolidation_only = false;  // set by apps/ensemble.cpp for those: no case is run
  real_t progress_seconds = 5.0;    // a progress line at most this often
  // The servo keys above as the stages take them (apps/triaxial_stages.hpp).
  ServoSettings servo_settings() const {
    return {servo,           servo_relaxation, servo_integral_relaxation, servo_gain,          servo_integral_gain,
            max_strain_rate, servo_interval,   stress_tolerance,          unbalanced_tolerance};
  }
};

// Domain decomposition over MPI ranks (ignored on one rank).
struct ParallelSpec {
  std::string decomposition = "cartesian";  // "cartesian" or "metis"
  double rebalance_threshold = 1.10;        // max/mean owned particles that triggers METIS
  std::int64_t rebalance_interval = 10;     // neighbour rebuilds between imbalance checks
  std::string cut = "work";                 // Cartesian runs of bins: "work" or "even"
  std::string balance = "count";            // what "work" weighs: "count" or "time" (parallel/balance_policy.hpp)
  // Groups of ranks that run different realisations at once (0: "auto", the most groups that
  // divide the ranks and have a realisation each); 1: every realisation on all ranks in turn.
  std::int64_t groups = 1;
};

// Fabric analysis of the contact sub-networks (core/fabric.hpp, docs/fabric.md) at the output
// rows of a triaxial test's shear stage and at the end of consolidation.
struct FabricSpec {
  bool enabled = true;          // used by [triaxial] and [[stage]] scenes
  real_t strong_ratio = 1.0;    // strong contact: f_n > strong_ratio * mean f_n (> 0)
  std::int64_t rose_bins = 36;  // rose diagram bins over [0, pi) (1 .. 3600)
};

// [fields] (docs/fields.md, "Fields during a run"): the coarse-grained fields computed during the
// run every 'every' output rows and written into run.h5. Absent (enabled = false): nothing is
// computed nor allocated.
struct FieldsSpec {
  bool enabled = false;
  std::optional<std::array<int, 3>> cells;  // nodes along x, y, z; or
  std::optional<real_t> spacing;            // m: round(L_a / spacing) nodes along axis a (default: width)
  bool lucy = false;                        // kernel = "lucy" (else "gaussian")
  real_t width = 0;                         // m: the Gaussian's standard deviation, Lucy's support radius
  real_t cutoff = 3;                        // Gaussian: support radius in widths (>= 1)
  std::int64_t every = 1;                   // output rows between field instants (>= 1)
  std::vector<std::string> quantities;      // empty: every quantity (coarse_grain(), displacement_fields())

  // Whether the run writes the dataset 'name' (core/coarse_grain.hpp): every one without
  // `quantities`, else those listed ("networks": every contact_density_<k> and fabric_<k>).
  bool keeps(const std::string& name) const;
  // Whether a network dataset is kept (else the network sums are not computed).
  bool networks() const;
  // Whether a displacement dataset is kept (displacement, displacement_gradient,
  // strain_increment): then every field instant needs the previous one's positions.
  bool displacement() const;
  // Whether the series carry the column `localisation` ([fields] given, the strain increment kept).
  bool localisation() const { return enabled && keeps("strain_increment"); }
};

// [[wall]]: a plane inside the periodic cell (docs/scene.md, "Walls"). The contact law is the
// scene's [contact] with the keys given in the wall's table replaced.
struct WallSpec {
  Vec3 point = Vec3::Zero();     // m
  Vec3 normal = Vec3::UnitZ();   // unit (normalised from the input), into the granular domain
  Vec3 velocity = Vec3::Zero();  // m/s
  // Servo control (pressure > 0, core/wall_servo.hpp): the wall moves along its normal to keep
  // the spheres' push on it at pressure x the cell's cross-section.
  real_t pressure = 0;            // Pa
  real_t servo_relaxation = 0.5;  // fraction of the force error one step corrects, (0, 1)
  real_t max_speed = 0;           // m/s; 0: 1e-3 of the smallest radius per time step
  bool own_law = false;           // some [contact] key given in the wall's table
  ContactLawParams law;           // the scene's law with the wall's keys
  std::int32_t material = -1;     // the [[material]] it names (index into Scene::materials), or -1
};

// [[material]] (docs/scene.md, "Materials"): the k-th table is material k (Particles::material).
struct MaterialSpec {
  std::string name;
  ContactLawParams law;    // [contact] with the material's keys
  real_t density = 0;      // kg/m^3, of its generated spheres
  std::int64_t type = -1;  // the data file's atom type of its spheres (-1: none)
  real_t fraction = 0;     // its share of the generated spheres, by number (0: none)
  bool spheres() const { return type >= 0 || fraction > 0; }
};

struct Scene {
  std::string path;  // the scene file ("<built-in demo>" for the default)
  std::string text;  // the scene file's text, kept for the output
  ParticleSource source = ParticleSource::Generate;
  GenerateSpec generate;
  real_t density = 2650;          // kg/m^3 (generated spheres)
  std::string data_file;          // resolved path (source = file)
  std::optional<Vec3> cell_size;  // m; for a data file, the box in the file by default
  ContactLawParams law;
  real_t local_damping = 0;  // alpha
  CompressSpec compress;
  std::int64_t steps = 1000;
  real_t time_step_fraction = 0.25;
  std::optional<real_t> time_step;  // s; overrides the fraction when given
  bool force_time_step = false;
  real_t skin = 0.001;  // m
  std::int64_t output_every = 100;
  Vec3 gravity = Vec3::Zero();          // m/s^2
  real_t max_overlap = 1.0;             // stop when an overlap exceeds this fraction of the smaller radius
  std::int64_t snapshot_every = 10000;  // steps between HDF5 snapshots (docs/output.md)
  bool hdf5 = true;                     // write OUT/run.h5 and OUT/run.xmf
  real_t kinetic_runaway = 1.5;  // stop when kinetic (or stored + dissipated) energy > this x the energy put in (>= 1)
  real_t max_initial_overlap = 0.2;   // refuse an initial overlap above this fraction of the smaller radius
  real_t density_scaling = 1.0;       // masses and moments of inertia multiplied by this (> 0)
  std::int64_t checkpoint_every = 0;  // steps between checkpoints (0 = none by count)
  real_t checkpoint_seconds = 600;    // s of wall-clock time between checkpoints (0 = none by time)
  TriaxialSpec triaxial;
  ParallelSpec parallel;
  FabricSpec fabric;
  FieldsSpec fields;
  // The [[stage]] tables, in order (io/serial/stage_spec.hpp; empty: none). A scene gives them, or
  // [triaxial], or neither (a plain run).
  std::vector<StageSpec> stages;
  std::vector<WallSpec> walls;    // [[wall]]
  std::vector<DrivenSet> driven;  // [[driven]] (docs/scene.md "Driven particles")
  // [[material]] and [[material_pair]] (empty: one material, [contact]'s law and [particles]
  // density). With exactly one [[material]], 'law' and 'density' are its own.
  std::vector<MaterialSpec> materials;
  std::vector<Materials::Given> material_pairs;
};

// The law of every pair of the scene's materials (core/contact/materials.hpp); empty for a
// scene of one material.
Materials scene_materials(const Scene& sc);
// The material of generated sphere 'id' (a scene with [[material]] fractions): the fractions'
// share of the ids, by a low-discrepancy sequence of the id (the same on any rank count).
std::uint8_t generated_material(const Scene& sc, GlobalId id);

Scene load_scene(const std::string& path);
Scene parse_scene(const std::string& text, const std::string& path);  // path: for messages
Scene default_scene();                                                // examples/demo.toml, built into the executable

}  // namespace fabrica
