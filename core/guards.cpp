#include "core/guards.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <span>

namespace fabrica {

void StepGuards::check_motion(real_t max_v2, real_t max_ratio, bool displacement_finite, const Particles& p,
                              Domain& domain, std::int64_t step, real_t dt) {
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  if (rmin_ == 0) {  // once: the smallest radius over every rank
    real_t r = inf;
    for (std::size_t a = 0; a < p.n_owned(); ++a) r = std::min(r, p.radius[a]);
    rmin_ = -domain.max_all(-r);
  }
  const real_t bound = 0.5 * rmin_ / dt;                      // half the smallest radius in one step
  if (max_ratio > 0) overlap_guard(max_ratio, domain, step);  // the earlier event (the previous force computation)
  else if (!displacement_finite || !(max_v2 <= bound * bound)) speed_guard(max_v2, bound, p, domain, step, dt);
}

void StepGuards::speed_guard(real_t max_v2, real_t bound, const Particles& p, Domain& domain, std::int64_t step,
                             real_t dt) {
  // Only when the guard trips: the particle (the highest id among equals) and its velocity,
  // from a second reduction; non-holders send -inf.
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  double w[4] = {-inf, -inf, -inf, -inf};
  for (std::size_t a = 0; a < p.n_owned(); ++a) {
    const real_t v2 = p.v[a].squaredNorm();
    const bool bad = !std::isfinite(v2) || !p.x[a].allFinite() || (v2 >= max_v2 && std::isfinite(max_v2));
    if (bad && double(p.id[a]) > w[0]) w[0] = double(p.id[a]), w[1] = p.v[a][0], w[2] = p.v[a][1], w[3] = p.v[a][2];
  }
  domain.max_all(std::span<double>(w, 4));
  char b[400];
  if (!std::isfinite(max_v2))
    std::snprintf(b, sizeof b,
                  "numerical blow-up at step %lld: particle %.0f has a non-finite position "
                  "or velocity (velocity (%.6g, %.6g, %.6g) m/s)",
                  (long long)(step + 1), w[0], w[1], w[2], w[3]);
  else
    std::snprintf(b, sizeof b,
                  "numerical blow-up at step %lld: particle %.0f moves at %.6g m/s, more than "
                  "half the smallest radius (%.6g m) per time step (%.6g s), %.6g m/s: an overlap can "
                  "jump past any bound in one step (velocity (%.6g, %.6g, %.6g) m/s)",
                  (long long)(step + 1), w[0], std::sqrt(max_v2), rmin_, dt, bound, w[1], w[2], w[3]);
  message_ = b;
}

void StepGuards::overlap_guard(real_t max_ratio, Domain& domain, std::int64_t step) {
  // Only when the guard trips: the contact from a second reduction (the highest ids among
  // equal ratios); non-holders send -inf.
  constexpr real_t inf = std::numeric_limits<real_t>::infinity();
  const bool mine = overlap_.ratio == max_ratio;
  double w[4] = {mine ? double(overlap_.a) : -inf, mine ? double(overlap_.b) : -inf, mine ? overlap_.overlap : -inf,
                 mine ? overlap_.radius : -inf};
  domain.max_all(std::span<double>(w, 4));
  char b[400];
  const bool wall = w[1] < 0;
  std::snprintf(b, sizeof b,
                "numerical blow-up at step %lld: overlap of particle%s %.0f and %s%.0f is %.6g of "
                "the smaller radius (%.6g m, radius %.6g m), beyond the geometric limit %.6g (a "
                "centre inside the other body)",
                (long long)step, wall ? "" : "s", w[0], wall ? "wall " : "", wall ? -1 - w[1] : w[1], max_ratio, w[2],
                w[3], kMaxOverlapRatio);
  message_ = b;
}

void StepGuards::check_cell(const PeriodicCell& cell, real_t cutoff, real_t skin, std::int64_t step) {
  // The list holds one periodic image per pair; that is every image within the cutoff while
  // each cell length exceeds twice the cutoff (check_cell_size at the start). A cell that
  // shrinks (consolidation) can pass that limit: two spheres could then touch through two
  // images, and the second contact would be missed (spheres run into each other unseen and
  // the energy account fills with energy never put in). Checked at every rebuild, which is
  // enough: a pair outside the list cannot come into contact before the next one.
  if (!message_.empty()) return;
  // A sheared cell: the heights between opposite faces (a shear thins them too).
  const Vec3 L = cell.sheared() ? cell.heights() : cell.lengths();
  const real_t need = 2.0 * cutoff;
  for (int k = 0; k < 3; ++k) {
    if (L[k] > need) continue;
    char what[160], b[600];
    if (cell.sheared())
      std::snprintf(what, sizeof what, "the sheared periodic cell has thinned to a height h%d = %.6g m", k + 1, L[k]);
    else std::snprintf(what, sizeof what, "the periodic cell has shrunk to L%d = %.6g m", k + 1, L[k]);
    std::snprintf(b, sizeof b,
                  "the run cannot go on at step %lld: %s, "
                  "no longer above 2 (2 Rmax + skin) = %.6g m (Rmax %.6g m, skin %.6g m); two "
                  "spheres could now touch through two periodic images, which the contact search "
                  "does not follow. Use a larger specimen (more spheres, or a narrower gradation), "
                  "so that every cell length stays above that limit at the densest state",
                  (long long)(step + 1), what, need, 0.5 * (cutoff - skin), skin);
    message_ = b;
    return;
  }
}

}  // namespace fabrica
