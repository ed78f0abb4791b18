// A stage's cursor and result (apps/stage_run.hpp) as named, typed fields of a checkpoint
// section (io/mpi/fields.hpp): another build reads them or refuses them naming the field.
#pragma once
#include "apps/stage_run.hpp"
#include "io/mpi/fields.hpp"

namespace fabrica {

void write_result(FieldWriter& w, const StageResult& r);
StageResult read_result(FieldReader& r);
void write_cursor(FieldWriter& w, const StageCursor& c);
StageCursor read_cursor(FieldReader& r);

}  // namespace fabrica
