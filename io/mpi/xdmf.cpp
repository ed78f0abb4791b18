#include "io/mpi/xdmf.hpp"

#include "io/mpi/layout.hpp"
#include "io/serial/write_check.hpp"

#include <algorithm>
#include <functional>
#include <map>
#include <sstream>

namespace fabrica {
namespace {

// An HDF DataItem of 'rows' (x 'cols' when non-zero) values at 'dataset' (file:/path).
std::string hdf_item(const std::string& dataset, std::int64_t rows, int cols, const char* type, int prec) {
  std::ostringstream d;
  d << "<DataItem Dimensions=\"" << rows;
  if (cols) d << ' ' << cols;
  d << "\" NumberType=\"" << type << "\" Precision=\"" << prec << "\" Format=\"HDF\">" << xml_escape(dataset)
    << "</DataItem>";
  return d.str();
}

// The connectivity: 'n' values from the start of the vertex index, as a hyperslab of 'dims'.
std::string vertex_slab(const std::string& h5file, const std::string& dims, std::int64_t n, std::int64_t vertices) {
  std::ostringstream x;
  x << "          <DataItem ItemType=\"HyperSlab\" Dimensions=\"" << dims << "\" Type=\"HyperSlab\">\n"
    << "            <DataItem Dimensions=\"3 1\" Format=\"XML\">0 1 " << n << "</DataItem>\n"
    << "            <DataItem Dimensions=\"" << vertices << "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">"
    << xml_escape(h5file + ":/" + layout::kVertexIndex) << "</DataItem>\n"
    << "          </DataItem>\n";
  return x.str();
}

// One sidecar: per case (in first-seen order) a temporal collection named case + suffix, and
// in it one uniform grid per entry of that case, named case + suffix + "_" + step, with its
// time; grid(x, entry, item) writes the grid's topology, geometry and attributes, item(ds,
// cols, type, precision) being the DataItem of dataset 'ds' of the entry's snapshot group
// 'group' ("particles" or "contacts").
using ItemFn = std::function<std::string(const std::string&, int, const char*, int)>;
void write_document(const std::string& path, const std::string& h5file, const std::vector<XdmfEntry>& entries,
                    const std::string& suffix, const std::string& group,
                    const std::function<void(std::ostringstream&, const XdmfEntry&, const ItemFn&)>& grid) {
  std::ostringstream x;
  x.precision(17);  // full precision for the times
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
       "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n  <Domain>\n";
  std::vector<std::string> cases;
  for (const auto& e : entries)
    if (std::find(cases.begin(), cases.end(), std::get<0>(e)) == cases.end()) cases.push_back(std::get<0>(e));
  for (const std::string& c : cases) {
    x << "    <Grid Name=\"" << xml_escape(c + suffix) << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (const XdmfEntry& e : entries) {
      const auto& [cn, step, time, rows] = e;
      if (cn != c) continue;
      const std::string base = h5file + ":/" + layout::snapshot_path(cn, step) + "/" + group + "/";
      const ItemFn item = [&](const std::string& ds, int cols, const char* type, int prec) {
        return hdf_item(base + ds, rows, cols, type, prec);
      };
      x << "      <Grid Name=\"" << xml_escape(c + suffix) << "_" << layout::step_name(step)
        << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << time << "\"/>\n";
      grid(x, e, item);
      x << "      </Grid>\n";
    }
    x << "    </Grid>\n";
  }
  x << "  </Domain>\n</Xdmf>\n";
  // Written to a temporary file, checked, synced and renamed (io/serial/write_check.hpp): a reader (or
  // a crash, or a full disk) never sees half a file, and a failed write keeps the previous one.
  write_file_atomic(path, x.str(), "xdmf");
}

}  // namespace

std::string xml_escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    if (c == '&') r += "&amp;";
    else if (c == '<') r += "&lt;";
    else if (c == '>') r += "&gt;";
    else if (c == '"') r += "&quot;";
    else r += c;
  }
  return r;
}

void write_xdmf(const std::string& path, const std::string& h5file, const std::vector<XdmfEntry>& entries,
                std::int64_t vertices) {
  write_document(
      path, h5file, entries, "", "particles", [&](std::ostringstream& x, const XdmfEntry& e, const ItemFn& item) {
        const std::int64_t n = std::get<3>(e);
        auto attribute = [&](const char* name, const char* kind, int cols, const char* type) {
          return std::string("        <Attribute Name=\"") + name + "\" AttributeType=\"" + kind +
              "\" Center=\"Node\">\n          " + item(name, cols, type, 8) + "\n        </Attribute>\n";
        };
        x << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\">\n"
          << vertex_slab(h5file, std::to_string(n), n, vertices) << "        </Topology>\n"
          << "        <Geometry GeometryType=\"XYZ\">\n          " << item("position", 3, "Float", 8)
          << "\n        </Geometry>\n"
          << attribute("radius", "Scalar", 0, "Float") << attribute("velocity", "Vector", 3, "Float")
          << attribute("spin", "Vector", 3, "Float") << attribute("id", "Scalar", 0, "Int")
          << std::string("        <Attribute Name=\"material\" AttributeType=\"Scalar\" Center=\"Node\">\n          ") +
                item("material", 0, "UChar", 1) + "\n        </Attribute>\n";
      });
}

void write_contacts_xdmf(const std::string& path, const std::string& h5file, const std::vector<XdmfEntry>& entries,
                         std::int64_t vertices) {
  write_document(path, h5file, entries, "_contacts", "contacts",
                 [&](std::ostringstream& x, const XdmfEntry& e, const ItemFn& item) {
                   const std::int64_t m = std::get<3>(e);
                   auto attribute = [&](const char* name, const char* type, int prec) {
                     return std::string("        <Attribute Name=\"") + name +
                         "\" AttributeType=\"Scalar\" Center=\"Cell\">\n          " + item(name, 0, type, prec) +
                         "\n        </Attribute>\n";
                   };
                   // M two-node line cells over 2M points: the ends (x1, x1 + branch) of every contact,
                   // connectivity 0, 1, ..., 2M-1 (the first 2M values of the vertex index).
                   x << "        <Topology TopologyType=\"Polyline\" NumberOfElements=\"" << m
                     << "\" NodesPerElement=\"2\">\n"
                     << vertex_slab(h5file, std::to_string(m) + " 2", 2 * m, vertices) << "        </Topology>\n"
                     << "        <Geometry GeometryType=\"XYZ\">\n          " << item("ends", 6, "Float", 8)
                     << "\n        </Geometry>\n"
                     << attribute("fn", "Float", 8) << attribute("ft_norm", "Float", 8)
                     << attribute("mr_norm", "Float", 8) << attribute("sliding", "UChar", 1)
                     << attribute("rolling", "UChar", 1) << attribute("strong", "UChar", 1)
                     << attribute("id1", "Int", 8) << attribute("id2", "Int", 8);
                 });
}

void write_cell_xdmf(const std::string& path, const std::vector<CellXdmfEntry>& entries) {
  std::vector<XdmfEntry> rows;
  std::map<std::pair<std::string, std::int64_t>, std::array<double, 9>> cells;
  for (const CellXdmfEntry& c : entries) {
    rows.emplace_back(c.case_name, c.step, c.time, 8);
    cells[{c.case_name, c.step}] = c.h;
  }
  write_document(path, "", rows, "_cell", "", [&](std::ostringstream& x, const XdmfEntry& e, const ItemFn&) {
    const std::array<double, 9>& h = cells.at({std::get<0>(e), std::get<1>(e)});
    x << "        <Topology TopologyType=\"Polyline\" NumberOfElements=\"12\" NodesPerElement=\"2\">\n"
      << "          <DataItem Dimensions=\"12 2\" NumberType=\"Int\" Precision=\"4\" Format=\"XML\">"
      << "0 1 2 3 4 5 6 7 0 2 1 3 4 6 5 7 0 4 1 5 2 6 3 7</DataItem>\n"
      << "        </Topology>\n"
      << "        <Geometry GeometryType=\"XYZ\">\n"
      << "          <DataItem Dimensions=\"8 3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">";
    for (int k = 0; k < 8; ++k) {
      const double s0 = k & 1, s1 = (k >> 1) & 1, s2 = (k >> 2) & 1;
      for (int r = 0; r < 3; ++r) x << (k || r ? " " : "") << s0 * h[3 * r] + s1 * h[3 * r + 1] + s2 * h[3 * r + 2];
    }
    x << "</DataItem>\n"
      << "        </Geometry>\n"
      << "        <Attribute Name=\"edge\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
      << "          <DataItem Dimensions=\"12\" NumberType=\"Int\" Precision=\"4\" Format=\"XML\">"
      << "1 1 1 1 2 2 2 2 3 3 3 3</DataItem>\n"
      << "        </Attribute>\n";
  });
}

void write_fields_xdmf(const std::string& path, const std::string& h5file,
                       const std::vector<FieldsXdmfEntry>& entries) {
  std::ostringstream x;
  x.precision(17);
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
       "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n  <Domain>\n";
  std::vector<std::string> cases;
  for (const auto& e : entries)
    if (std::find(cases.begin(), cases.end(), e.case_name) == cases.end()) cases.push_back(e.case_name);
  for (const std::string& c : cases) {
    x << "    <Grid Name=\"" << xml_escape(c + "_fields")
      << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (const FieldsXdmfEntry& e : entries) {
      if (e.case_name != c) continue;
      // XDMF orders the axes slowest first: z, y, x (the datasets are (nz, ny, nx[, c])).
      const std::string dims =
          std::to_string(e.cells[2]) + " " + std::to_string(e.cells[1]) + " " + std::to_string(e.cells[0]);
      x << "      <Grid Name=\"" << xml_escape(c + "_fields_" + layout::step_name(e.step))
        << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << e.time << "\"/>\n";
      if (e.explicit_nodes)
        x << "        <Topology TopologyType=\"3DSMesh\" Dimensions=\"" << dims << "\"/>\n"
          << "        <Geometry GeometryType=\"XYZ\">\n"
          << "          <DataItem Dimensions=\"" << dims << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">"
          << xml_escape(h5file + ":" + e.group + "/" + kNodePosition) << "</DataItem>\n"
          << "        </Geometry>\n";
      else
        x << "        <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" << dims << "\"/>\n"
          << "        <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
          << "          <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << e.origin[2]
          << " " << e.origin[1] << " " << e.origin[0] << "</DataItem>\n"
          << "          <DataItem Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" << e.spacing[2]
          << " " << e.spacing[1] << " " << e.spacing[0] << "</DataItem>\n"
          << "        </Geometry>\n";
      for (const auto& [name, comps] : e.quantities) {
        const char* kind = comps == 1 ? "Scalar" : comps == 3 ? "Vector" : "Tensor";
        x << "        <Attribute Name=\"" << xml_escape(name) << "\" AttributeType=\"" << kind
          << "\" Center=\"Node\">\n"
          << "          <DataItem Dimensions=\"" << dims << (comps > 1 ? " " + std::to_string(comps) : std::string())
          << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">"
          << xml_escape(h5file + ":" + e.group + "/" + name) << "</DataItem>\n"
          << "        </Attribute>\n";
      }
      x << "      </Grid>\n";
    }
    x << "    </Grid>\n";
  }
  x << "  </Domain>\n</Xdmf>\n";
  write_file_atomic(path, x.str(), "xdmf");
}

}  // namespace fabrica
