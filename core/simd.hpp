// Lane types for the contact kernel (core/contact_law.hpp, core/forces.cpp): one double, or
// four doubles in one 256-bit register (d4, a GCC/Clang vector extension; AVX2 under
// -march=x86-64-v3, split into SSE2 halves by the compiler on older targets). Every operation
// on d4 is done lane by lane with IEEE rounding, exactly as the scalar operation on each lane:
// +, -, *, / and sqrt are correctly rounded, and with -ffp-contract=off (the project's flag,
// docs/verification.md) no product is fused with a sum in either form. Code written once over a
// lane type T therefore gives the same bits with T = double and with T = d4, lane for lane
// (tests/unit/test_forces_simd.cpp).
//
// Branches become masks: a comparison of d4 values gives a vector of 0 / -1 (m4), select()
// picks per lane, any() tells whether a masked block can be skipped. Keep both arms free of
// side effects; an arm computed for lanes that do not take it may hold NaN, which select()
// throws away.
#pragma once
#include "core/types.hpp"

#include <cmath>
#include <cstdint>

#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace fabrica::simd {

typedef double d4 __attribute__((vector_size(32)));
typedef decltype(d4{} < d4{}) m4;  // 64-bit integer lanes, 0 (false) or -1 (true)

template <class T>
struct Lanes;
template <>
struct Lanes<double> {
  using mask = bool;
  static constexpr int n = 1;
};
template <>
struct Lanes<d4> {
  using mask = m4;
  static constexpr int n = 4;
};
template <class T>
using mask_t = typename Lanes<T>::mask;

inline double sqrt(double x) { return std::sqrt(x); }
inline d4 sqrt(d4 x) {
#if defined(__AVX__)
  return _mm256_sqrt_pd(x);
#else
  return d4{std::sqrt(x[0]), std::sqrt(x[1]), std::sqrt(x[2]), std::sqrt(x[3])};
#endif
}

inline double select(bool m, double a, double b) { return m ? a : b; }
inline d4 select(m4 m, d4 a, d4 b) { return m ? a : b; }

inline bool any(bool m) { return m; }
inline bool any(m4 m) {
#if defined(__AVX__)
  return _mm256_movemask_pd(reinterpret_cast<__m256d>(m)) != 0;
#else
  return (m[0] | m[1] | m[2] | m[3]) != 0;
#endif
}
inline bool all(bool m) { return m; }
inline bool all(m4 m) {
#if defined(__AVX__)
  return _mm256_movemask_pd(reinterpret_cast<__m256d>(m)) == 0xF;
#else
  return (m[0] & m[1] & m[2] & m[3]) != 0;
#endif
}

template <class T>
mask_t<T> all_true();
template <>
inline bool all_true<double>() {
  return true;
}
template <>
inline m4 all_true<d4>() {
  return m4{-1, -1, -1, -1};
}

// Lane l of a value or a mask (l = 0 for the scalar types).
inline double lane(double v, int) { return v; }
inline double lane(d4 v, int l) { return v[l]; }
inline bool lane(bool m, int) { return m; }
inline bool lane(m4 m, int l) { return m[l] != 0; }

inline void set_lane(double& v, int, double x) { v = x; }
inline void set_lane(d4& v, int l, double x) { v[l] = x; }

// a[idx[0]], ..., a[idx[n-1]].
template <class T>
T gather(const real_t* a, const Index* idx);
template <>
inline double gather<double>(const real_t* a, const Index* idx) {
  return a[idx[0]];
}
template <>
inline d4 gather<d4>(const real_t* a, const Index* idx) {
  return d4{a[idx[0]], a[idx[1]], a[idx[2]], a[idx[3]]};
}

// a[0], ..., a[n-1] (contiguous, any alignment).
template <class T>
T load(const real_t* a);
template <>
inline double load<double>(const real_t* a) {
  return a[0];
}
template <>
inline d4 load<d4>(const real_t* a) {
  d4 v;
  __builtin_memcpy(&v, a, sizeof v);
  return v;
}
inline void store(real_t* a, double v) { a[0] = v; }
inline void store(real_t* a, d4 v) { __builtin_memcpy(a, &v, sizeof v); }

// A 3-vector with one lane type per component (structure of arrays over the lanes).
template <class T>
struct V3 {
  T x, y, z;
};
template <class T>
inline V3<T> operator+(const V3<T>& a, const V3<T>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
inline V3<T> operator-(const V3<T>& a, const V3<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T, class S>
inline V3<T> operator*(const S& s, const V3<T>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T, class S>
inline V3<T> operator*(const V3<T>& a, const S& s) {
  return {a.x * s, a.y * s, a.z * s};
}
template <class T, class S>
inline V3<T> operator/(const V3<T>& a, const S& s) {
  return {a.x / s, a.y / s, a.z / s};
}
// In Eigen's order for 3-vectors (checked bit for bit against Eigen 3.4): (x + y) + z.
template <class T>
inline T dot(const V3<T>& a, const V3<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
inline T squared_norm(const V3<T>& a) {
  return a.x * a.x + a.y * a.y + a.z * a.z;
}
template <class T>
inline V3<T> cross(const V3<T>& a, const V3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T, class M>
inline V3<T> select(const M& m, const V3<T>& a, const V3<T>& b) {
  return {select(m, a.x, b.x), select(m, a.y, b.y), select(m, a.z, b.z)};
}
template <class T>
inline V3<T> zero3() {
  return {T{}, T{}, T{}};
}

inline V3<double> from_vec(const Vec3& v) { return {v[0], v[1], v[2]}; }
inline Vec3 to_vec(const V3<double>& v) { return Vec3(v.x, v.y, v.z); }
inline Vec3 lane(const V3<d4>& v, int l) { return Vec3(v.x[l], v.y[l], v.z[l]); }
inline Vec3 lane(const V3<double>& v, int) { return to_vec(v); }

// a[idx[0]], ..., a[idx[n-1]] of an array of Vec3 (24-byte records), as components.
template <class T>
V3<T> gather3(const Vec3* a, const Index* idx);
template <>
inline V3<double> gather3<double>(const Vec3* a, const Index* idx) {
  return from_vec(a[idx[0]]);
}
template <>
inline V3<d4> gather3<d4>(const Vec3* a, const Index* idx) {
#if defined(__AVX__)
  // Four rows (x, y, z, -) loaded with a mask (no read past the last record), transposed.
  const __m256i m = _mm256_set_epi64x(0, -1, -1, -1);
  const __m256d r0 = _mm256_maskload_pd(a[idx[0]].data(), m), r1 = _mm256_maskload_pd(a[idx[1]].data(), m);
  const __m256d r2 = _mm256_maskload_pd(a[idx[2]].data(), m), r3 = _mm256_maskload_pd(a[idx[3]].data(), m);
  const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);  // x0 x1 z0 z1, y0 y1 - -
  const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
  return {_mm256_permute2f128_pd(t0, t2, 0x20), _mm256_permute2f128_pd(t1, t3, 0x20),
          _mm256_permute2f128_pd(t0, t2, 0x31)};
#else
  const Vec3 &p0 = a[idx[0]], &p1 = a[idx[1]], &p2 = a[idx[2]], &p3 = a[idx[3]];
  return {d4{p0[0], p1[0], p2[0], p3[0]}, d4{p0[1], p1[1], p2[1], p3[1]}, d4{p0[2], p1[2], p2[2], p3[2]}};
#endif
}

// The lanes of v as rows (x, y, z, -) of 4 doubles, rows[4 l .. 4 l + 2] = lane l: a Vec3 read
// from a row is one 16-byte and one 8-byte load inside the row's 32-byte store, which the store
// buffer forwards.
inline void to_rows(const V3<double>& v, real_t* rows) { rows[0] = v.x, rows[1] = v.y, rows[2] = v.z; }
inline void to_rows(const V3<d4>& v, real_t* rows) {
#if defined(__AVX__)
  const __m256d t0 = _mm256_unpacklo_pd(v.x, v.y), t1 = _mm256_unpackhi_pd(v.x, v.y);  // x0 y0 x2 y2, x1 y1 x3 y3
  const __m256d t2 = _mm256_unpacklo_pd(v.z, v.z), t3 = _mm256_unpackhi_pd(v.z, v.z);  // z0 z0 z2 z2, z1 z1 z3 z3
  _mm256_store_pd(rows + 0, _mm256_permute2f128_pd(t0, t2, 0x20));
  _mm256_store_pd(rows + 4, _mm256_permute2f128_pd(t1, t3, 0x20));
  _mm256_store_pd(rows + 8, _mm256_permute2f128_pd(t0, t2, 0x31));
  _mm256_store_pd(rows + 12, _mm256_permute2f128_pd(t1, t3, 0x31));
#else
  for (int l = 0; l < 4; ++l) rows[4 * l] = v.x[l], rows[4 * l + 1] = v.y[l], rows[4 * l + 2] = v.z[l];
#endif
}

// a[idx[l]] = lane l of v (stores, in lane order).
inline void scatter3(Vec3* a, const Index* idx, const V3<double>& v) { a[idx[0]] = to_vec(v); }
inline void scatter3(Vec3* a, const Index* idx, const V3<d4>& v) {
  for (int l = 0; l < 4; ++l) a[idx[l]] = lane(v, l);
}
inline void scatter(real_t* a, const Index* idx, double v) { a[idx[0]] = v; }
inline void scatter(real_t* a, const Index* idx, d4 v) {
  for (int l = 0; l < 4; ++l) a[idx[l]] = v[l];
}

}  // namespace fabrica::simd
