#include "apps/fabric_output.hpp"

#include "core/measures.hpp"
#include "core/principal.hpp"

#include <fmt/core.h>

#include <cmath>

namespace fabrica {

namespace {
std::string num(real_t v) { return std::isnan(v) ? std::string("nan") : fmt::format("{:.10g}", v); }
}  // namespace

void write_fabric_headers(const FabricStreams& out, int rose_bins, bool principal) {
  if (out.fabric) {
    *out.fabric << "stage,step,eps1,network,count,mean_fn,zeta,gamma,xi,share,phi11,phi22,phi33,phi12,"
                   "phi23,phi13,phi_1,phi_2,phi_3,dir_1,dir_2,dir_3,a_c,a_b,a_n,a_t,ac11,ac22,"
                   "ac33,an11,an22,an33,at11,at22,at33,b0,f0,p_k,q_k,s11_k,s22_k,s33_k,s12_k,s23_k,"
                   "s13_k,s21_k,s32_k,s31_k,nonpositive_weights,min_weight";
    if (principal) *out.fabric << ",noncoaxiality,ac_1,ac_2,ac_3,ab_1,ab_2,ab_3,an_1,an_2,an_3,at_1,at_2,at_3";
    *out.fabric << '\n';
  }
  if (out.sff) {
    *out.sff << "stage,step,eps1,contacts,mean_fn,p,q,q_p";
    for (auto name : kPartitionNames) *out.sff << ",q_p_star_" << name;
    for (auto name : kPartitionNames) *out.sff << ",q_p_tensor_" << name;
    for (auto name : kPartitionNames) *out.sff << ",q_p_exact_" << name;
    for (auto name : kPartitionNames) *out.sff << ",q_p_exact_tensor_" << name;
    for (auto name : kPartitionNames) *out.sff << ",q_p_recombined_" << name;
    *out.sff << '\n';
  }
  if (out.rose) {
    *out.rose << "stage,step,eps1,network,plane";
    for (int b = 0; b < rose_bins; ++b) *out.rose << ",bin" << b;
    *out.rose << '\n';
  }
}

void write_fabric_rows(const FabricStreams& out, const std::string& stage, std::int64_t step, real_t eps1,
                       const FabricResult& r, bool principal) {
  const std::string label = fmt::format("{},{},{}", stage, step, num(eps1));
  const Vec3 stress_major = principal ? fabrica::principal(r.stress).major : Vec3::Zero();
  if (out.fabric) {
    for (int k = 0; k < kNetworks; ++k) {
      const NetworkFabric& n = r.net[k];
      real_t pk = 0, qk = 0;
      deviatoric_invariants(n.stress, pk, qk);
      const real_t v[] = {n.mean_fn,
                          n.zeta,
                          n.gamma,
                          n.xi,
                          n.share,
                          n.phi(0, 0),
                          n.phi(1, 1),
                          n.phi(2, 2),
                          n.phi(0, 1),
                          n.phi(1, 2),
                          n.phi(0, 2),
                          n.phi_principal[0],
                          n.phi_principal[1],
                          n.phi_principal[2],
                          n.phi_major[0],
                          n.phi_major[1],
                          n.phi_major[2],
                          n.a_c,
                          n.a_b,
                          n.a_n,
                          n.a_t,
                          n.ac(0, 0),
                          n.ac(1, 1),
                          n.ac(2, 2),
                          n.an(0, 0),
                          n.an(1, 1),
                          n.an(2, 2),
                          n.at(0, 0),
                          n.at(1, 1),
                          n.at(2, 2),
                          n.branch.trace(),
                          n.normal_force.trace(),
                          pk,
                          qk,
                          n.stress(0, 0),
                          n.stress(1, 1),
                          n.stress(2, 2),
                          n.stress(0, 1),
                          n.stress(1, 2),
                          n.stress(0, 2),
                          n.stress(1, 0),
                          n.stress(2, 1),
                          n.stress(2, 0)};
      *out.fabric << label << ',' << kNetworkNames[k] << ',' << n.count;
      for (real_t x : v) *out.fabric << ',' << num(x);
      *out.fabric << ',' << n.nonpositive_weights << ',' << num(n.min_weight);
      if (principal) {  // NaN for an empty network (its tensors are NaN)
        *out.fabric << ',' << num(axes_angle(n.phi_major, stress_major));
        for (const Mat3* a : {&n.ac, &n.ab, &n.an, &n.at})
          for (real_t x : fabrica::principal(*a).values) *out.fabric << ',' << num(x);
      }
      *out.fabric << '\n';
    }
  }
  if (out.sff) {
    *out.sff << label << ',' << r.contacts << ',' << num(r.mean_fn) << ',' << num(r.p) << ',' << num(r.q) << ','
             << num(r.q_p);
    for (real_t x : r.q_p_star) *out.sff << ',' << num(x);
    for (real_t x : r.q_p_star_tensor) *out.sff << ',' << num(x);
    for (real_t x : r.q_p_exact) *out.sff << ',' << num(x);
    for (real_t x : r.q_p_exact_tensor) *out.sff << ',' << num(x);
    for (real_t x : r.q_p_recombined) *out.sff << ',' << num(x);
    *out.sff << '\n';
  }
  if (out.rose) {
    for (int k = 0; k < kNetworks; ++k)
      for (int plane = 0; plane < 2; ++plane) {
        *out.rose << label << ',' << kNetworkNames[k] << ',' << (plane == 0 ? "12" : "23");
        for (std::int64_t c : plane == 0 ? r.net[k].rose12 : r.net[k].rose23) *out.rose << ',' << c;
        *out.rose << '\n';
      }
  }
}

}  // namespace fabrica
