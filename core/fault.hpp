// A test hook, read in this one place: FABRICA_FAULT_INJECT=RANK:SITE[,RANK:SITE...] makes the
// named site fail on that MPI rank alone, as a real failure there would (a read that cannot open
// its file, a write that finds the disk full). It exists so that tests can show that an error met
// by one rank ends every rank with its message, and nothing hangs (tests/cli, docs/output.md).
// Sites: "scene" (the scene file), "data" (the particle data file), "snapshot" (a contact
// snapshot read from run.h5), "checkpoint" (the checkpoint read, rank 0's), "csv" (a CSV or
// fabric-file write, rank 0's), "h5" (a run.h5 dataset write), "xdmf" (run.xmf). Unset: no effect.
#pragma once
#include <string>
#include <string_view>

namespace fabrica {

// The rank this process is (set once by the executable's error guard; 0 until then).
void set_fault_rank(int rank);
// True if FABRICA_FAULT_INJECT names 'site' for this rank.
bool fault_injected(std::string_view site);
// The text an injected failure reports.
std::string fault_text(std::string_view site);

}  // namespace fabrica
