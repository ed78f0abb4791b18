// The stress servo of the periodic cell: per axis, a strain rate that brings the axis' stress
// sigma_kk (compression positive) to a target. Two ways to set its gain ([triaxial] servo):
//
//  "stiffness" (the default): the gain follows the specimen. At every update the specimen's
//    response to the servo's own strain rates (specimen_response()): its stiffness
//    S_k = sum_{l servo-controlled} M_kl and its viscosity V_k = sum_l C_kl, with
//      M_kl = (1/V) sum_c |d|^2 n_k n_l [(k_n - k_s) n_k n_l + k_s delta_kl]   (Pa)
//      C_kl = (1/V) sum_c |d|^2 n_k n_l [(c_n - c_s) n_k n_l + c_s delta_kl]   (Pa s)
//    (the affine, sticking response d sigma_kk / d eps_l of the touching contacts, and the same
//    for their dashpots, d sigma_kk / d edot_l: branch d, normal n, stiffnesses k_n, k_s,
//    dashpot coefficients c_n, c_s). A rate edot held over one servo interval T moves the
//    stress by (S_k T + V_k) edot: the elastic part as the cell strains, the viscous part at
//    once (the dashpots see the affine relative velocity). The servo sets the rate that would
//    correct the fraction 'relaxation' of the stress error within one interval:
//      edot_k = target (relaxation e_k + integral_relaxation I_k) / (S_k T + V_k),
//    e_k = (sigma_kk - target) / target, I_k the sum of the past errors (anti-windup: not
//    summed while the rate is capped). The affine response bounds the specimen's true one
//    from above, so the correction per interval never exceeds 'relaxation' of the error
//    whatever E, k_n, the damping or N: the loop converges for any stiffness and size (as
//    PFC's servo, which derives its gain from the contact stiffness and the number of
//    contacts). Without V_k, strong dashpots (108,672 spheres of the benchmark scene, whose
//    damping rate 7593 1/s makes V_k about 20 S_k T) turned every correction into a viscous
//    stress jump 10 times the error, and the rate alternated between the caps for ever.
//  "gains": edot_k = gain e_k + integral_gain int e_k dt, fixed by the scene. When its loop gain
//    gain (S_k T + V_k) / target exceeds 2 and the error (above 5 %) has alternated in sign at
//    20 updates in a row, the servo over-corrects and can never settle: the stage stops with
//    what it saw (ServoDivergence: axis, error, gain, stiffness, loop gain, the largest stable
//    gain).
//
// Both cap |edot_k| at max_strain_rate (extension positive: a specimen above the target
// expands); axes not under control keep their fixed rate.
//
// Shear components (12, 13, 23; set_shear): the same law on the symmetric shear stress s_ij and
// the engineering shear rate gamma_dot_ij = 2 D_ij, with the shear stiffness S_c = d s_ij /
// d gamma_ij of the touching contacts (core/specimen_response.hpp, add_shear_response) and its
// viscosity. A shear target may be zero or negative, so its error is relative to a scale of the
// stage's stresses ('scale', Pa; the mean normal target, or p) instead of the target itself:
// e = (s_ij - target) / scale, gamma_dot = scale (relaxation e + ...) / (S T + V). The sign is
// that of the normal axes: a shear stress above its target (compression positive: a positive
// gamma resists with a negative s_ij) is brought down by a positive gamma_dot.
#pragma once
#include "core/simulation.hpp"
#include "io/serial/scene.hpp"

#include <array>
#include <stdexcept>
#include <string>

namespace fabrica {

// M_kl and C_kl of the header, over every rank's touching particle-particle contacts
// (collective: one sum of 18 numbers). Zero without contacts; C is zero without dashpots.
struct SpecimenResponse {
  Mat3 stiffness = Mat3::Zero();        // M, Pa
  Mat3 viscosity = Mat3::Zero();        // C, Pa s
  Vec3 shear_stiffness = Vec3::Zero();  // S_c of the shear components 12, 13, 23, Pa (with 'shear')
  Vec3 shear_viscosity = Vec3::Zero();  // their viscosity, Pa s
  bool empty() const { return stiffness.isZero() && viscosity.isZero(); }
};
// With 'shear' also the shear components' (one collective sum of 24 numbers instead of 18).
SpecimenResponse specimen_response(Simulation& sim, bool shear = false);

// The servo cannot converge (gains mode, loop gain above 2): the message says what it saw.
class ServoDivergence : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Servo {
 public:
  // 'interval' is the time between two updates [s] (servo_interval steps); 'target' the stress
  // of each servo-controlled axis [Pa] (compression positive, > 0).
  Servo(const ServoSettings& s, real_t interval, std::array<bool, 3> axes, Vec3 fixed, Vec3 target);
  // A target that moves with the path (constant p, true triaxial): set before update().
  void set_target(int k, real_t target) { target_[k] = target; }
  const Vec3& target() const { return target_; }
  // The shear components under control ('axes'), the engineering rates of the others ('fixed')
  // and the targets s_ij of the controlled ones (Pa, either sign); before the first update.
  void set_shear(std::array<bool, 3> axes, Vec3 fixed, Vec3 target);
  void set_shear_target(int c, real_t target) { shear_target_[c] = target; }
  const Vec3& shear_target() const { return shear_target_; }
  // The scale of the shear errors (Pa, > 0): set before update_shear().
  void set_shear_scale(real_t scale) { shear_scale_ = scale; }
  real_t shear_scale() const { return shear_scale_; }
  const std::array<bool, 3>& shear_axes() const { return shear_axes_; }
  bool any_shear_axis() const { return shear_axes_[0] || shear_axes_[1] || shear_axes_[2]; }
  // The rates after a measurement of 'stress', 'elapsed' seconds after the previous one, for
  // the specimen's response 'R' (specimen_response). Throws ServoDivergence (see the header).
  Vec3 update(const Mat3& stress, real_t elapsed, const SpecimenResponse& R);
  // The engineering shear rates of 12, 13, 23 after the same measurement (R with its shear
  // response); the fixed rates of the components not under control.
  Vec3 update_shear(const Mat3& stress, real_t elapsed, const SpecimenResponse& R);
  // Whether update() reads R for this stress: always with "stiffness"; with "gains" only when
  // an error above 5 % has changed sign (the over-correction check), so that fixed gains cost
  // no contact loop otherwise. The same on every rank (reduced stress).
  bool needs_response(const Mat3& stress) const;
  const Vec3& integral() const { return normal_.integral; }  // for checkpoints
  void set_integral(const Vec3& i) { normal_.integral = i; }
  const Vec3& shear_integral() const { return shear_.integral; }
  void set_shear_integral(const Vec3& i) { shear_.integral = i; }
  // At the last update, for messages: the gain of each axis in 1/s (rate per unit relative
  // error), the last stiffness S_k [Pa] and viscosity V_k [Pa s] it saw (with "gains": 0
  // until it first needed them).
  const Vec3& gain() const { return normal_.gain; }
  const Vec3& stiffness() const { return normal_.stiffness; }
  const Vec3& viscosity() const { return normal_.viscosity; }
  // "gain (g1, g2, g3) 1/s, stiffness (S1, S2, S3) Pa[, viscosity (V1, V2, V3) Pa s]"; with
  // shear components under control, then "; shear gain (..) 1/s, stiffness (..) Pa".
  std::string describe() const;

 private:
  // The state of one component at a slot of the three-vectors below.
  struct Slots {
    Vec3 integral = Vec3::Zero();
    Vec3 gain = Vec3::Zero(), stiffness = Vec3::Zero(), viscosity = Vec3::Zero();
    Vec3 last_error = Vec3::Zero();  // gains mode: the over-correction check (not checkpointed:
    std::array<int, 3> flips{};      // a restart counts its 20 updates afresh)
  };
  // The rate of slot k of 's' for the measured 'value' against 'target', its error relative to
  // 'scale', with the stiffness S and viscosity C it moves against; 'what' names it in messages
  // ("axis 1", "shear 12"). Throws ServoDivergence.
  real_t rate(Slots& s, int k, real_t value, real_t target, real_t scale, real_t S, real_t C, real_t elapsed, bool seen,
              const std::string& what);
  ServoMode mode_;
  Vec3 target_;
  real_t kp_, ki_, cap_, relax_, irelax_, interval_;
  std::array<bool, 3> axes_;
  Vec3 fixed_;
  Slots normal_;
  std::array<bool, 3> shear_axes_{};
  Vec3 shear_fixed_ = Vec3::Zero(), shear_target_ = Vec3::Zero();
  real_t shear_scale_ = 1;
  Slots shear_;
};

}  // namespace fabrica
