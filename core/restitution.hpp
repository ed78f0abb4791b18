// Coefficient of restitution of Fabrica's linear normal spring-dashpot with the no-tension
// clamp f_n = max(0, k_n u_n - c_n du_n/dt), c_n = 2 beta sqrt(m_eff k_n), and its inverse,
// so that a scene can give the restitution e a user measures (LIGGGHTS, PFC) instead of beta.
//
// The clamp ends the contact force when k u + c u' = 0, i.e. when the acceleration of the
// damped oscillator u = A exp(-beta w t) sin(w_d t) vanishes, before the overlap closes; the
// rebound speed is the speed then (the force stays zero afterwards). With s = beta w_0,
// w_d = w_0 sqrt(1 - beta^2) and theta = w_d t* = atan2(2 s w_d, s^2 - w_d^2):
//   e(beta) = -exp(-s t*) (cos theta - (s / w_d) sin theta)          (beta < 1)
// and the same with cosh, sinh, w' = w_0 sqrt(beta^2 - 1), theta = atanh(2 s w' / (s^2 + w'^2))
// when beta > 1 (e(1) = exp(-2)). e decreases monotonically from 1 (beta = 0) to 0 (beta ->
// infinity) and does not depend on k_n or m_eff (Schwager & Poeschel 2007, Phys. Rev. E 75,
// 051304). The textbook beta(e) = -ln e / sqrt(pi^2 + ln^2 e), which assumes the contact lasts
// until the overlap closes, gives e = 0.32 / 0.55 / 0.81 for 0.2 / 0.5 / 0.8 with the clamp.
//
// The shear spring is not clamped: a stuck contact's tangential oscillation is the free damped
// oscillator, whose half-period restitution is the textbook one (shear_damping_ratio_for_restitution).
#pragma once
#include "core/types.hpp"

namespace fabrica {

// e of the clamped normal dashpot at damping ratio beta >= 0.
real_t clamped_restitution(real_t beta);

// The damping ratio beta >= 0 with clamped_restitution(beta) = e, for 0 < e <= 1 (to a relative
// 1e-14 in e, by bisection; e = 1 gives 0).
real_t damping_ratio_for_restitution(real_t e);

// beta = -ln e / sqrt(pi^2 + ln^2 e): the unclamped oscillator (the shear spring-dashpot).
real_t shear_damping_ratio_for_restitution(real_t e);

}  // namespace fabrica

namespace fabrica {

// The damped Hertz impact of Hertz-Mindlin (core/contact/hertz_mindlin.hpp) with the no-tension
// clamp, f = max(0, K u^{3/2} + c(u) u'), c = 2 sqrt(5/6) beta sqrt(m* 3/2 K u^{1/2}). With
// u = X xi, t = T tau, T = sqrt(m* / K) X^{-1/4} and X chosen so that the approach speed is 1,
//   xi'' = -xi^{3/2} - sqrt(5) beta xi^{1/4} xi',  xi(0) = 0, xi'(0) = 1,
// so e depends on beta only (Tsuji et al. 1992), as for the linear dashpot. e is the rebound
// speed where the force first vanishes (the clamp), integrated with classical Runge-Kutta at
// d tau = 2e-5 and the vanishing point interpolated (restitution.cpp): to about 1e-9.
real_t hertz_clamped_restitution(real_t beta);
// The inverse, for 0 < e <= 1 (bisection to 1e-10 in beta).
real_t hertz_damping_for_restitution(real_t e);

}  // namespace fabrica
