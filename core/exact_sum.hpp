// Exact, order-independent sums of doubles, for reductions whose result must not depend on the
// number of MPI ranks (core/fabric.cpp).
//
// Each term is rounded once, towards zero, to the fixed grid 2^-128 (a per-term operation, so
// the same whatever the rank that holds the term), then added exactly to a fixed-point integer
// of 9 signed 64-bit "digits" of 32 bits each: value = sum_k d_k 2^(32 k - 128), k = 0..8.
// Integer addition is associative, so any grouping of the terms - one rank or several, in any
// order - gives the same integer, and after normalize() the same digits, bit for bit; value()
// converts them to the nearest-ish double (within 2 ulp), deterministically.
//
// Range: |term| < 2^149 (about 7e44), else add() throws std::overflow_error; non-finite terms
// throw std::domain_error. Terms below 2^-128 (3e-39) are lost (absolute error 2^-128 per term).
// A slot takes 2^30 additions between normalizations (done automatically); the sum over ranks
// of normalized digits fits as long as there are fewer than 2^31 ranks.
#pragma once
#include <bit>
#include <cmath>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

namespace fabrica {

__extension__ typedef unsigned __int128 ExactSumsWide;  // GCC/Clang: 128-bit shifts

class ExactSums {
 public:
  static constexpr int kDigits = 9;
  static constexpr int kLowExp = -128;

  explicit ExactSums(std::size_t slots = 0) : d_(slots * kDigits, 0) {}

  std::size_t slots() const { return d_.size() / kDigits; }

  void add(std::size_t slot, double x) {
    // IEEE 754 binary64: x = (-1)^sign mant 2^(field - 1075), mant with the hidden bit (normal
    // numbers; subnormals lie far below the grid and are dropped).
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(x);
    const int field = int((bits >> 52) & 0x7ff);
    if (field == 0x7ff) throw std::domain_error("ExactSums: non-finite term");
    if (field == 0) return;  // zero or subnormal (< 2^-1022)
    std::int64_t mant = std::int64_t((bits & ((std::uint64_t(1) << 52) - 1)) | (std::uint64_t(1) << 52));
    int pos = field - 1075 - kLowExp;  // |x| = mant 2^(pos + kLowExp)
    if (pos < 0) {
      if (pos <= -53) return;
      mant >>= -pos;  // towards zero
      pos = 0;
    }
    const int k = pos / 32, s = pos % 32;
    if (k + 2 >= kDigits) throw std::overflow_error("ExactSums: term out of range");
    const ExactSumsWide v = static_cast<ExactSumsWide>(mant) << s;  // < 2^85
    const std::int64_t c0 = std::int64_t(v & 0xffffffffu), c1 = std::int64_t((v >> 32) & 0xffffffffu),
                       c2 = std::int64_t(v >> 64);
    std::int64_t* d = d_.data() + slot * kDigits;
    if (!(bits >> 63)) d[k] += c0, d[k + 1] += c1, d[k + 2] += c2;
    else d[k] -= c0, d[k + 1] -= c1, d[k + 2] -= c2;
    if (++adds_ >= (std::int64_t(1) << 30)) normalize();
  }

  // Carries propagated: digits 0..7 in [0, 2^32), digit 8 signed. The canonical form of the
  // integer, hence the same bits for the same value.
  void normalize() {
    for (std::size_t s = 0; s < slots(); ++s) {
      std::int64_t* d = d_.data() + s * kDigits;
      for (int k = 0; k + 1 < kDigits; ++k) {
        const std::int64_t carry = d[k] >> 32;  // floor division by 2^32
        d[k] -= carry * (std::int64_t(1) << 32);
        d[k + 1] += carry;
      }
    }
    adds_ = 0;
  }

  // The sum of slot 'slot' (call normalize() first).
  double value(std::size_t slot) const {
    const std::int64_t* d = d_.data() + slot * kDigits;
    std::int64_t m[kDigits];
    const bool negative = d[kDigits - 1] < 0;
    // The magnitude in canonical digits: negate the two's-complement-like number if negative.
    std::int64_t borrow = 0;
    for (int k = 0; k < kDigits; ++k) {
      std::int64_t x = negative ? -d[k] - borrow : d[k];
      borrow = 0;
      if (negative && k + 1 < kDigits && x < 0) x += std::int64_t(1) << 32, borrow = 1;
      m[k] = x;
    }
    double r = 0;  // from the most significant digit down: deterministic rounding
    for (int k = kDigits - 1; k >= 0; --k) r += std::ldexp(double(m[k]), 32 * k + kLowExp);
    return negative ? -r : r;
  }

  std::span<std::int64_t> words() { return d_; }

 private:
  std::vector<std::int64_t> d_;
  std::int64_t adds_ = 0;
};

}  // namespace fabrica
