// Scene files: valid scenes parse to the documented values; bad input is refused with a message
// that names the file, the field and the value.
#include "io/serial/scene.hpp"
#include "io/serial/setup.hpp"
#include "core/restitution.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

using namespace fabrica;

namespace {

// Expects parse_scene to throw an InputError whose message contains every fragment.
void expect_error(const std::string& text, std::initializer_list<std::string> fragments) {
  try {
    parse_scene(text, "bad.toml");
    FAIL() << "no error for:\n" << text;
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("bad.toml"), std::string::npos) << m;
    for (const auto& f : fragments) EXPECT_NE(m.find(f), std::string::npos) << "missing '" << f << "' in: " << m;
  }
}

}  // namespace

TEST(Scene, DefaultsAndValues) {
  const Scene s = parse_scene(R"(
[particles]
count = 500
d_min = 0.002
d_max = 0.004
[contact]
normal_stiffness = 2.5e5
friction = 0.5
rolling_friction = 0.1
damping_ratio_normal = 0.2
[run]
steps = 10
time_step = 1e-6
gravity = [0, 0, -9.81]
)",
                              "ok.toml");
  EXPECT_EQ(s.generate.count, 500);
  EXPECT_DOUBLE_EQ(s.generate.d_min, 0.002);
  EXPECT_EQ(s.law.stiffness_mode, NormalStiffnessMode::Direct);
  EXPECT_DOUBLE_EQ(s.law.normal_stiffness, 2.5e5);
  EXPECT_DOUBLE_EQ(s.law.friction, 0.5);
  EXPECT_DOUBLE_EQ(s.law.rolling_friction, 0.1);
  EXPECT_DOUBLE_EQ(s.law.damping_ratio_n, 0.2);
  EXPECT_DOUBLE_EQ(*s.time_step, 1e-6);
  EXPECT_DOUBLE_EQ(s.gravity[2], -9.81);
  EXPECT_DOUBLE_EQ(s.law.stiffness_ratio, 1.0);  // default
  EXPECT_DOUBLE_EQ(s.skin, 0.001);               // default
  EXPECT_FALSE(s.compress.enabled);
}

TEST(Scene, DemoSceneIsValidAndMatchesExample) {
  const Scene s = default_scene();
  std::ifstream in(std::string(FABRICA_SOURCE_DIR) + "/examples/demo.toml");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(s.text, text);
  EXPECT_TRUE(s.triaxial.enabled);
  EXPECT_EQ(s.triaxial.rolling_friction_cases.size(), 2u);
}

TEST(Scene, NonPositiveAndNegativeValuesAreRefused) {
  expect_error("[particles]\nd_min = -0.01\n", {"[particles]", "d_min", "-0.01", "positive"});
  expect_error("[particles]\ndensity = 0\n", {"density", "0", "positive"});
  expect_error("[contact]\nyoungs_modulus = -1e8\n", {"[contact]", "youngs_modulus", "-100000000"});
  expect_error("[contact]\nnormal_stiffness = 0.0\n", {"normal_stiffness", "positive"});
  expect_error("[contact]\nstiffness_ratio = 0\n", {"stiffness_ratio", "positive"});
  expect_error("[contact]\nfriction = -0.2\n", {"friction", "-0.2", ">= 0"});
  expect_error("[contact]\nrolling_friction = -0.05\n", {"rolling_friction", "-0.05"});
  expect_error("[run]\nskin = 0\n", {"[run]", "skin"});
  expect_error("[run]\nlocal_damping = 1.5\n", {"local_damping", "1.5"});
  expect_error("[run]\ntime_step = -1e-6\n", {"time_step", "-1e-06"});
}

TEST(Scene, NaNAndInfAreRefused) {
  expect_error("[contact]\nfriction = nan\n", {"friction", "nan", "finite"});
  expect_error("[contact]\nyoungs_modulus = inf\n", {"youngs_modulus", "inf", "finite"});
  expect_error("[cell]\nsize = [0.4, nan, 0.8]\n", {"[cell]", "size", "finite"});
}

TEST(Scene, UnknownKeysAndTablesAreRefused) {
  expect_error("[contact]\nfricton = 0.3\n", {"[contact]", "fricton", "unknown key"});
  expect_error("[contacts]\nfriction = 0.3\n", {"contacts", "unknown top-level"});
  expect_error("steps = 10\n", {"steps", "unknown top-level"});
}

TEST(Scene, WrongTypesAndContradictionsAreRefused) {
  expect_error("[contact]\nfriction = \"high\"\n", {"friction", "high", "number"});
  expect_error("[run]\nsteps = 1.5\n", {"steps", "1.5", "integer"});
  expect_error("[contact]\nyoungs_modulus = 1e8\nnormal_stiffness = 1e6\n", {"not both"});
  expect_error("[run]\ntime_step = 1e-6\ntime_step_fraction = 0.2\n", {"time_step", "not both"});
  expect_error("[particles]\nsource = \"lattice\"\n", {"source", "lattice"});
  expect_error("[particles]\nsource = \"file\"\n", {"file", "missing"});
  expect_error("[particles]\nd_min = 0.05\nd_max = 0.01\n", {"d_max", "0.01", "d_min"});
  expect_error("[contact\nfriction = 0.3\n", {"bad.toml:1", "syntax"});
}

TEST(Scene, TimeStepAboveTheEstimateIsRefusedUnlessForced) {
  Scene s = parse_scene("[particles]\ncount = 50\nd_max = 0.012\n[run]\ntime_step_fraction = 1.5\n", "bad.toml");
  try {
    make_setup(s);
    FAIL() << "time_step_fraction 1.5 accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("bad.toml: [run] time_step_fraction = 1.5"), std::string::npos) << m;
  }
  s.force_time_step = true;
  const fabrica::Setup ok = make_setup(s);
  EXPECT_NEAR(ok.params.dt, 1.5 * ok.critical_dt, 1e-15);

  Scene t = parse_scene("[particles]\ncount = 50\nd_max = 0.012\n[run]\ntime_step = 1.0\n", "bad.toml");
  EXPECT_THROW(make_setup(t), InputError);
}

TEST(Scene, TriaxialTableIsValidated) {
  const Scene s = parse_scene(
      "[triaxial]\nconfining_pressure = 1e5\nrolling_friction_cases = [0.0, 0.05]\n"
      "axial_strain = 0.1\n",
      "ok.toml");
  EXPECT_TRUE(s.triaxial.enabled);
  EXPECT_DOUBLE_EQ(s.triaxial.confining_pressure, 1e5);
  EXPECT_EQ(s.triaxial.rolling_friction_cases, (std::vector<real_t>{0.0, 0.05}));
  expect_error("[triaxial]\nconfining_pressure = -2e5\n", {"[triaxial]", "confining_pressure", "-200000"});
  expect_error("[triaxial]\nrolling_friction_cases = [0.1, -0.2]\n", {"rolling_friction_cases", "-0.2"});
  expect_error("[triaxial]\naxial_strain = 1.5\n", {"axial_strain", "1.5"});
  expect_error("[triaxial]\nservo_gian = 1\n", {"servo_gian", "unknown key"});
  expect_error("[triaxial]\n[compress]\n", {"[compress] and [triaxial]"});
  expect_error("[triaxial]\n[run]\nsteps = 10\n", {"[run] steps", "not used with [triaxial]"});
}

TEST(Scene, FabricTableIsValidated) {
  const Scene d = parse_scene("[triaxial]\n", "ok.toml");
  EXPECT_TRUE(d.fabric.enabled);
  EXPECT_EQ(d.fabric.strong_ratio, 1.0);
  EXPECT_EQ(d.fabric.rose_bins, 36);
  const Scene s = parse_scene("[triaxial]\n[fabric]\nenabled = false\nstrong_ratio = 1.5\nrose_bins = 18\n", "ok.toml");
  EXPECT_FALSE(s.fabric.enabled);
  EXPECT_EQ(s.fabric.strong_ratio, 1.5);
  EXPECT_EQ(s.fabric.rose_bins, 18);
  expect_error("[fabric]\nstrong_ratio = 0\n", {"[fabric] strong_ratio = 0", "must be positive"});
  expect_error("[fabric]\nrose_bins = 0\n", {"[fabric] rose_bins = 0", "[1, 3600]"});
  expect_error("[fabric]\nrose_bins = 2.5\n", {"[fabric] rose_bins", "must be an integer"});
  expect_error("[fabric]\nenabled = 1\n", {"[fabric] enabled", "true or false"});
  expect_error("[fabric]\nbins = 3\n", {"[fabric] bins", "unknown key"});
}

// [parallel]: the defaults, values, and bad values refused naming the key.
TEST(Scene, ParallelKeys) {
  const Scene d = parse_scene("", "empty.toml");
  EXPECT_EQ(d.parallel.decomposition, "cartesian");
  EXPECT_EQ(d.parallel.rebalance_threshold, 1.10);
  EXPECT_EQ(d.parallel.rebalance_interval, 10);
  EXPECT_EQ(d.parallel.cut, "work");
  const Scene s = parse_scene("[parallel]\ncut = \"even\"\nrebalance_interval = 4\n", "ok.toml");
  EXPECT_EQ(s.parallel.cut, "even");
  EXPECT_EQ(s.parallel.rebalance_interval, 4);
  EXPECT_EQ(d.parallel.balance, "count");
  EXPECT_EQ(parse_scene("[parallel]\nbalance = \"time\"\n", "ok.toml").parallel.balance, "time");
  expect_error("[parallel]\nbalance = \"speed\"\n",
               {"bad.toml", "[parallel] balance = \"speed\"", "\"count\" or \"time\""});
  expect_error("[parallel]\ncut = \"weight\"\n", {"[parallel] cut = \"weight\"", "\"work\" or \"even\""});
  expect_error("[parallel]\ncut = 1\n", {"[parallel]", "cut"});
  expect_error("[parallel]\nrebalance_interval = 0\n", {"[parallel] rebalance_interval = 0", "positive"});
  expect_error("[parallel]\ndecomposition = \"rcb\"\n",
               {"[parallel] decomposition = \"rcb\"", "\"cartesian\" or \"metis\""});
  expect_error("[parallel]\nrebalance_threshold = 0.9\n", {"[parallel]", "rebalance_threshold", ">= 1"});
  expect_error("[parallel]\ncuts = \"work\"\n", {"[parallel]", "cuts", "unknown key"});
}

TEST(Scene, OutputKeys) {
  const Scene d = parse_scene("", "empty.toml");
  EXPECT_EQ(d.snapshot_every, 10000);
  EXPECT_TRUE(d.hdf5);
  const Scene s = parse_scene("[run]\nsnapshot_every = 250\nhdf5 = false\n", "out.toml");
  EXPECT_EQ(s.snapshot_every, 250);
  EXPECT_FALSE(s.hdf5);
  expect_error("[run]\nsnapshot_every = 0\n", {"[run]", "snapshot_every", "0", "positive"});
  expect_error("[run]\nsnapshot_every = 1.5\n", {"snapshot_every", "1.5", "integer"});
  expect_error("[run]\nhdf5 = \"yes\"\n", {"[run]", "hdf5", "yes", "true or false"});
}

// [run] checkpoint_every (steps, 0 = off) and checkpoint_seconds (s, 0 = off): docs/scene.md.
TEST(Scene, CheckpointKeys) {
  const Scene d = parse_scene("", "none.toml");
  EXPECT_EQ(d.checkpoint_every, 0);
  EXPECT_EQ(d.checkpoint_seconds, 600.0);
  const Scene s = parse_scene("[run]\ncheckpoint_every = 5000\ncheckpoint_seconds = 0\n", "ck.toml");
  EXPECT_EQ(s.checkpoint_every, 5000);
  EXPECT_EQ(s.checkpoint_seconds, 0.0);
  expect_error("[run]\ncheckpoint_every = -1\n", {"[run]", "checkpoint_every", "-1", ">= 0"});
  expect_error("[run]\ncheckpoint_every = 2.5\n", {"checkpoint_every", "integer"});
  expect_error("[run]\ncheckpoint_seconds = -60\n", {"[run]", "checkpoint_seconds", "-60", ">= 0"});
  expect_error("[run]\ncheckpoint_seconds = nan\n", {"checkpoint_seconds", "finite"});
}

// The bad-input corpus of issue 16 (scene side): sizes outside what a sphere can be, and a count
// whose memory the machine does not have, refused with the field and the value.
TEST(Scene, DiametersOutsideTheirRangeAreRefused) {
  expect_error("[particles]\nd_min = 1e-310\n", {"[particles]", "d_min", "1e-310", "[1e-09, 1000] m"});
  expect_error("[particles]\nd_min = 0.01\nd_max = 5000\n", {"d_max", "5000", "at most 1000 m"});
}

TEST(Scene, CountBeyondTheMachinesMemoryIsRefusedBeforeAllocation) {
  try {
    make_setup(parse_scene("[particles]\ncount = 1000000000000000\n", "bad.toml"));
    FAIL() << "count = 1e15 accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    for (const char* f :
         {"bad.toml", "[particles] count = 1000000000000000", "needs at least", "of memory", "the machine has"})
      EXPECT_NE(m.find(f), std::string::npos) << "missing '" << f << "' in: " << m;
  }
}

// The servo's mode: "stiffness" by default (interval 2), "gains" when servo_gain or
// servo_integral_gain is given (interval 5, as before); keys of the other mode are refused.
TEST(Scene, ServoModeAndItsKeys) {
  const Scene d = parse_scene("[triaxial]\n", "s.toml");
  EXPECT_EQ(d.triaxial.servo, ServoMode::Stiffness);
  EXPECT_EQ(d.triaxial.servo_interval, 2);
  EXPECT_EQ(d.triaxial.servo_relaxation, 0.5);
  EXPECT_EQ(d.triaxial.servo_integral_relaxation, 0.05);
  const Scene g = parse_scene("[triaxial]\nservo_gain = 12.0\n", "s.toml");
  EXPECT_EQ(g.triaxial.servo, ServoMode::Gains);
  EXPECT_EQ(g.triaxial.servo_interval, 5);
  EXPECT_EQ(g.triaxial.servo_gain, 12.0);
  const Scene r =
      parse_scene("[triaxial]\nservo = \"stiffness\"\nservo_relaxation = 0.3\nservo_interval = 4\n", "s.toml");
  EXPECT_EQ(r.triaxial.servo_relaxation, 0.3);
  EXPECT_EQ(r.triaxial.servo_interval, 4);
  expect_error("[triaxial]\nservo = \"pid\"\n", {"[triaxial]", "servo", "pid", "stiffness"});
  EXPECT_EQ(d.triaxial.equilibration, TriaxialSpec::Equilibration::Common);
  EXPECT_EQ(parse_scene("[triaxial]\nequilibration = \"case\"\n", "s.toml").triaxial.equilibration,
            TriaxialSpec::Equilibration::Case);
  EXPECT_EQ(parse_scene("[triaxial]\nequilibration = \"common\"\n", "s.toml").triaxial.equilibration,
            TriaxialSpec::Equilibration::Common);
  EXPECT_EQ(parse_scene("[triaxial]\nequilibration = \"none\"\n", "s.toml").triaxial.equilibration,
            TriaxialSpec::Equilibration::None);
  expect_error("[triaxial]\nequilibration = \"shared\"\n",
               {"[triaxial]", "equilibration", "\"shared\"", "\"case\", \"common\" or \"none\""});
  expect_error("[triaxial]\nservo = \"stiffness\"\nservo_gain = 4.0\n", {"servo_gain", "gains"});
  expect_error("[triaxial]\nservo_gain = 4.0\nservo_relaxation = 0.3\n", {"servo_relaxation", "stiffness"});
  expect_error("[triaxial]\nservo_relaxation = 0.7\n", {"servo_relaxation", "0.7", "(0, 0.5]"});
  expect_error("[triaxial]\nservo_integral_relaxation = 0.6\n", {"servo_integral_relaxation", "0.6"});
}

// [[stage]] tables (io/serial/stage_parse.cpp): each type's controls, end conditions, contact
// parameters and servo keys; bad input refused with stage[i].field and the value.
TEST(Scene, StageList) {
  const Scene s = parse_scene(R"(
[[stage]]
type = "isotropic"
pressure = 1e5
friction = 1.0
local_damping = 0.7
damping_ratio_normal = 0.4
end = { at_rest = true }
[[stage]]
name = "by hand"
type = "mixed"
control.axis_1 = { strain_rate = -0.5 }
control.axis_2 = { stress = 2e5 }
control.axis_3 = { stress = 3e5 }
max_strain_rate = 2.0
servo_interval = 4
end = { strain = 0.1, q_p = 1.5 }
[[stage]]
type = "true_triaxial"
pressure = 1e5
b = 0.5
axial_strain_rate = 0.2
end = { steps = 100 }
[[stage]]
type = "cyclic_stress"
pressure = 1e5
axial_strain_rate = 0.2
amplitude = 5e4
cycles = 3
[[stage]]
type = "triaxial_extension"
pressure = 1e5
axial_strain_rate = 0.2
end = { strain = -0.01, strain_axis = 1 }
)",
                              "s.toml");
  ASSERT_EQ(s.stages.size(), 5u);
  const StageSpec& a = s.stages[0];
  EXPECT_EQ(a.name, "isotropic");
  EXPECT_EQ(a.where, "stage[1]");
  EXPECT_EQ(a.stress, Vec3::Constant(1e5));
  EXPECT_TRUE(a.end.at_rest);
  EXPECT_EQ(*a.law.get(&ContactLawParams::friction), 1.0);
  EXPECT_FALSE(a.law.get(&ContactLawParams::rolling_friction));
  EXPECT_EQ(*a.local_damping, 0.7);
  EXPECT_EQ(*a.law.get(&ContactLawParams::damping_ratio_n), 0.4);
  EXPECT_FALSE(a.law.get(&ContactLawParams::damping_ratio_s));
  const StageSpec& m = s.stages[1];
  EXPECT_EQ(m.name, "by hand");
  EXPECT_EQ(m.mode[0], AxisMode::StrainRate);
  EXPECT_EQ(m.rate[0], -0.5);
  EXPECT_EQ(m.mode[2], AxisMode::Stress);
  EXPECT_EQ(m.stress[2], 3e5);
  EXPECT_EQ(m.servo.max_strain_rate, 2.0);
  EXPECT_EQ(m.servo.interval, 4);
  EXPECT_EQ(*m.end.strain, 0.1);
  EXPECT_EQ(*m.end.q_p, 1.5);
  EXPECT_EQ(s.stages[2].path, StagePath::TrueTriaxial);
  EXPECT_EQ(s.stages[2].b, 0.5);
  EXPECT_EQ(s.stages[2].rate[0], -0.2);
  EXPECT_EQ(*s.stages[2].end.steps, 100);
  EXPECT_EQ(s.stages[3].path, StagePath::CyclicStress);
  EXPECT_EQ(s.stages[3].cycles, 3);
  EXPECT_TRUE(s.stages[3].end.cycles);
  EXPECT_EQ(s.stages[4].rate[0], 0.2);  // extension lengthens axis 1

  expect_error("[[stage]]\ntype = \"shear\"\nend = { steps = 1 }\n",
               {"stage[1].type", "\"shear\"", "unknown stage type"});
  expect_error("[[stage]]\nend = { steps = 1 }\n", {"stage[1].type", "(missing)"});
  expect_error(
      "[[stage]]\ntype = \"hold\"\nend = { steps = 1 }\n[[stage]]\ntype = \"mixed\"\n"
      "control.axis_1 = { stress = 1e5, strain_rate = 0.1 }\ncontrol.axis_2 = { stress = 1e5 }\n"
      "control.axis_3 = { stress = 1e5 }\nend = { steps = 1 }\n",
      {"stage[2].control.axis_1", "contradictory controls"});
  expect_error(
      "[[stage]]\ntype = \"mixed\"\ncontrol.axis_1 = { stress = 1e5 }\ncontrol.axis_2 = { stress = 1e5 }\n"
      "end = { steps = 1 }\n",
      {"stage[1].control.axis_3", "(missing)"});
  expect_error("[[stage]]\ntype = \"isotropic\"\npressure = 1e5\n", {"stage[1].end", "no end condition"});
  expect_error("[[stage]]\ntype = \"isotropic\"\npressure = 0\nend = { at_rest = true }\n",
               {"stage[1].pressure = 0", "positive"});
  expect_error("[[stage]]\ntype = \"isotropic\"\nend = { at_rest = true }\n", {"stage[1].pressure", "(missing)"});
  expect_error("[[stage]]\ntype = \"anisotropic\"\nstress = [1e5, -1, 1e5]\nend = { at_rest = true }\n",
               {"stage[1].stress", "three positive"});
  expect_error("[[stage]]\ntype = \"hold\"\npressure = 1e5\nend = { steps = 1 }\n", {"stage[1].pressure", "not used"});
  expect_error("[[stage]]\ntype = \"hold\"\nend = { steps = 0 }\n", {"stage[1].end.steps = 0"});
  expect_error("[[stage]]\ntype = \"hold\"\nend = { steps = 3000000 }\n",
               {"stage[1].end.steps = 3000000", "max_steps"});
  expect_error("[[stage]]\ntype = \"hold\"\nend = { stepz = 3 }\n", {"stage[1].end.stepz", "unknown key"});
  expect_error("[[stage]]\ntype = \"cyclic_strain\"\npressure = 1e5\naxial_strain_rate = 0.1\namplitude = 0.01\n",
               {"stage[1].cycles", "(missing)"});
  expect_error(
      "[[stage]]\ntype = \"cyclic_stress\"\npressure = 1e5\naxial_strain_rate = 0.1\namplitude = 2e5\ncycles = 1\n",
      {"stage[1].amplitude = 200000", "below pressure"});
  expect_error(
      "[[stage]]\ntype = \"triaxial_compression\"\npressure = 1e5\naxial_strain_rate = 0.1\nend = { strain = -0.1 }\n",
      {"stage[1].end.strain = -0.1", "never reached"});
  expect_error(
      "[[stage]]\ntype = \"triaxial_compression\"\npressure = 1e5\naxial_strain_rate = 5\nend = { strain = 0.1 }\n",
      {"stage[1].axial_strain_rate = 5", "max_strain_rate"});
  expect_error("[[stage]]\ntype = \"hold\"\nlocal_damping = 1.0\nend = { steps = 1 }\n",
               {"stage[1].local_damping = 1", "[0, 1)"});
  expect_error("[[stage]]\ntype = \"hold\"\ndamping_ratio_normal = 1.0\nend = { steps = 1 }\n",
               {"stage[1].damping_ratio_normal = 1", "[0, 1)"});
  expect_error("[[stage]]\ntype = \"hold\"\ndamping_ratio_shear = -0.1\nend = { steps = 1 }\n",
               {"stage[1].damping_ratio_shear = -0.1", "[0, 1)"});
  expect_error("[[stage]]\ntype = \"hold\"\nname = \"a,b\"\nend = { steps = 1 }\n", {"stage[1].name", "commas"});
  expect_error("stage = 3\n", {"stage = 3", "array of tables"});
  expect_error("[triaxial]\n[[stage]]\ntype = \"hold\"\nend = { steps = 1 }\n",
               {"[[stage]] and [triaxial] both given"});
  expect_error("[compress]\n[[stage]]\ntype = \"hold\"\nend = { steps = 1 }\n",
               {"[[stage]] and [compress] both given"});
  expect_error("[run]\nsteps = 5\n[[stage]]\ntype = \"hold\"\nend = { steps = 1 }\n", {"[run] steps = 5", "[[stage]]"});
}

// The shear stages (issue 42; docs/shear.md): control.shear_ij of a mixed stage, simple_shear
// (its plane: the normal axis first, then the direction it slides along), cyclic_simple_shear,
// principal_rotation; contradictory or incomplete controls refused naming the stage and key.
TEST(Scene, ShearStages) {
  const Scene s = parse_scene(R"([[stage]]
type = "mixed"
control.axis_1 = { stress = 1e5 }
control.axis_2 = { stress = 1e5 }
control.axis_3 = { strain_rate = 0.0 }
control.shear_12 = { stress = -2e4 }
control.shear_23 = { strain_rate = 0.01 }
end = { at_rest = true }
[[stage]]
type = "simple_shear"
pressure = 1e5
shear_strain_rate = 0.05
plane = "31"
end = { shear_strain = 0.2 }
[[stage]]
type = "cyclic_simple_shear"
constant_volume = true
shear_strain_rate = 0.1
amplitude_stress = 3e4
cycles = 5
[[stage]]
type = "principal_rotation"
pressure = 1e5
q = 3e4
b = 0.5
rotation_rate = -45
angle = 90
end = { steps = 10 }
[[stage]]
type = "hold"
end = { steps = 1 }
)",
                              "shear.toml");
  ASSERT_EQ(s.stages.size(), 5u);
  const StageSpec& m = s.stages[0];
  EXPECT_TRUE(m.shears());
  EXPECT_EQ(m.shear_mode[0], AxisMode::Stress);
  EXPECT_EQ(m.shear_stress[0], -2e4);
  EXPECT_EQ(m.shear_mode[1], AxisMode::StrainRate);
  EXPECT_EQ(m.shear_rate[1], 0.0);
  EXPECT_EQ(m.shear_rate[2], 0.01);
  EXPECT_EQ(m.shear_normal, -1);  // rotation-free
  const StageSpec& ss = s.stages[1];
  EXPECT_EQ(ss.path, StagePath::SimpleShear);
  EXPECT_EQ(ss.shear_normal, 2);      // planes normal to axis 3
  EXPECT_EQ(ss.shear_direction, 0);   // slide along axis 1
  EXPECT_EQ(ss.shear_rate[1], 0.05);  // the 13 component
  EXPECT_EQ(ss.mode[2], AxisMode::Stress);
  EXPECT_EQ(ss.stress[2], 1e5);
  EXPECT_EQ(ss.mode[0], AxisMode::StrainRate);  // the lateral axes fixed
  EXPECT_EQ(ss.rate[0], 0.0);
  EXPECT_EQ(*ss.end.shear_strain, 0.2);
  EXPECT_EQ(ss.end.shear_component, 1);
  const StageSpec& c = s.stages[2];
  EXPECT_EQ(c.path, StagePath::CyclicShearStress);
  EXPECT_EQ(c.mode, (std::array<AxisMode, 3>{AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate}));
  EXPECT_EQ(c.amplitude, 3e4);
  EXPECT_EQ(c.cycles, 5);
  EXPECT_TRUE(c.end.cycles);
  const StageSpec& r = s.stages[3];
  EXPECT_EQ(r.path, StagePath::PrincipalRotation);
  EXPECT_NEAR(r.rotation_rate, -std::numbers::pi / 4, 1e-15);
  EXPECT_NEAR(r.angle, std::numbers::pi / 2, 1e-15);
  EXPECT_TRUE(r.end.angle);
  // At the start angle 0: s11 = s1, s22 = s3, s33 = s2 = s3 + b (s1 - s3), p and q as given.
  const Vec3 sp = principal_stresses(1e5, 3e4, 0.5);
  EXPECT_NEAR(sp.sum() / 3, 1e5, 1e-9);
  EXPECT_NEAR(std::sqrt(0.5 *
                        ((sp[0] - sp[1]) * (sp[0] - sp[1]) + (sp[1] - sp[2]) * (sp[1] - sp[2]) +
                         (sp[2] - sp[0]) * (sp[2] - sp[0]))),
              3e4, 1e-9);
  EXPECT_NEAR(r.stress[0], sp[0], 1e-9);
  EXPECT_NEAR(r.stress[1], sp[2], 1e-9);
  EXPECT_NEAR(r.stress[2], sp[1], 1e-9);
  EXPECT_FALSE(s.stages[4].shears());
  EXPECT_TRUE(any_shears(s.stages));

  const std::string mixed =
      "[[stage]]\ntype = \"mixed\"\ncontrol.axis_1 = { stress = 1e5 }\ncontrol.axis_2 = { stress = 1e5 }\n"
      "control.axis_3 = { stress = 1e5 }\n";
  expect_error(mixed + "control.shear_12 = { stress = 1e4, strain_rate = 0.1 }\nend = { steps = 1 }\n",
               {"stage[1].control.shear_12", "contradictory controls"});
  expect_error(mixed + "control.shear_13 = { }\nend = { steps = 1 }\n", {"stage[1].control.shear_13", "give"});
  expect_error(mixed + "control.shear_21 = { stress = 1e4 }\nend = { steps = 1 }\n",
               {"stage[1].control.shear_21", "unknown key"});
  expect_error(mixed + "control.shear_12 = { strain_rate = 2.0 }\nend = { steps = 1 }\n",
               {"stage[1].control.shear_12.strain_rate = 2", "max_strain_rate"});
  expect_error(mixed + "control.shear_12 = { strain_rate = -0.1 }\nend = { shear_strain = 0.1 }\n",
               {"stage[1].end.shear_strain = 0.1", "never reached"});
  expect_error(mixed + "end = { shear_strain = 0.1 }\n",
               {"stage[1].end.shear_strain = 0.1", "controls no shear component"});
  expect_error(mixed + "control.shear_12 = { strain_rate = 0.1 }\n", {"stage[1].end", "no end condition"});
  const std::string simple = "[[stage]]\ntype = \"simple_shear\"\nshear_strain_rate = 0.1\n";
  expect_error(simple + "constant_volume = true\npressure = 1e5\nend = { shear_strain = 0.1 }\n",
               {"stage[1].pressure = 100000", "contradictory controls"});
  expect_error(simple + "end = { shear_strain = 0.1 }\n", {"stage[1].pressure", "(missing)"});
  expect_error(simple + "pressure = 1e5\nplane = \"11\"\nend = { shear_strain = 0.1 }\n",
               {"stage[1].plane = \"11\"", "two different axes"});
  expect_error(simple + "pressure = 1e5\nend = { shear_strain = -0.1 }\n",
               {"stage[1].end.shear_strain = -0.1", "never reached"});
  expect_error(simple +
                   "pressure = 1e5\nlateral = \"pressure\"\nconstant_volume = false\namplitude = 0.1\n"
                   "end = { shear_strain = 0.1 }\n",
               {"stage[1].amplitude", "not used"});
  expect_error(
      "[[stage]]\ntype = \"cyclic_simple_shear\"\nshear_strain_rate = 0.1\nconstant_volume = true\n"
      "amplitude = 0.01\namplitude_stress = 1e4\ncycles = 2\n",
      {"stage[1].amplitude_stress = 10000", "contradictory controls"});
  expect_error(
      "[[stage]]\ntype = \"cyclic_simple_shear\"\nshear_strain_rate = 0.1\nconstant_volume = true\n"
      "cycles = 2\n",
      {"stage[1].amplitude", "(missing)"});
  const std::string rot = "[[stage]]\ntype = \"principal_rotation\"\npressure = 1e5\nb = 0.5\n";
  expect_error(rot + "q = 3e4\nangle = 90\n", {"stage[1].rotation_rate", "(missing)"});
  expect_error(rot + "q = 3e5\nrotation_rate = 10\nangle = 90\n", {"stage[1].q = 300000", "too large"});
  expect_error("[[stage]]\ntype = \"hold\"\nshear_strain_rate = 0.1\nend = { steps = 1 }\n",
               {"stage[1].shear_strain_rate", "not used"});
}

// Without the key, a generated specimen is placed sequentially below 200,000 spheres (the
// study's specimens unchanged) and by regions from 200,000 on; the key overrides either way.
TEST(Scene, PlacementDefaultsToRegionsForLargeSpecimens) {
  auto placement = [](const std::string& particles) {
    return parse_scene("[particles]\n" + particles + "\n", "p.toml").generate.placement;
  };
  using P = GenerateSpec::Placement;
  EXPECT_EQ(placement("count = 13584"), P::Sequential);
  EXPECT_EQ(placement("count = 199999"), P::Sequential);
  EXPECT_EQ(placement("count = 200000"), P::Regions);
  EXPECT_EQ(placement("count = 4000000"), P::Regions);
  EXPECT_EQ(placement("count = 4000000\nplacement = \"sequential\""), P::Sequential);
  EXPECT_EQ(placement("count = 1000\nplacement = \"regions\""), P::Regions);
  EXPECT_EQ(GenerateSpec::kRegionsFrom, 200000);
}

// The example scenes parse, and say what their comments say.
TEST(Scene, ExampleScenesAreValid) {
  const std::string dir = std::string(FABRICA_SOURCE_DIR) + "/examples/";
  const Scene paper = load_scene(dir + "paper.toml");
  EXPECT_EQ(paper.generate.count, 13584);
  EXPECT_EQ(paper.generate.placement, GenerateSpec::Placement::Sequential);
  EXPECT_EQ(paper.triaxial.rolling_friction_cases.size(), 6u);
  EXPECT_EQ(paper.time_step_fraction, 0.5);  // the time-to-solution settings (docs/triaxial.md)
  EXPECT_EQ(paper.skin, 0.003);
  const Scene ensemble = load_scene(dir + "paper_ensemble.toml");
  EXPECT_EQ(ensemble.triaxial.seeds, (std::vector<std::uint64_t>{13584, 13585, 13586, 13587, 13588}));
  EXPECT_EQ(ensemble.triaxial.consolidation_friction_cases, (std::vector<real_t>{0.1, 0.3, 0.5, 0.7, 1.0}));
  EXPECT_EQ(ensemble.parallel.groups, 0);  // "auto"
  EXPECT_EQ(ensemble.generate.count, paper.generate.count);
  // One realisation at 8 x the study's size: the paper protocol otherwise unchanged.
  const Scene big = load_scene(dir + "paper_large.toml");
  EXPECT_EQ(big.generate.count, 8 * paper.generate.count);
  EXPECT_EQ(big.generate.seed, paper.generate.seed);
  EXPECT_EQ(big.generate.placement, GenerateSpec::Placement::Sequential);
  EXPECT_EQ(big.triaxial.rolling_friction_cases, paper.triaxial.rolling_friction_cases);
  EXPECT_EQ(big.triaxial.consolidation_friction, paper.triaxial.consolidation_friction);
  EXPECT_EQ(big.triaxial.axial_strain, paper.triaxial.axial_strain);
  EXPECT_EQ(big.triaxial.axial_strain_rate, paper.triaxial.axial_strain_rate);
  EXPECT_EQ(big.law.youngs_modulus, paper.law.youngs_modulus);
  EXPECT_EQ(big.law.friction, paper.law.friction);
  EXPECT_EQ(big.time_step_fraction, paper.time_step_fraction);
  EXPECT_EQ(big.skin, paper.skin);
  EXPECT_EQ(big.parallel.groups, 1);
  const Scene large = load_scene(dir + "large.toml");
  EXPECT_EQ(large.generate.count, 200000);
  EXPECT_EQ(large.generate.placement, GenerateSpec::Placement::Regions);
  EXPECT_TRUE(large.triaxial.enabled);
  EXPECT_EQ(large.triaxial.rolling_friction_cases, std::vector<real_t>{0.1});
  EXPECT_EQ(large.checkpoint_seconds, 600.0);
  EXPECT_EQ(large.time_step_fraction, 0.5);  // the paper scene's settings (docs/large.md)
  EXPECT_EQ(large.skin, 0.003);
  EXPECT_EQ(large.law.youngs_modulus, paper.law.youngs_modulus);
  // The shear examples (docs/shear.md): the study's law, a cubic cell, the paths their comments say.
  const Scene simple = load_scene(dir + "simple_shear.toml");
  EXPECT_EQ(simple.law.youngs_modulus, paper.law.youngs_modulus);
  EXPECT_EQ(simple.law.friction, paper.law.friction);
  ASSERT_EQ(simple.stages.size(), 3u);
  const StageSpec& ss = simple.stages[2];
  EXPECT_EQ(ss.path, StagePath::SimpleShear);
  EXPECT_EQ(ss.shear_normal, 0);
  EXPECT_EQ(ss.shear_direction, 1);
  EXPECT_EQ(ss.stress[0], 100e3);
  EXPECT_EQ(*ss.end.shear_strain, 0.3);
  const Scene cyclic = load_scene(dir + "cyclic_simple_shear.toml");
  EXPECT_EQ(cyclic.law.youngs_modulus, paper.law.youngs_modulus);
  ASSERT_EQ(cyclic.stages.size(), 3u);
  EXPECT_EQ(cyclic.stages[1].shear_mode[0], AxisMode::Stress);  // all six components controlled
  const StageSpec& cs = cyclic.stages[2];
  EXPECT_EQ(cs.path, StagePath::CyclicShearStress);
  EXPECT_EQ(cs.mode, (std::array<AxisMode, 3>{AxisMode::StrainRate, AxisMode::StrainRate, AxisMode::StrainRate}));
  EXPECT_EQ(cs.rate, Vec3::Zero());  // constant volume
  EXPECT_EQ(cs.amplitude, 15e3);
  EXPECT_EQ(cs.cycles, 4);
}

// Walls and driven particles do not follow a deforming cell: refused with [[stage]].
TEST(Scene, StagesWithWallsOrDrivenParticlesAreRefused) {
  const std::string stage = "[[stage]]\ntype = \"isotropic\"\npressure = 1e5\nend.steps = 10\n";
  expect_error("[particles]\ncount = 100\n" + stage + "[[wall]]\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n",
               {"[[stage]] and [[wall]] both given"});
  expect_error("[particles]\ncount = 100\n" + stage + "[[driven]]\nids = [1]\n",
               {"[[stage]] and [[driven]] both given"});
}

// [contact] model (docs/scene.md, "Contact models"): the keys of one model refused with the other.
TEST(Scene, HertzMindlinModelAndItsKeys) {
  const Scene s = parse_scene(
      "[contact]\nmodel = \"hertz_mindlin\"\nyoungs_modulus = 7e10\npoisson_ratio = 0.3\n"
      "restitution_normal = 0.5\nfriction = 0.4\n",
      "h.toml");
  EXPECT_EQ(s.law.model, ContactModel::HertzMindlin);
  EXPECT_EQ(s.law.youngs_modulus, 7e10);
  EXPECT_EQ(s.law.poisson_ratio, 0.3);
  EXPECT_NEAR(hertz_clamped_restitution(s.law.damping_ratio_n), 0.5, 1e-8);
  EXPECT_EQ(s.law.damping_ratio_s, s.law.damping_ratio_n);  // LIGGGHTS: one beta for both
  EXPECT_EQ(parse_scene("[contact]\nfriction = 0.4\n", "l.toml").law.model, ContactModel::Linear);
  expect_error("[contact]\nmodel = \"hertz\"\n", {"[contact]", "model", "\"hertz\"", "hertz_mindlin"});
  expect_error("[contact]\nmodel = \"hertz_mindlin\"\nnormal_stiffness = 1e5\n",
               {"[contact]", "normal_stiffness", "100000", "model = \"linear\""});
  expect_error("[contact]\nmodel = \"hertz_mindlin\"\nstiffness_ratio = 2\n", {"stiffness_ratio", "2"});
  expect_error("[contact]\nmodel = \"hertz_mindlin\"\ndamping_rate_normal = 20\n", {"damping_rate_normal", "20"});
  expect_error("[contact]\npoisson_ratio = 0.3\n", {"[contact]", "poisson_ratio", "0.3", "hertz_mindlin"});
  expect_error("[contact]\nmodel = \"hertz_mindlin\"\npoisson_ratio = 0.5\n", {"poisson_ratio", "0.5", "(-1, 0.5)"});
  expect_error("[contact]\nmodel = \"hertz_mindlin\"\npoisson_ratio = -1\n", {"poisson_ratio", "-1", "(-1, 0.5)"});
}

// [contact] rolling_model and rolling_damping (docs/scene.md, "Rolling resistance models").
TEST(Scene, RollingModelsAndTheirKeys) {
  const Scene s =
      parse_scene("[contact]\nrolling_friction = 0.1\nrolling_model = \"epsd\"\nrolling_damping = 0.3\n", "r.toml");
  EXPECT_EQ(s.law.rolling_model, RollingModel::Epsd);
  EXPECT_EQ(s.law.rolling_damping, 0.3);
  EXPECT_TRUE(s.law.viscous());  // the rolling dashpot needs the masses
  EXPECT_EQ(parse_scene("[contact]\nrolling_model = \"constant_torque\"\n", "c.toml").law.rolling_model,
            RollingModel::ConstantTorque);
  EXPECT_EQ(parse_scene("[contact]\n", "d.toml").law.rolling_model, RollingModel::ElasticPlastic);
  expect_error("[contact]\nrolling_model = \"epsd2\"\n",
               {"[contact]", "rolling_model", "\"epsd2\"", "constant_torque"});
  expect_error("[contact]\nrolling_damping = 0.3\n", {"[contact]", "rolling_damping", "0.3", "epsd"});
  expect_error("[contact]\nrolling_model = \"epsd\"\nrolling_damping = 1.2\n", {"rolling_damping", "1.2", "[0, 1)"});
}

// [contact] twisting_friction (docs/scene.md, "Twisting resistance"), a wall's own and a stage's.
TEST(Scene, TwistingFrictionAndItsKeys) {
  EXPECT_FALSE(parse_scene("[contact]\n", "d.toml").law.twisting());
  const Scene s = parse_scene("[contact]\nmodel = \"hertz_mindlin\"\ntwisting_friction = 0.05\n", "t.toml");
  EXPECT_EQ(s.law.twisting_friction, 0.05);
  EXPECT_TRUE(s.law.twisting());
  EXPECT_FALSE(s.law.rolling());  // one without the other
  const Scene w = parse_scene("[[wall]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\ntwisting_friction = 0.2\n", "w.toml");
  ASSERT_EQ(w.walls.size(), 1u);
  EXPECT_TRUE(w.walls[0].own_law);
  EXPECT_EQ(w.walls[0].law.twisting_friction, 0.2);
  EXPECT_FALSE(w.law.twisting());
  expect_error("[contact]\ntwisting_friction = -0.1\n", {"[contact]", "twisting_friction", "-0.1", ">= 0"});
  expect_error("[[wall]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\ntwisting_friction = -2\n",
               {"[wall #1]", "twisting_friction", "-2", ">= 0"});
}

// The law's declared parameters (core/contact/params.hpp kLawParameters): every scene key is in
// docs/scene.md's [contact] table with its unit, and its bound refuses a value outside it in
// [contact] by name (each key with its model), in [[wall]] where a wall may give it, and in
// [[stage]] where a stage may; the checkpoint's and HDF5's field list is the same list.
TEST(Scene, LawParametersAreDeclaredOnce) {
  std::ifstream in(std::string(FABRICA_SOURCE_DIR) + "/docs/scene.md");
  ASSERT_TRUE(in) << "docs/scene.md";
  std::stringstream doc;
  doc << in.rdbuf();
  const std::string text = doc.str();
  const std::size_t from = text.find("## `[contact]`"), to = text.find("\n## ", from + 1);
  ASSERT_NE(from, std::string::npos);
  const std::string contact = text.substr(from, to - from);
  struct Names {
    std::vector<std::string> v;
    void field(const char* n, std::uint8_t) { v.push_back(n); }
    void field(const char* n, real_t) { v.push_back(n); }
  } names;
  const ContactLawParams law;
  law_fields(names, law);
  ASSERT_EQ(names.v.size(), std::size(kLawParameters));
  std::size_t k = 0;
  for (const LawParameter& p : kLawParameters) {
    EXPECT_EQ(names.v[k++], p.field);
    if (!p.key) continue;
    const std::string row = "| `" + std::string(p.key) + "` | " + p.unit + " |";
    EXPECT_NE(contact.find(row), std::string::npos) << "docs/scene.md [contact] lacks the row " << row;
    // A value outside the bound: -1 fails every bound but Poisson's, which -2 fails.
    const std::string bad = p.bound == Bound::Poisson ? "-2" : "-1";
    const std::string model = p.model == ForModel::HertzMindlin ? "model = \"hertz_mindlin\"\n" : "";
    const std::string epsd = p.member == &ContactLawParams::rolling_damping ? "rolling_model = \"epsd\"\n" : "";
    expect_error("[contact]\n" + model + epsd + p.key + " = " + bad + "\n",
                 {"[contact]", p.key, bad, bound_text(p.bound)});
    if (p.wall)
      expect_error(
          "[contact]\n" + model + "[[wall]]\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n" + p.key + " = " + bad + "\n",
          {"[wall #1]", p.key, bad, bound_text(p.bound)});
    if (p.wall)  // a [[material]] takes the keys a wall takes
      expect_error("[contact]\n" + model + "[[material]]\nname = \"m\"\nfraction = 1.0\n" + p.key + " = " + bad + "\n",
                   {"[material #1]", p.key, bad, bound_text(p.bound)});
    if (p.stage)
      expect_error("[[stage]]\ntype = \"hold\"\n" + std::string(p.key) + " = " + bad + "\nend = { steps = 1 }\n",
                   {std::string("stage[1].") + p.key, bad, bound_text(p.bound)});
  }
}
