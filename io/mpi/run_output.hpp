// The run's output file OUT/run.h5, written collectively by every rank with MPI-IO, and its
// XDMF sidecars (layout, units and guarantees in docs/output.md):
//   /scene                           the scene text; attribute path
//   /snapshots/<case>/<step>         attributes step, time, cell_lengths, cell_matrix, strain, ...
//   /snapshots/<case>/<step>/particles/{id,position,velocity,spin,radius}
//   /snapshots/<case>/<step>/contacts/{id1,id2,normal,branch,overlap,fn,ft,mr,sliding,rolling,
//                                      strong,ft_norm,mr_norm,ends}
//   /series/<case>/<column>          the macro series, one extendible dataset per CSV column
// and the sidecars OUT/run.xmf, OUT/run_contacts.xmf and, once a snapshot's cell is sheared,
// OUT/run_cell.xmf (the cell's edges). Snapshots are stored in global id order whatever the
// number of ranks, written in rounds of a bounded size by io/mpi/snapshot_writer.hpp; nothing is
// gathered on one rank.
// Every member function is collective: every rank calls it with the same arguments.
#pragma once
#include "core/coarse_grain.hpp"
#include "core/simulation.hpp"
#include "io/mpi/field_history.hpp"
#include "io/mpi/h5.hpp"
#include "io/serial/scene.hpp"
#include "io/mpi/xdmf.hpp"

#include <mpi.h>

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <vector>

namespace fabrica {

class RunOutput {
 public:
  // Creates OUT/run.h5 (and OUT); an existing file is refused with an InputError unless
  // 'overwrite'. Writes the version attributes and the scene.
  RunOutput(MPI_Comm comm, const Scene& scene, const std::string& outdir, bool overwrite);
  // A restart (fabrica run --restart): opens the existing OUT/run.h5 read-write (no overwrite
  // needed). Before anything is written, rank 0 opens it read-only and checks it is a Fabrica
  // output file of this scene; if not (e.g. corrupt), an InputError names it and nothing is
  // touched. A missing run.h5 is created anew ('created_anew()' then true). Call
  // resume_after() next, once the case the checkpoint was taken in is known.
  struct Restart {};
  RunOutput(MPI_Comm comm, const Scene& scene, const std::string& outdir, Restart);
  // Closes the file if close() was not called (errors then only printed) - except while an
  // exception unwinds on several ranks: it may be this rank's alone, and closing is collective,
  // so the file is abandoned instead (flushed at the last snapshot). Callers close() explicitly
  // on errors that every rank meets (CollectiveError, InputError).
  ~RunOutput();
  RunOutput(const RunOutput&) = delete;
  RunOutput& operator=(const RunOutput&) = delete;

  static std::string file_name(const std::string& outdir);  // OUT/run.h5

  // One row of the series of 'case_name'. 'csv_header' is the CSV header line of that series
  // (its columns name the datasets; "stage" and "step" are stored apart); 'stage' is the
  // row's value of the stage column ("" if the header has none); 'values' are the remaining
  // columns in header order. Rows are buffered and appended at the next snapshot or flush().
  void series_row(const std::string& case_name, const std::string& csv_header, const std::string& stage,
                  std::int64_t step, std::span<const double> values);

  std::int64_t snapshot_every() const { return every_; }
  bool snapshot_due(std::int64_t step) const { return step % every_ == 0; }
  // The particles and contacts of 'sim' now, with the strain eps_i = ln(l_i0 / l_i). A second
  // snapshot of the same case and step is skipped (e.g. the end of a stage on a cadence step).
  void snapshot(const std::string& case_name, const Simulation& sim, const Vec3& strain);
  // [fields] (docs/fields.md, "Fields during a run"): whether the output row at 'k' steps (the
  // counter of the caller's loop: of the run, or of the stage) is a field instant, k a multiple of
  // [fields] every x [run] output_every; always false without [fields] (nothing else is done).
  bool fields_due(std::int64_t k) const { return fields_steps_ > 0 && k % fields_steps_ == 0; }
  // The coarse-grained fields of 'sim' now (io/mpi/run_fields.hpp), into /fields/<case>/<step>,
  // with the displacement fields since the case's previous field instant when [fields] keeps
  // them; a second instant of the same case and step is skipped. Returns the instant's
  // localisation index (core/localisation.hpp) when it has a strain increment, else NaN (the
  // series' column `localisation`). Collective.
  double fields(const std::string& case_name, Simulation& sim);
  // The previous field instant's positions (io/mpi/field_history.hpp): saved in checkpoints and
  // restored on a restart (apps/app_checkpoint.hpp). Empty unless [fields] keeps a displacement
  // field.
  FieldHistory& field_history() { return history_; }
  const FieldHistory& field_history() const { return history_; }
  double fields_seconds() const { return fields_seconds_; }  // wall time computing and writing them
  std::int64_t field_instants() const { return std::int64_t(fields_xmf_.size()); }

  // The snapshots of 'source_case' with a step in (first_step, last_step] also become snapshots
  // of 'case_name' (the same steps), as HDF5 hard links: stored once, read through either path.
  // For a stage that two cases share (apps/stage_record.hpp).
  void link_snapshots(const std::string& source_case, const std::string& case_name, std::int64_t first_step,
                      std::int64_t last_step);
  // The same for the field instants ([fields]): /fields/<case_name>/<step> links to
  // /fields/<source_case>/<step>, with their sidecar entries.
  void link_fields(const std::string& source_case, const std::string& case_name, std::int64_t first_step,
                   std::int64_t last_step);

  // A restart from a checkpoint taken at 'step' in case cases[current] ('cases': every case of
  // the run in the order it writes them): removes the series rows with a step after 'step' and
  // the snapshots after it of that case, and the series and snapshots of every later case
  // (which starts over); earlier cases are kept. Rebuilds the XDMF sidecar(s) from what
  // remains and flushes; later rows and snapshots are appended as in an uninterrupted run.
  void resume_after(std::int64_t step, const std::vector<std::string>& cases, std::size_t current);
  bool created_anew() const { return created_anew_; }

  // Appends the buffered series rows, flushes the file (H5Fflush) and rewrites run.xmf (and,
  // with several cases, run_<case>.xmf).
  void flush();
  void close();  // flush() and close the file; idempotent
  // close() on an error every rank has met (collective): a second failure (the disk is still
  // full) is not reported again; the file keeps what the last successful flush wrote.
  void close_after_error();

  double seconds() const { return seconds_; }  // wall time spent in output so far
  double bytes() const { return bytes_; }      // bytes of data written so far (all ranks)
  std::int64_t snapshots() const { return std::int64_t(xmf_.size()); }
  const std::string& path() const { return path_; }

 private:
  struct SeriesBuffer {
    std::vector<std::string> columns;  // value columns
    bool has_stage = false;
    std::vector<std::string> labels;  // stage names, code = index
    std::vector<std::int64_t> step;
    std::vector<std::uint8_t> stage;
    std::vector<std::vector<double>> values;  // per column, pending rows
    std::string header;
    hsize_t written = 0;
    bool created = false;
  };
  struct XmfEntry {
    std::string case_name;
    std::int64_t step;
    double time;
    std::int64_t particles;
    std::int64_t contacts;    // 0: not in the contacts' sidecar
    std::array<double, 9> h;  // the cell matrix, row by row (the attribute cell_matrix)
    bool sheared;             // h has an off-diagonal term: the cell's sidecar is written
  };
  void write_header(const Scene& scene);
  void write_snapshot(const std::string& case_name, const Simulation& sim, const Vec3& strain);
  void flush_all();
  void mark_failure(
      const std::function<void()>& f);  // failed_ = true if f throws  // version attributes, /scene, empty groups
  void flush_series();
  void write_xmf() const;
  void write_cell_xmf(const std::vector<std::string>& cases) const;  // run_cell.xmf, if sheared
  double write_fields(const std::string& case_name, Simulation& sim);

  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  std::string outdir_, path_;
  std::int64_t every_;
  double strong_ratio_;  // [fabric] strong_ratio: the strong flag of the stored contacts
  h5::File file_;
  std::map<std::string, SeriesBuffer> series_;
  std::vector<XmfEntry> xmf_;
  double seconds_ = 0, bytes_ = 0;
  std::int64_t vertices_ = 0;  // length of /xdmf/vertices
  // [fields]: the scene's table, its strong ratio and path; the steps between instants (0: none).
  FieldsSpec fields_spec_;
  double fields_strong_ratio_ = 1;
  std::string scene_path_;
  std::int64_t fields_steps_ = 0;
  // A stage of the scene shears the cell: every field instant's grid is written with its nodes'
  // positions (FieldsXdmfEntry::explicit_nodes), so that a case's grids are all of one type.
  bool fields_explicit_ = false;
  double fields_seconds_ = 0;
  // The last instant's fields, their storage reused by the next instant's (no fresh pages).
  FieldsResult spare_fields_;
  FieldHistory history_;  // the previous field instant's positions (displacement fields)
  std::vector<FieldsXdmfEntry> fields_xmf_;
  bool created_anew_ = false;
  bool failed_ = false;  // a write of this file failed: it is not flushed again
};

}  // namespace fabrica
