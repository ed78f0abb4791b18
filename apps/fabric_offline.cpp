#include "apps/fabric_offline.hpp"

#include "apps/fabric_output.hpp"
#include "core/fabric.hpp"
#include "core/serial_domain.hpp"
#include "core/errors.hpp"
#include "io/mpi/snapshot.hpp"
#include "io/serial/write_check.hpp"
#include "parallel/guard.hpp"
#include "parallel/mpi_domain.hpp"

#include <fmt/core.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>

namespace fabrica {

int fabric_offline(const MpiContext& mpi, const FabricOfflineArgs& a) {
  namespace fs = std::filesystem;
  if (!(a.strong_ratio > 0)) throw InputError(fmt::format("--strong-ratio = {}: must be positive", a.strong_ratio));
  if (a.bins < 1 || a.bins > 3600) throw InputError(fmt::format("--bins = {}: must lie in [1, 3600]", a.bins));
  // Which snapshots: by case, in step order (list_snapshots sorts them so).
  // Every rank reads run.h5 itself; the ranks agree on the outcome of each read, so that a read
  // that fails on one rank ends every rank with its message (parallel/guard.hpp).
  std::map<std::string, std::vector<SnapshotInfo>> chosen;
  std::vector<SnapshotInfo> listed;
  agree(mpi.comm(), [&] { listed = list_snapshots(a.file); });
  for (const SnapshotInfo& s : listed)
    if (a.case_name.empty() || s.case_name == a.case_name) chosen[s.case_name].push_back(s);
  if (chosen.empty())
    throw InputError(a.case_name.empty() ? fmt::format("{}: no contact snapshots in the file", a.file)
                                         : fmt::format("{}: no snapshots of case \"{}\"", a.file, a.case_name));
  for (auto& [name, list] : chosen) {
    if (a.step) {
      std::vector<SnapshotInfo> one;
      for (const SnapshotInfo& s : list)
        if (s.step == *a.step) one.push_back(s);
      if (one.empty() && !a.case_name.empty())
        throw InputError(fmt::format("{}: case \"{}\" has no snapshot at step {}", a.file, name, *a.step));
      list = one;
    } else if (!a.all) {
      list = {list.back()};
    }
  }
  const fs::path out = a.outdir.empty() ? fs::path(a.file).parent_path() / "fabric" : fs::path(a.outdir);
  const bool root = mpi.rank() == 0;
  std::unique_ptr<Domain> domain;
  if (mpi.size() > 1) domain = std::make_unique<MpiDomain>(mpi.comm());
  else domain = std::make_unique<SerialDomain>();
  const FabricOptions opt{a.strong_ratio, int(a.bins)};
  std::size_t analysed = 0;
  for (const auto& [name, list] : chosen) {
    if (list.empty()) continue;
    // Each file is written to PATH.tmp, checked, synced and renamed over PATH at the end
    // (io/serial/write_check.hpp): a failed write leaves an earlier analysis as it was.
    std::ofstream f, s, r;
    const std::array<std::string, 3> paths{(out / name / "fabric.csv").string(), (out / name / "sff.csv").string(),
                                           (out / name / "rose.csv").string()};
    std::array<std::ofstream*, 3> files{&f, &s, &r};
    FabricStreams streams;
    agree(mpi.comm(), [&] {
      if (!root) return;
      make_output_directory((out / name).string());
      for (int k = 0; k < 3; ++k) open_checked(*files[k], paths[k] + ".tmp");
      streams = {&f, &s, &r};
      write_fabric_headers(streams, int(a.bins));
      for (int k = 0; k < 3; ++k) check_stream(*files[k], paths[k] + ".tmp");
    });
    for (const SnapshotInfo& info : list) {
      ContactSnapshot snap;
      agree(mpi.comm(), [&] { snap = read_contact_snapshot(a.file, name, info.step); });
      // Wall contacts (id2 < 0, docs/output.md) are counted apart: the fabric is the particles'.
      std::vector<ContactRecord> mine;
      for (std::size_t c = std::size_t(mpi.rank()); c < snap.contacts.size(); c += std::size_t(mpi.size()))
        if (snap.contacts[c].id2 >= 0) mine.push_back(snap.contacts[c]);
      // The cell's volume: L1 L2 L3, or |det H| of a sheared cell (its cell_matrix).
      const FabricResult res = analyse_fabric(mine, snap.info.volume(), opt, *domain);
      agree(mpi.comm(), [&] {
        if (!root) return;
        write_fabric_rows(streams, "snapshot", info.step, snap.info.strain[0], res);
        for (int k = 0; k < 3; ++k) check_stream(*files[k], paths[k] + ".tmp");
      });
      if (!root) continue;
      std::size_t walls_all = 0;  // over the whole snapshot (every rank read it)
      for (const ContactRecord& c : snap.contacts) walls_all += c.id2 < 0;
      fmt::print(
          "{} step {}: eps1 {:.4f}, {} contacts{}, q/p {:.4f}, (q/p)* all {:.4f}, "
          "ns-sf/ns-wf/s-sf/s-wf {:.4f} (with the exact shares of p: {:.4f})\n",
          name, info.step, snap.info.strain[0], res.contacts,
          walls_all ? fmt::format(" (and {} with walls, not in the fabric)", walls_all) : std::string(), res.q_p,
          res.q_p_star[kPartAll], res.q_p_star[kPartSlideForce], res.q_p_exact[kPartSlideForce]);
      ++analysed;
    }
    agree(mpi.comm(), [&] {
      if (!root) return;
      for (int k = 0; k < 3; ++k) close_checked(*files[k], paths[k] + ".tmp");
      for (int k = 0; k < 3; ++k) replace_file(paths[k] + ".tmp", paths[k]);
    });
  }
  if (root)
    fmt::print("{} snapshot(s) analysed; fabric.csv, sff.csv, rose.csv written under {}\n", analysed, out.string());
  return 0;
}

}  // namespace fabrica
