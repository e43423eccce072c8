#pragma once
// Peak heap memory per benchmark: a benchmark::MemoryManager fed by replacement global operator
// new/delete (memory_counter.cpp, compiled once into every bench executable through the
// fleetslam_bench_memory object library in CMakeLists.txt).
//
// Why this is written here: Google Benchmark only defines the MemoryManager interface (Start / Stop
// filling a Result); it ships no implementation, because counting allocations means hooking the
// allocator, which it leaves to the user (its own tests replace operator new the same way).
//
// What is counted: blocks from every form of C++ operator new (plain, array, nothrow, aligned), in any
// thread, between Start and Stop, by their usable size (malloc_usable_size, so that unsized deletes can
// be subtracted). Not counted: memory taken with malloc/posix_memalign directly, i.e. cv::Mat buffers
// (cv::fastMalloc), Eigen's dynamic-size matrices (Eigen::internal::aligned_malloc), and C libraries
// (MuJoCo, OSMesa). So "peak" is the peak of the C++ heap (std containers, the project's own objects)
// above its level at Start, and a lower bound of what the process needed.
//
// When: Google Benchmark 1.7.1 runs each benchmark once more after timing it, for min(16, iterations)
// iterations, with the manager started around the whole benchmark function, so the figure includes
// what the function builds before its timed loop (not what static caches built earlier). Allocation
// counting is off during the timed runs: timings are unchanged.
//
// Output: 1.7.1 writes the manager's Result only in JSON (max_bytes_used, allocs_per_iter,
// total_allocated_bytes, net_heap_growth, e.g. with --benchmark_out=FILE); run_benchmarks() adds them
// to the console as the user counters peak_MiB and allocs/iter.

#include <cstdint>
#include <vector>

#include <benchmark/benchmark.h>

namespace fleetslam::bench {

class AllocationCounter final : public benchmark::MemoryManager {
 public:
  void Start() override;
  void Stop(Result& result) override;
  // The deprecated pointer form, still pure virtual in 1.7.1.
  void Stop(Result* result) override;

  // The peak bytes of each Stop() not yet taken, oldest first. The console reporter reads the peaks from
  // here, not through Run::memory_result: 1.7.1 keeps the results in a std::vector that reallocates
  // between repetitions, so the runs' pointers into it dangle (google/benchmark#1939, fixed in 1.9.2).
  std::vector<std::int64_t> take_peaks();

 private:
  std::vector<std::int64_t> peaks_;
};

// A bench executable's main(): registers an AllocationCounter, runs the benchmarks selected by the
// google-benchmark flags in argv and shows peak memory on the console. Returns main's exit status.
int run_benchmarks(int argc, char** argv);

}  // namespace fleetslam::bench
