#include "core/energy_account.hpp"

namespace fabrica {

EnergyBook::EnergyBook(const EnergyAccount& s)
    : e0_(s.e0), work_(s.work), gravity_work_local_(s.gravity_work_local), wall_work_(s.wall_work),
      drive_work_(s.drive_work) {
  if (s.vol_strain[1] != 0) last_ = Known{s.stress_prev, s.vol_strain[0]};
}

EnergyAccount EnergyBook::record() const {
  EnergyAccount a;
  a.e0 = e0_;
  a.work = work_;
  if (last_) {
    a.vol_strain = Vec3(last_->volume, 1.0, 0.0);
    a.stress_prev = last_->stress;
  }
  a.gravity_work_local = gravity_work_local_;
  a.wall_work = wall_work_;
  a.drive_work = drive_work_;
  return a;
}

void EnergyBook::close_step(real_t V, const Vec3& strain_increment, const Vec3& stress_end) {
  const Vec3 end = V * stress_end;
  if (!strain_increment.isZero()) {
    const Vec3 start = last_ ? Vec3(last_->volume * last_->stress.diagonal()) : end;
    work_ -= 0.5 * (start + end).dot(strain_increment);
  }
  last_ = Known{Mat3(stress_end.asDiagonal()), V};
}

void EnergyBook::close_step(real_t V, const Mat3& strain_increment, const Mat3& stress_end) {
  const Mat3 end = V * stress_end;
  if (!strain_increment.isZero()) {
    const Mat3 start = last_ ? Mat3(last_->volume * last_->stress) : end;
    work_ -= 0.5 * (start + end).cwiseProduct(strain_increment).sum();
  }
  last_ = Known{stress_end, V};
}

}  // namespace fabrica
