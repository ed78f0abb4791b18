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
  Mat3 stiffness = Mat3::Zero();  // M, Pa
  Mat3 viscosity = Mat3::Zero();  // C, Pa s
  bool empty() const { return stiffness.isZero() && viscosity.isZero(); }
};
SpecimenResponse specimen_response(Simulation& sim);

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
  // The rates after a measurement of 'stress', 'elapsed' seconds after the previous one, for
  // the specimen's response 'R' (specimen_response). Throws ServoDivergence (see the header).
  Vec3 update(const Mat3& stress, real_t elapsed, const SpecimenResponse& R);
  // Whether update() reads R for this stress: always with "stiffness"; with "gains" only when
  // an error above 5 % has changed sign (the over-correction check), so that fixed gains cost
  // no contact loop otherwise. The same on every rank (reduced stress).
  bool needs_response(const Mat3& stress) const;
  const Vec3& integral() const { return integral_; }  // for checkpoints
  void set_integral(const Vec3& i) { integral_ = i; }
  // At the last update, for messages: the gain of each axis in 1/s (rate per unit relative
  // error), the last stiffness S_k [Pa] and viscosity V_k [Pa s] it saw (with "gains": 0
  // until it first needed them).
  const Vec3& gain() const { return gain_; }
  const Vec3& stiffness() const { return stiffness_; }
  const Vec3& viscosity() const { return viscosity_; }
  // "gain (g1, g2, g3) 1/s, stiffness (S1, S2, S3) Pa[, viscosity (V1, V2, V3) Pa s]"
  std::string describe() const;

 private:
  ServoMode mode_;
  Vec3 target_;
  real_t kp_, ki_, cap_, relax_, irelax_, interval_;
  std::array<bool, 3> axes_;
  Vec3 fixed_;
  Vec3 integral_ = Vec3::Zero();
  Vec3 gain_ = Vec3::Zero(), stiffness_ = Vec3::Zero(), viscosity_ = Vec3::Zero();
  Vec3 last_error_ = Vec3::Zero();  // gains mode: the over-correction check (not checkpointed:
  std::array<int, 3> flips_{};      // a restart counts its 20 updates afresh)
};

}  // namespace fabrica
