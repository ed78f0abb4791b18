// Plain values appended to and read back from the byte buffers that travel between the ranks of
// one run. Every rank runs the same build, so the values keep their native layout here; what is
// written to files has an explicit layout instead (io/mpi/fields.hpp). T is a plain value or a
// struct of them and of fixed-size Eigen vectors (which std::is_trivially_copyable does not
// admit, though copying their bytes is exact).
#pragma once
#include <cstddef>
#include <cstring>
#include <vector>

namespace fabrica {

// A contiguous range of memory a message (or part of one) is received into.
struct BytePiece {
  void* at;
  std::size_t bytes;
};

template <class T>
void put(std::vector<char>& buf, const T& v) {
  const std::size_t n = buf.size();
  buf.resize(n + sizeof(T));
  std::memcpy(buf.data() + n, &v, sizeof(T));
}

// Reads a T at 'in' and moves 'in' past it.
template <class T>
T get(const char*& in) {
  T v;
  std::memcpy(static_cast<void*>(&v), in, sizeof(T));
  in += sizeof(T);
  return v;
}

}  // namespace fabrica
