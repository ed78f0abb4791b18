// The checkpoint format's declared lists against docs/checkpoint.md ("Format"): the header's
// fields at their offsets (io/mpi/checkpoint_format.hpp), every field of a simulation's global
// section (io/mpi/simulation_fields.hpp, from the layout a write records), the format each
// optional field came in, and the record layouts; and the global section read back as written,
// or with its defaults when the optional fields are absent (a file of an earlier format).
#include "core/contact/params.hpp"
#include "io/mpi/checkpoint_format.hpp"
#include "io/mpi/simulation_fields.hpp"
#include "io/mpi/state_fields.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <utility>

namespace fabrica {
namespace {

// The "## Format" section of docs/checkpoint.md.
std::string format_section() {
  std::ifstream in(std::string(FABRICA_SOURCE_DIR) + "/docs/checkpoint.md");
  EXPECT_TRUE(in) << "docs/checkpoint.md";
  std::stringstream doc;
  doc << in.rdbuf();
  const std::string text = doc.str();
  const std::size_t from = text.find("## Format"), to = text.find("\n## ", from + 1);
  EXPECT_NE(from, std::string::npos);
  return text.substr(from, to - from);
}

// A global section with one of everything: a wall with its own law, a driven set, two
// materials, a run of the decomposition, a wall force; and, if 'sheared', a sheared cell.
SimulationGlobal sample(bool materials, bool sheared = false) {
  SimulationGlobal g;
  g.particle_record = particle_record_schema(materials);
  g.contact_record = contact_record_schema(false);
  g.cell_lengths = Vec3(1, 2, 3);
  if (sheared) {
    g.cell_sheared = true;
    g.cell_matrix << 1, 0, 0, 0.7, 2, 0, 0, 0, 3;  // edge 1 leans along axis 2
    g.cell_velocity_gradient.setZero();
    g.cell_velocity_gradient(1, 0) = 0.25;
    g.cell_strain.setZero();
    g.cell_strain(0, 1) = g.cell_strain(1, 0) = 0.35;
  }
  g.params.dt = 1e-6;
  Wall w;
  w.own_law = true;
  w.law.friction = 0.7;
  w.servo_pressure = 1e5;
  if (materials) w.material = 1;
  g.params.walls.push_back(w);
  DrivenSet d;
  d.ids = {3, 5};
  d.velocity = Vec3(0, 0, 1);
  g.params.driven.push_back(d);
  if (materials) {
    g.params.materials.names = {"sand", "steel"};
    g.params.materials.laws.resize(2);
    g.params.materials.pairs.resize(4);
    g.params.materials.pairs[1].pair_estar = 2e9;
  }
  g.step = 12;
  g.rebuilds = 3;
  g.time = 0.5;
  g.macro.wall_force = {Vec3(1, 2, 3)};
  g.decomposition.lengths = Vec3(1, 2, 3);
  g.decomposition.cuts = {0, 4};
  g.decomposition.since_check = 2;
  g.energy.e0 = 7;
  return g;
}

std::vector<std::string> names_of(const std::string& schema) {
  std::vector<std::string> out;
  std::stringstream s(schema);
  for (std::string e; std::getline(s, e, ';');) out.push_back(e.substr(0, e.find(':')));
  return out;
}

TEST(CheckpointFormat, HeaderAsDocumented) {
  const std::string doc = format_section();
  for (const std::string& f : header_layout())
    EXPECT_NE(doc.find(f), std::string::npos) << "docs/checkpoint.md's header row lacks '" << f << "'";
}

TEST(CheckpointFormat, GlobalFieldsAsDocumented) {
  const std::string doc = format_section();
  FieldWriter w;
  write_simulation_global(w, sample(true, true));
  std::set<std::string> seen;
  for (const std::string& n : names_of(w.schema())) {
    if (!seen.insert(n).second) continue;
    // The last measured state is documented as a whole (`macro.*`: MacroState's members).
    if (n.rfind("macro.", 0) == 0 || n.rfind("dissipation.", 0) == 0) {
      EXPECT_NE(doc.find("`macro.*`"), std::string::npos);
      continue;
    }
    EXPECT_NE(doc.find("`" + n + "`"), std::string::npos) << "docs/checkpoint.md does not name `" << n << "`";
  }
  for (bool m : {false, true}) {
    EXPECT_NE(doc.find("`" + particle_record_schema(m)), std::string::npos) << particle_record_schema(m);
    EXPECT_NE(doc.find("`" + contact_record_schema(m) + "`"), std::string::npos) << contact_record_schema(m);
  }
}

// A field a later format added is documented after that format's "format version N" or
// "since format N", the nearest such mention before its name.
TEST(CheckpointFormat, OptionalFieldsDocumentedWithTheirFormat) {
  const std::string doc = format_section();
  auto format_before = [&](const std::string& name) {
    const std::size_t at = doc.find("`" + name + "`");
    if (at == std::string::npos) return -1;
    int found = -1;
    std::size_t best = 0;
    for (const char* lead : {"format version ", "since format "}) {
      const std::size_t p = doc.rfind(lead, at);
      if (p != std::string::npos && p + 1 > best) {
        best = p + 1;
        found = std::atoi(doc.c_str() + p + std::string(lead).size());
      }
    }
    return found;
  };
  for (const OptionalField& f : kOptionalGlobalFields) EXPECT_EQ(format_before(f.name), int(f.since)) << f.name;
  for (const LawParameter& p : kLawParameters)
    if (p.since > int(kOldestCheckpointFormat)) EXPECT_EQ(format_before(p.field), p.since) << p.field;
}

// Read back as written (with and without materials, orthorhombic and sheared), and read again
// the same bytes.
TEST(CheckpointFormat, GlobalRoundTrip) {
  for (const auto& [m, sheared] : {std::pair{false, false}, {true, false}, {false, true}, {true, true}}) {
    FieldWriter w;
    const SimulationGlobal written = sample(m, sheared);
    write_simulation_global(w, written);
    // An orthorhombic cell's section holds no field of a sheared one (as format 10 wrote it).
    EXPECT_EQ(w.schema().find("cell.matrix") != std::string::npos, sheared);
    FieldReader r(w.schema(), w.bytes().data(), w.bytes().size(), "ck: section sim");
    const SimulationGlobal g = read_simulation_global(r, "ck: section sim", 2);
    EXPECT_EQ(g.params.materials.size(), m ? 2u : 0u);
    EXPECT_EQ(g.params.walls.at(0).material, m ? 1 : -1);
    EXPECT_EQ(g.params.walls.at(0).law.friction, 0.7);
    EXPECT_EQ(g.params.driven.at(0).ids.size(), 2u);
    EXPECT_EQ(g.decomposition.cuts.size(), 2u);
    EXPECT_EQ(g.macro.wall_force.size(), 1u);
    EXPECT_EQ(g.cell_sheared, sheared);
    const PeriodicCell cell = cell_of(g);
    EXPECT_EQ(cell.sheared(), sheared);
    if (sheared) {
      EXPECT_EQ(cell.matrix(), written.cell_matrix);
      EXPECT_EQ(cell.velocity_gradient(), written.cell_velocity_gradient);
      EXPECT_EQ(cell.strain(), written.cell_strain);
    } else {
      EXPECT_EQ(cell.lengths(), written.cell_lengths);
    }
    FieldWriter again;
    write_simulation_global(again, g);
    EXPECT_EQ(again.schema(), w.schema());
    EXPECT_EQ(again.bytes(), w.bytes());
  }
}

// The bounds a reader checks, by the messages of the field.
TEST(CheckpointFormat, GlobalCountsRefused) {
  SimulationGlobal g = sample(false);
  g.decomposition.cuts.assign(7, 0);  // more than 3 runs per rank of 2 ranks
  FieldWriter w;
  write_simulation_global(w, g);
  FieldReader r(w.schema(), w.bytes().data(), w.bytes().size(), "ck: section sim");
  try {
    read_simulation_global(r, "ck: section sim", 2);
    FAIL() << "no error";
  } catch (const std::exception& e) {
    EXPECT_EQ(std::string(e.what()),
              "ck: section sim: decomposition_cuts = 7, expected 0 to 6 (three axes of at most 2 runs)");
  }
}

}  // namespace
}  // namespace fabrica
