#pragma once
// Errors of the project. Bad input (config, scene, dataset, message) is an InputError thrown at the
// boundary, its message "where: why" with where = "file:line" or "file:key". Broken invariants inside
// algorithms are InvariantErrors from FLEETSLAM_CHECK, which is always on (Release builds included).

#include <cstddef>
#include <stdexcept>
#include <string>

namespace fleetslam {

// Base of every exception the project throws on purpose.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Bad input: a file, a key or a message that cannot be used. what() == where() + ": " + why().
class InputError : public Error {
 public:
  InputError(std::string where, std::string why);

  // "file:line", "file:key" or just "file".
  const std::string& where() const noexcept { return where_; }
  const std::string& why() const noexcept { return why_; }

 private:
  std::string where_;
  std::string why_;
};

// Builds "file:line" for InputError.
std::string at_line(const std::string& file, std::size_t line_number);

// A broken internal invariant (a bug, not bad input).
class InvariantError : public Error {
 public:
  InvariantError(const char* file, int line, const char* condition, const std::string& message);
};

}  // namespace fleetslam

// Always-on invariant check; throws fleetslam::InvariantError naming the source line and condition.
#define FLEETSLAM_CHECK(condition, message)                                                \
  do {                                                                                     \
    if (!(condition)) {                                                                    \
      throw ::fleetslam::InvariantError(__FILE__, __LINE__, #condition, (message));        \
    }                                                                                      \
  } while (false)
