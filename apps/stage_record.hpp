// What one stage wrote (its series rows, fabric rows and HDF5 series rows), kept to be written
// again for another case: under [triaxial] equilibration = "common" every case of a sweep is
// re-equilibrated from the same consolidated state with the same parameters, so the first case
// runs the re-equilibration once and every later case starts from a copy of its end state
// (apps/triaxial_sweep.cpp) with these rows and links to its snapshots and field instants
// (RunOutput::link_snapshots, link_fields): the files are those a repeated re-equilibration would
// write, character for character.
#pragma once
#include "apps/fabric_output.hpp"

#include <cstdint>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

namespace fabrica {

class RunOutput;

class StageRecord {
 public:
  // Kept while a StageRun records (StageRun::record): the text of the rows written to the series
  // stream and the fabric streams (only on the ranks that write them: rank 0), and the HDF5
  // series rows (every rank, as RunOutput::series_row wants them).
  std::ostringstream series;
  FabricStreams fabric() { return {&fabric_, &sff_, &rose_}; }
  void h5_row(const std::string& stage, std::int64_t step, const double* values, std::size_t n);
  // The stage's steps: its snapshots are those of the source case after 'first_step' up to and
  // including 'last_step'.
  std::int64_t first_step = 0, last_step = 0;

  // Writes the rows to another case's files: 'series' and 'fabric' (rank 0's streams, null
  // elsewhere), and with 'output' (collective) its HDF5 series rows, snapshots and field
  // instants, the latter two as links to those of 'source_case'. 'csv_header' is the series'
  // header line.
  void replay(std::ostream* series, const FabricStreams* fabric, RunOutput* output, const std::string& csv_header,
              const std::string& source_case, const std::string& case_name) const;

 private:
  struct Row {
    std::string stage;
    std::int64_t step;
    std::vector<double> values;
  };
  std::vector<Row> h5_;
  std::ostringstream fabric_, sff_, rose_;
};

}  // namespace fabrica
