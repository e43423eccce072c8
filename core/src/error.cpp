#include "fleetslam/core/error.hpp"

namespace fleetslam {

InputError::InputError(std::string where, std::string why)
    : Error(where + ": " + why), where_(std::move(where)), why_(std::move(why)) {}

std::string at_line(const std::string& file, std::size_t line_number) {
  return file + ":" + std::to_string(line_number);
}

InvariantError::InvariantError(const char* file, int line, const char* condition,
                               const std::string& message)
    : Error(std::string(file) + ":" + std::to_string(line) + ": check failed (" + condition +
            "): " + message) {}

}  // namespace fleetslam
