#pragma once
// Elapsed time for the timings a run reports. A measurement only: no decision depends on it.

#include <chrono>

namespace fleetslam::slam {

class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double elapsed_ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace fleetslam::slam
