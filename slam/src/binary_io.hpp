#pragma once
// Little-endian binary encoding for the slam module's file formats (map files, vocabularies): a writer,
// a reader bounded to [begin, end) whose every read past the end is an InputError naming the file or
// section, and the FNV-1a 64 checksum both formats end with. Private to the slam library.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>

#include <Eigen/Geometry>

#include "fleetslam/core/error.hpp"

namespace fleetslam::slam::binary {

inline std::uint64_t fnv1a(const char* data, std::size_t size, std::uint64_t hash = 0xcbf29ce484222325ULL) {
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= static_cast<unsigned char>(data[i]);
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

// Little-endian encoding whatever the host's byte order.
class Writer {
 public:
  void bytes(const void* p, std::size_t n) { out_.append(static_cast<const char*>(p), n); }
  void u8(std::uint8_t v) { out_.push_back(static_cast<char>(v)); }
  void u32(std::uint32_t v) { put(v, 4); }
  void i32(std::int32_t v) { put(static_cast<std::uint32_t>(v), 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void i64(std::int64_t v) { put(static_cast<std::uint64_t>(v), 8); }
  void f32(float v) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    u32(bits);
  }
  void f64(double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    u64(bits);
  }
  void size(std::size_t n) { u64(static_cast<std::uint64_t>(n)); }
  void pose(const Eigen::Isometry3d& T) {
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) f64(T.matrix()(r, c));
    }
  }
  void vec3(const Eigen::Vector3d& v) {
    for (int i = 0; i < 3; ++i) f64(v[i]);
  }
  std::string& str() { return out_; }

 private:
  void put(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) out_.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  }
  std::string out_;
};

// Reads within [pos, end); any read past the end is an InputError naming the section.
class Reader {
 public:
  Reader(const std::string& data, std::size_t begin, std::size_t end, std::string where)
      : data_(data), pos_(begin), end_(end), where_(std::move(where)) {}

  void bytes(void* p, std::size_t n) {
    need(n);
    std::memcpy(p, data_.data() + pos_, n);
    pos_ += n;
  }
  std::uint8_t u8() { return static_cast<std::uint8_t>(get(1)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(get(4)); }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  std::uint64_t u64() { return get(8); }
  std::int64_t i64() { return static_cast<std::int64_t>(u64()); }
  bool flag() {
    const std::uint8_t v = u8();
    if (v > 1) fail("a flag byte holds " + std::to_string(v));
    return v == 1;
  }
  float f32() {
    const std::uint32_t bits = u32();
    float v = 0.0f;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  double f64() {
    const std::uint64_t bits = u64();
    double v = 0.0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  // A count of elements of at least min_bytes each, checked against the bytes left (no huge allocation).
  std::size_t count(std::size_t min_bytes, const char* what) {
    const std::uint64_t n = u64();
    if (n > (end_ - pos_) / std::max<std::size_t>(min_bytes, 1)) {
      fail(std::string("count of ") + what + " (" + std::to_string(n) + ") exceeds the bytes left");
    }
    return static_cast<std::size_t>(n);
  }
  Eigen::Isometry3d pose() {
    Eigen::Isometry3d T;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) T.matrix()(r, c) = f64();
    }
    return T;
  }
  Eigen::Vector3d vec3() {
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = f64();
    return v;
  }
  bool done() const { return pos_ == end_; }
  [[noreturn]] void fail(const std::string& why) const { throw InputError(where_, why); }

 private:
  void need(std::size_t n) const {
    if (n > end_ - pos_) fail("truncated: needs " + std::to_string(n) + " more bytes at offset " + std::to_string(pos_));
  }
  std::uint64_t get(int n) {
    need(static_cast<std::size_t>(n));
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= std::uint64_t{static_cast<unsigned char>(data_[pos_ + static_cast<std::size_t>(i)])} << (8 * i);
    pos_ += static_cast<std::size_t>(n);
    return v;
  }
  const std::string& data_;
  std::size_t pos_;
  std::size_t end_;
  std::string where_;
};

}  // namespace fleetslam::slam::binary
