// The periodic cell, which deforms homogeneously.
//
// Orthorhombic (the default): the box [0, L1) x [0, L2) x [0, L3), each axis i with a strain
// rate edot_i = (dL_i/dt) / L_i (extension positive). Particles follow the affine field
// x_i <- x_i * L_i(t+dt) / L_i(t) plus their own (fluctuating) motion, so the velocity of
// particle b relative to particle a includes edot (.) (x_b - x_a).
//
// Sheared: a parallelepiped whose edge vectors are the columns of the matrix H, the points
// x = H s with fractional coordinates s in [0, 1)^3, deformed by a full velocity gradient G
// (v_affine = G x): H <- F H and x <- F x over a step, F = exp(G dt). The relative velocity of
// b and a includes G (x_b - x_a). Particle velocities are fluctuations about the affine field,
// so nothing is remapped when a particle crosses a face. A cell becomes sheared when it is made
// from a matrix with an off-diagonal term or given a velocity gradient with one, and stays so;
// an orthorhombic cell takes the orthorhombic code paths, which are those of every scene
// before sheared cells, bit for bit.
//
// Large shear: a tilt that grows past kFlipRatio of an edge is taken back by replacing an edge
// vector with its sum with an integer multiple of another (reduce(), as LAMMPS' `flip`): the
// lattice of periodic images is unchanged, so the specimen and its trajectory are continuous;
// only the edges that describe the lattice change, and positions are wrapped anew.
#pragma once
#include "core/types.hpp"

#include <cmath>

namespace fabrica {

// The deformation of the cell over one step (PeriodicCell::deform): positions x <- F x, with,
// for an orthorhombic cell, F the diagonal 'scale'.
struct CellStep {
  bool sheared = false;
  Vec3 scale = Vec3::Ones();  // orthorhombic: the factors L(t+dt) / L(t)
  Mat3 F = Mat3::Identity();  // sheared: exp(G dt)
  Vec3 apply(const Vec3& x) const { return sheared ? Vec3(F * x) : Vec3(x.cwiseProduct(scale)); }
};

class PeriodicCell {
 public:
  // A ratio of a tilt to the edge it leans along, past which reduce() flips the cell (above
  // one half, so that a tilt on the half, as in an amplitude of cyclic shear, does not flip
  // back and forth; the heights stay above 1 / sqrt(1 + 0.6^2) = 0.86 of the edges).
  static constexpr real_t kFlipRatio = 0.6;

  PeriodicCell() = default;
  explicit PeriodicCell(const Vec3& lengths) : L_(lengths) {}
  // The parallelepiped of edge vectors the columns of h: orthorhombic if h is diagonal.
  static PeriodicCell from_matrix(const Mat3& h);

  bool sheared() const { return sheared_; }

  // Orthorhombic: the edge lengths. Sheared: the diagonal of H (not the edges' lengths; use
  // matrix(), heights() and volume()).
  const Vec3& lengths() const { return L_; }
  // The edge vectors as columns (orthorhombic: diag(L)).
  Mat3 matrix() const { return sheared_ ? H_ : Mat3(L_.asDiagonal()); }
  // The distances between opposite faces (orthorhombic: the lengths): the widths a neighbour
  // grid or a subdomain can be cut into.
  Vec3 heights() const;
  real_t volume() const { return sheared_ ? H_.determinant() : L_.prod(); }

  // Orthorhombic strain rates (extension positive); for a sheared cell the diagonal of G.
  const Vec3& strain_rate() const { return edot_; }
  void set_strain_rate(const Vec3& edot) {
    edot_ = edot;
    if (sheared_) G_.diagonal() = edot;
  }
  // The full velocity gradient (orthorhombic: diag(edot)).
  Mat3 velocity_gradient() const { return sheared_ ? G_ : Mat3(edot_.asDiagonal()); }
  // Sets G; an off-diagonal term makes the cell sheared.
  void set_velocity_gradient(const Mat3& g);
  // Whether the cell deforms at all (a zero velocity gradient skips the affine arithmetic).
  bool deforming() const { return sheared_ ? !G_.isZero() : !edot_.isZero(); }

  // The integral of the rate of deformation D = (G + G^T) / 2 over time since the cell became
  // sheared (the diagonal the logarithmic extensions, twice an off-diagonal term an engineering
  // shear strain); zero for an orthorhombic cell, whose strains follow from its lengths.
  const Mat3& strain() const { return strain_; }

  // Advances the cell by dt at the current rates: orthorhombic, an exact exponential update
  // per axis (so that the logarithmic strain ln(L0/L) is integrated without error); sheared,
  // H <- exp(G dt) H. Returns the map positions must follow.
  CellStep deform(real_t dt);

  // Minimum-image vector for a raw difference d = x_b - x_a (exact for |d| below half the
  // smallest height, which the neighbour search requires of every pair it keeps).
  Vec3 minimum_image(Vec3 d) const;
  // Maps a position into the cell ([0, L) per axis; sheared: fractional coordinates in [0, 1)).
  Vec3 wrap(Vec3 x) const;
  // Fractional coordinates s = H^-1 x (orthorhombic: x / L per axis).
  Vec3 fractional(const Vec3& x) const { return sheared_ ? Vec3(Hinv_ * x) : Vec3(x.cwiseQuotient(L_)); }
  // The point of fractional coordinates s (orthorhombic: s * L per axis).
  Vec3 cartesian(const Vec3& s) const { return sheared_ ? Vec3(H_ * s) : Vec3(s.cwiseProduct(L_)); }
  // The shift H n of the periodic image n (orthorhombic: n * L per axis, the same bits as
  // before sheared cells).
  Vec3 image_shift(int n0, int n1, int n2) const {
    if (!sheared_) return Vec3(n0 * L_[0], n1 * L_[1], n2 * L_[2]);
    return Vec3(H_.col(0) * real_t(n0) + H_.col(1) * real_t(n1) + H_.col(2) * real_t(n2));
  }

  // Sheared: if an edge leans along another by more than kFlipRatio of it, replaces the edge
  // with its sum with the integer multiple of the other that makes it most upright, until none
  // does; returns whether the edges changed (then positions must be wrapped anew and the
  // neighbour list and the decomposition remade). Orthorhombic: false.
  bool reduce();

  // The raw state, for checkpoints: H, G and the strain integral (orthorhombic: diag(L),
  // diag(edot) and zero).
  void restore_sheared(const Mat3& h, const Mat3& g, const Mat3& strain);

 private:
  void set_matrix(const Mat3& h);

  Vec3 L_ = Vec3::Ones();
  Vec3 edot_ = Vec3::Zero();
  bool sheared_ = false;
  Mat3 H_ = Mat3::Identity();
  Mat3 Hinv_ = Mat3::Identity();
  Mat3 G_ = Mat3::Zero();
  Mat3 strain_ = Mat3::Zero();
};

}  // namespace fabrica
