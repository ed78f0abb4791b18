// The XDMF 3 sidecars of run.h5 (docs/output.md): small XML files that tell ParaView (or any
// XDMF reader) where the snapshot datasets lie in the HDF5 file, one temporal collection per
// case. Written to path.tmp, checked, synced and renamed (io/serial/write_check.hpp).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <tuple>
#include <vector>

namespace fabrica {

// (case, step, time, rows): one snapshot, with its particles or contacts.
using XdmfEntry = std::tuple<std::string, std::int64_t, double, std::int64_t>;

// The spheres' sidecar for 'entries' (rows = particles N) in h5file (a name relative to the
// xmf): each snapshot a Polyvertex grid whose connectivity is the first N values of the
// dataset layout::kVertexIndex (length 'vertices' >= every N).
void write_xdmf(const std::string& path, const std::string& h5file, const std::vector<XdmfEntry>& entries,
                std::int64_t vertices);
// The contacts' sidecar for 'entries' (rows = contacts M > 0): each snapshot a Polyline grid
// of M two-node cells whose points are contacts/ends (x1, x1 + branch), with the cell
// attributes fn, ft_norm, mr_norm, sliding, rolling, strong, id1, id2.
void write_contacts_xdmf(const std::string& path, const std::string& h5file, const std::vector<XdmfEntry>& entries,
                         std::int64_t vertices);

// The periodic cell of one snapshot: (case, step, time) and its matrix H row by row (H[3 r + c];
// the columns are the edge vectors).
struct CellXdmfEntry {
  std::string case_name;
  std::int64_t step = 0;
  double time = 0;
  std::array<double, 9> h{};
};
// The cell's sidecar (a sheared cell's slanted box in ParaView): per case a temporal collection,
// each snapshot a Polyline grid of the cell's 12 edges (two-node cells) between its 8 corners
// H s, s in {0, 1}^3 (corner i + 2 j + 4 k at s = (i, j, k)), given inline (Format="XML"), with
// the cell attribute 'edge' (1, 2, 3: the edge vector each line runs along).
void write_cell_xdmf(const std::string& path, const std::vector<CellXdmfEntry>& entries);

// One instant of coarse-grained fields (docs/fields.md): the group of its datasets in h5file,
// the grid (nodes along x, y, z; spacing and first node, m) and each dataset's name and number
// of components (1 scalar, 3 vector, 9 tensor).
struct FieldsXdmfEntry {
  std::string case_name, group;  // group: absolute path of the instant's group
  std::int64_t step = 0;
  double time = 0;
  std::array<int, 3> cells{1, 1, 1};
  std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
  // The nodes are the dataset kNodePosition of the group (nz, ny, nx, 3), not origin + i spacing:
  // a sheared grid, and every grid of a case whose cell shears (docs/fields.md "A sheared cell":
  // ParaView's Xdmf3 reader takes the grid type of a temporal collection from its grids).
  bool explicit_nodes = false;
  std::vector<std::pair<std::string, int>> quantities;
};
// The dataset of the node positions in an instant's group (not a field), FieldsXdmfEntry::explicit_nodes.
inline constexpr const char* kNodePosition = "node_position";
// The fields' sidecar: per case a temporal collection of 3DCoRectMesh grids (nodes at
// origin + i spacing; explicit_nodes: a 3DSMesh whose XYZ geometry is kNodePosition), each
// dataset a node attribute (Dimensions nz ny nx [components]).
void write_fields_xdmf(const std::string& path, const std::string& h5file, const std::vector<FieldsXdmfEntry>& entries);

// s with &, <, > and " escaped for XML text and attributes.
std::string xml_escape(const std::string& s);

}  // namespace fabrica
