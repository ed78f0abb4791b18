#include "apps/stage_record.hpp"

#include "io/mpi/run_output.hpp"

namespace fabrica {

void StageRecord::h5_row(const std::string& stage, std::int64_t step, const double* values, std::size_t n) {
  h5_.push_back({stage, step, std::vector<double>(values, values + n)});
}

void StageRecord::replay(std::ostream* series_out, const FabricStreams* fabric_out, RunOutput* output,
                         const std::string& csv_header, const std::string& source_case,
                         const std::string& case_name) const {
  if (series_out) *series_out << series.str();
  if (fabric_out) {
    if (fabric_out->fabric) *fabric_out->fabric << fabric_.str();
    if (fabric_out->sff) *fabric_out->sff << sff_.str();
    if (fabric_out->rose) *fabric_out->rose << rose_.str();
  }
  if (!output) return;
  for (const Row& r : h5_) output->series_row(case_name, csv_header, r.stage, r.step, r.values);
  output->link_snapshots(source_case, case_name, first_step, last_step);
  output->link_fields(source_case, case_name, first_step, last_step);
}

}  // namespace fabrica
