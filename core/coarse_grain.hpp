// Coarse-grained continuum fields on a regular grid of the periodic cell (docs/fields.md):
// solid fraction, density, mean velocity, kinetic stress, contact stress in the Goldhirsch form,
// mean spin, and per contact sub-network of the fabric analysis (core/fabric.hpp) its contact
// density and fabric tensor; and, between two instants, the displacement gradient and the
// strain increment from the particles' displacements.
//
// Grid: n[a] nodes along axis a at (i + 1/2) h_a, h_a = L_a / n[a], over the cell [0, L) (a
// sheared cell: the same in its fractional coordinates, FieldGrid::set_matrix). Each
// point quantity (a particle's centre, a contact point, a quadrature point of a contact's
// branch) is spread over the nodes within the kernel's support, periodic images included, with
// weights W(|X_g - x|) normalised over those nodes: sum_g W_g dV = 1 exactly up to rounding, so
// that the volume integral sum_g field(g) dV of every density equals the sum of what was spread
// (the solid volume, the Love-Weber sum f (x) b), whatever the grid and the kernel.
//
// Collective through a Domain (core/domain.hpp): every rank passes its own particles and
// contacts (each once over all ranks) and the sums are exact (fixed-point integers, see GridSums
// in coarse_grain.cpp), so that every field is the same, bit for bit, on any number of ranks and
// for any split of the items over them. Without a GridExchange (or on one rank) every rank fills
// the whole grid and the grids are summed over the ranks; with one (core/grid_exchange.hpp) each
// rank fills only the box of nodes its items reach, sends those integers to the owners of the
// z-layers (core/grid_share.hpp) and gets the fields of its own layers (FieldsResult::layers).
#pragma once
#include "core/contact_snapshot.hpp"
#include "core/domain.hpp"
#include "core/fabric.hpp"
#include "core/grid_exchange.hpp"

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace fabrica {

enum class KernelType { Gaussian, Lucy };

struct FieldKernel {
  KernelType type = KernelType::Gaussian;
  // Gaussian: the standard deviation w, W ~ exp(-r^2 / (2 w^2)) for r < cutoff w.
  // Lucy: the support radius c, W ~ (1 + 3 r/c)(1 - r/c)^3 for r < c (cutoff unused).
  real_t width = 0;   // m
  real_t cutoff = 3;  // Gaussian: support radius in widths
  real_t support() const { return type == KernelType::Gaussian ? cutoff * width : width; }
  real_t raw(real_t r) const;  // the unnormalised kernel at distance r (0 beyond the support)
};

struct FieldGrid {
  std::array<int, 3> n{1, 1, 1};
  Vec3 lengths = Vec3::Ones();  // the cell's lengths at the instant, m (sheared: the diagonal of H)
  // A sheared cell (docs/fields.md "A sheared cell"): the grid is cut in fractional coordinates,
  // node (i, j, k) at H ((i + 1/2) / n0, (j + 1/2) / n1, (k + 1/2) / n2), periodic images H m.
  // Orthorhombic (sheared false, H unused): the nodes at (i + 1/2) h_a, the same bits as always.
  bool sheared = false;
  Mat3 H = Mat3::Identity(), Hinv = Mat3::Identity();
  // The cell of edge vectors the columns of h: sheared if h has an off-diagonal term, else the
  // orthorhombic cell of lengths diag(h).
  void set_matrix(const Mat3& h);
  Mat3 matrix() const { return sheared ? H : Mat3(lengths.asDiagonal()); }
  // Orthorhombic: L_a / n_a. Sheared: the distance between neighbouring nodes along each edge.
  Vec3 spacing() const;
  std::size_t nodes() const { return std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]); }
  // Node (i, j, k) is number i + n0 (j + n1 k): x fastest.
  Vec3 node(int i, int j, int k) const;
  real_t cell_volume() const {
    return sheared ? std::abs(H.determinant()) / real_t(nodes()) : lengths.prod() / real_t(nodes());
  }
  // A position mapped into the cell ([0, L) per axis; sheared: fractional coordinates in [0, 1)).
  Vec3 wrap(const Vec3& x) const;
  // The fractional coordinate of x along axis 2 in [0, 1): which z-layer it lies in.
  double layer_coordinate(const Vec3& x) const;
  // Sheared: x's position in node units along each axis, H^-1 x (.) n (node i at i + 1/2).
  Vec3 index_coordinate(const Vec3& x) const;
  // Sheared: the reach in node index along each axis of a ball of radius r (r |row a of H^-1| n_a).
  Vec3 index_reach(real_t r) const;
  // Half the longest diagonal of a grid cell (a parallelepiped when sheared): every point is
  // within it of a node.
  real_t half_diagonal() const;
};

// The positions of the nodes of the z-layers [layers.first, layers.end) of 'grid', 3 values a
// node, node i + n0 (j + n1 (k - layers.first)) (a sheared grid's geometry for its XDMF, which
// places its nodes explicitly: docs/fields.md "A sheared cell").
std::vector<double> node_positions(const FieldGrid& grid, Layers layers);

// Why a grid and kernel cannot be used (empty: they can): the kernel's support does not reach
// the nearest node from every point (support below the half-diagonal of a grid cell), a kernel
// width below 'min_radius' (the smallest sphere radius: the field would resolve the inside of
// a sphere), fewer than 1 node along an axis, or a bad cut-off.
std::string check_field_grid(const FieldGrid& grid, const FieldKernel& kernel, real_t min_radius);

// Whether 'name' is a field coarse_grain() computes (solid_fraction, ..., contact_density_<k>,
// fabric_<k> for a network k of kNetworkNames), "networks" (every network's two fields), or one
// of displacement_fields() (displacement, displacement_gradient, strain_increment).
bool field_quantity_known(const std::string& name);

// Bytes of the largest rank's memory for the fields of 'grid' (the fixed-point sums and the
// result) on 'ranks' ranks: the whole grid on one rank; on several, the box of sums of a slab of
// z-layers and the kernel's reach on either side (the whole xy-plane: items dealt by slabs, as
// `fabrica fields` deals them; a run's subdomains give boxes of about the same volume), the slab's
// sums and fields, and 8 bytes a node of the whole grid (the localisation index's gather).
double field_bytes(const FieldGrid& grid, const FieldKernel& kernel = {}, int ranks = 1);

struct CgParticle {
  Vec3 x = Vec3::Zero();  // m (any image: wrapped by the grid)
  Vec3 v = Vec3::Zero();  // m/s
  Vec3 w = Vec3::Zero();  // rad/s
  real_t radius = 0;      // m
  real_t mass = 0;        // kg
};

// A particle-particle contact for the fields: its record (fn, ft, normal, branch, overlap,
// flags) and the centre and radius of body 1.
struct CgContact {
  ContactRecord rec;
  Vec3 x1 = Vec3::Zero();  // m
  real_t r1 = 0;           // m
};

struct FieldOptions {
  real_t strong_ratio = 1.0;  // strong: f_n > strong_ratio x (global mean f_n), as the fabric analysis
  bool networks = true;       // the per-network contact density and fabric tensor
};

// One field per quantity, node-major (node i + n0 (j + n1 k)), 'components' values a node; a
// tensor is 9 values a node in row-major order.
struct Field {
  std::string name;
  std::string unit;
  int components = 1;
  std::vector<double> values;
};

struct FieldsResult {
  FieldGrid grid;
  FieldKernel kernel;
  // The fields hold the z-layers [layers.first, layers.end) of the grid (all of them unless the
  // grid was shared over the ranks): node i + n0 (j + n1 (k - layers.first)).
  std::vector<Field> fields;
  Layers layers;
  std::size_t sum_nodes = 0;                          // the nodes of this rank's fixed-point sums (its box)
  std::int64_t particles = 0, contacts = 0;           // over all ranks
  real_t strong_threshold = 0;                        // N
  const Field& field(const std::string& name) const;  // throws std::out_of_range if absent
};

// The fields of one instant. 'contacts' must be particle-particle contacts (id2 >= 0), each
// listed once over all ranks, with the particles they join listed once over all ranks too.
// Fields (docs/fields.md): solid_fraction [1], density [kg/m^3], velocity [m/s] (mass-weighted
// mean), kinetic_stress [Pa] (sum m v' (x) v' W, v' = v - velocity, compression positive as the
// Love-Weber stress), contact_stress [Pa] (sum f (x) b times the integral of W along the branch),
// stress [Pa] (contact + kinetic), spin [rad/s] (mass-weighted mean); per network k (with
// options.networks) contact_density_<k> [1/m^3] and fabric_<k> [1] (sum n n W / sum W). A mean
// is NaN where its weight is zero. 'recycle' (optional): a previous result whose fields' storage
// is reused (a field of the same name), so that fields computed at every instant do not map
// fresh memory each time; its fields are left empty. 'exchange' (optional): the grid shared
// over its ranks (above), the result holding this rank's slab of z-layers only.
FieldsResult coarse_grain(const FieldGrid& grid, const FieldKernel& kernel, std::span<const CgParticle> particles,
                          std::span<const CgContact> contacts, const FieldOptions& options, Domain& reducer,
                          FieldsResult* recycle = nullptr, GridExchange* exchange = nullptr);

// One particle at two instants for the displacement fields.
struct CgMotion {
  Vec3 x0 = Vec3::Zero(), x1 = Vec3::Zero();  // m, positions at t0 and t1 (each in its cell, any image)
  real_t radius = 0;                          // m
};

// The displacement gradient between two instants of a cell of lengths L0 -> L1 (orthorhombic,
// homogeneously deformed), on 'grid' (grid.lengths = L0: the reference configuration); of a
// sheared cell H0 -> H1 (grid.H = H0, H1 any matrix): u = H1' (s0 + ds) - x0 with s0 = H0^-1 x0,
// ds the nearest-image s1 - s0 in the fractional coordinates of H1' = deformed_reference_edges(),
// an image shifted by H0 m moving by u + (H1' - H0) m; a flip between the instants is undone, so
// that G is F - I for a homogeneous deformation F. Each
// particle's displacement is u = L1 (.) (s0 + ds) - x0, with s0 = x0 / L0 and ds the scaled
// displacement s1 - s0 taken to the nearest image (fluctuating displacements below half the cell
// between the instants); a periodic image of the particle shifted by k (.) L0 moves by
// u + k (.) (L1 - L0). At each node, the displacement gradient is the kernel-weighted
// (volume-weighted) least-squares fit of u against x over the particles the kernel reaches:
//   G = C_ux C_xx^-1,  C_ux = sum W V (u - u_bar) (x) (x - x_bar),  C_xx = sum W V (x - x_bar) (x) (x - x_bar),
// exact (to rounding) for a homogeneous deformation, u = A x. Fields: displacement [m] (the
// weighted mean u_bar), displacement_gradient [1] (G, 9 values, du_i/dx_j in row i),
// strain_increment [1] (sym G, compression negative), and NaN where C_xx is singular (fewer
// than 4 non-coplanar particles in reach). Collective, the same bits for any split of the motions
// over the ranks (each particle once over all of them). 'recycle', 'exchange': as for
// coarse_grain().
FieldsResult displacement_fields(const FieldGrid& grid, const FieldKernel& kernel, const Mat3& H1,
                                 std::span<const CgMotion> motions, Domain& reducer, FieldsResult* recycle = nullptr,
                                 GridExchange* exchange = nullptr);
inline FieldsResult displacement_fields(const FieldGrid& grid, const FieldKernel& kernel, const Vec3& L1,
                                        std::span<const CgMotion> motions, Domain& reducer,
                                        FieldsResult* recycle = nullptr, GridExchange* exchange = nullptr) {
  return displacement_fields(grid, kernel, Mat3(L1.asDiagonal()), motions, reducer, recycle, exchange);
}

// A sheared cell's displacements (docs/fields.md "A sheared cell"): the edges H1 of the later
// instant as the deformed edges of the reference H0, F H0, undoing a flip (reduce(), core/cell.hpp)
// between the instants: H1 = F H0 M with M an integer unimodular matrix, recovered as
// round(H0^-1 H1) while the deformation is small: each entry of H0^-1 H1 within kFlipTolerance
// of an integer (a deformation of less than a quarter of the edges in fractional terms), else
// throws std::domain_error. Returns H1 M^-1 (H1 itself without a flip).
constexpr double kFlipTolerance = 0.25;
Mat3 deformed_reference_edges(const Mat3& H0, const Mat3& H1);

}  // namespace fabrica
