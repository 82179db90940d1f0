#pragma once
// Internal (not installed): the checkpoint's field writer and bounds-checked reader, which
// checkpoint.cpp (the run's state) and checkpoint_scalpels.cpp (a run with scalpels) share.
// Every count is checked against the bytes that remain before anything is allocated.

#include <zlib.h>

#include <Eigen/Core>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "lamina/core/error.h"
#include "lamina/io/checkpoint.h"

namespace lamina::io::checkpoint_detail {

inline uint32_t crc(uint32_t c, const void* data, size_t bytes) {
  return static_cast<uint32_t>(crc32_z(c, static_cast<const Bytef*>(data), bytes));
}

struct Writer {
  std::string out;
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void bytes(const void* p, size_t n) {
    if (n > 0) out.append(static_cast<const char*>(p), n);  // an empty vector's data() may be null
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    pod<uint64_t>(v.size());
    bytes(v.data(), v.size() * sizeof(T));
  }
  void str(const std::string& s) {
    pod<uint64_t>(s.size());
    bytes(s.data(), s.size());
  }
  void mat(const Eigen::MatrixX3d& m) { matrix(m); }
  // Any matrix with a fixed column count: its rows, then its column-major values.
  template <class M>
  void matrix(const M& m) {
    pod<uint64_t>(static_cast<uint64_t>(m.rows()));
    bytes(m.data(), static_cast<size_t>(m.size()) * sizeof(typename M::Scalar));
  }
};

struct Reader {
  const std::string& path;
  const char* p;
  const char* end;
  uint32_t version = 0;  ///< the checkpoint's format version (what the fields hold)
  [[noreturn]] void truncated() const {
    throw invalid_input(path, "checkpoint is truncated or corrupt (a field runs past its end)");
  }
  void take(void* dst, size_t n) {
    if (n == 0) return;  // an empty vector's data() may be null, which memcpy must not see
    if (static_cast<size_t>(end - p) < n) truncated();
    std::memcpy(dst, p, n);
    p += n;
  }
  template <class T>
  T pod() {
    T v;
    take(&v, sizeof v);
    return v;
  }
  // A count of elements of `size` bytes each, no more than the bytes that remain can hold.
  size_t count(size_t size) {
    const auto n = pod<uint64_t>();
    if (n > static_cast<uint64_t>(end - p) / size) truncated();
    return static_cast<size_t>(n);
  }
  template <class T>
  std::vector<T> vec() {
    std::vector<T> v(count(sizeof(T)));
    take(v.data(), v.size() * sizeof(T));
    return v;
  }
  std::string str() {
    std::string s(count(1), '\0');
    take(s.data(), s.size());
    return s;
  }
  Eigen::MatrixX3d mat() { return matrix<Eigen::MatrixX3d>(); }
  template <class M>
  M matrix() {
    using T = typename M::Scalar;
    M m(static_cast<Eigen::Index>(count(M::ColsAtCompileTime * sizeof(T))), M::ColsAtCompileTime);
    take(m.data(), static_cast<size_t>(m.size()) * sizeof(T));
    return m;
  }
};

void write_scalpels(Writer& w, const ScalpelCheckpoint& k);
ScalpelCheckpoint read_scalpels(Reader& r);

}  // namespace lamina::io::checkpoint_detail
