// The allocation counter of memory_counter.hpp: replacement global operator new/delete (this file is the
// one translation unit per bench executable that defines them) and the console reporter that shows the
// counter's figures.
#include "memory_counter.hpp"

#include <malloc.h>  // malloc_usable_size (glibc)
#include <unistd.h>  // isatty

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

namespace fleetslam::bench {
namespace {

// Counting state. Relaxed atomics: the figures are read after the measured threads have joined.
std::atomic<bool> g_active{false};
std::atomic<std::int64_t> g_in_use{0};  // bytes above the level at Start (negative when older blocks are freed)
std::atomic<std::int64_t> g_peak{0};
std::atomic<std::int64_t> g_allocs{0};
std::atomic<std::int64_t> g_allocated{0};

void count_allocation(void* p) {
  if (!g_active.load(std::memory_order_relaxed)) return;
  const auto bytes = static_cast<std::int64_t>(malloc_usable_size(p));
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  g_allocated.fetch_add(bytes, std::memory_order_relaxed);
  const std::int64_t now = g_in_use.fetch_add(bytes, std::memory_order_relaxed) + bytes;
  std::int64_t peak = g_peak.load(std::memory_order_relaxed);
  while (now > peak && !g_peak.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
  }
}

void count_release(void* p) {
  if (p == nullptr || !g_active.load(std::memory_order_relaxed)) return;
  g_in_use.fetch_sub(static_cast<std::int64_t>(malloc_usable_size(p)), std::memory_order_relaxed);
}

// One attempt; nullptr when the system has no memory left.
void* try_allocate(std::size_t bytes, std::size_t alignment) {
  if (bytes == 0) bytes = 1;
  void* p = nullptr;
  if (alignment <= alignof(std::max_align_t)) {
    p = std::malloc(bytes);
  } else if (posix_memalign(&p, alignment, bytes) != 0) {
    p = nullptr;
  }
  if (p != nullptr) count_allocation(p);
  return p;
}

// operator new's contract: retry through the new-handler, throw bad_alloc when there is none.
void* allocate(std::size_t bytes, std::size_t alignment) {
  for (;;) {
    if (void* p = try_allocate(bytes, alignment)) return p;
    const std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}

void* allocate_nothrow(std::size_t bytes, std::size_t alignment) noexcept {
  try {
    return allocate(bytes, alignment);
  } catch (...) {
    return nullptr;
  }
}

void release(void* p) noexcept {
  count_release(p);
  std::free(p);
}

constexpr std::size_t kDefault = alignof(std::max_align_t);

// ConsoleReporter, plus the memory figures (reported by 1.7.1 in JSON only) as user counters.
class MemoryConsoleReporter final : public benchmark::ConsoleReporter {
 public:
  MemoryConsoleReporter(OutputOptions options, AllocationCounter& counter) : ConsoleReporter(options), counter_(counter) {}

  // The runs that had a memory measurement, in order, take the counter's peaks in order (see
  // AllocationCounter::take_peaks on why not run.memory_result).
  void ReportRuns(const std::vector<Run>& reports) override {
    const std::vector<std::int64_t> peaks = counter_.take_peaks();
    std::size_t next = 0;
    std::vector<Run> runs = reports;
    for (Run& run : runs) {
      if (run.memory_result == nullptr || next >= peaks.size()) continue;
      run.counters["peak_MiB"] = static_cast<double>(peaks[next++]) / (1024.0 * 1024.0);
      run.counters["allocs/iter"] = run.allocs_per_iter;
    }
    ConsoleReporter::ReportRuns(runs);
  }

 private:
  AllocationCounter& counter_;
};

// The value of --NAME=VALUE in argv ("" when absent; "true" for a bare --NAME).
std::string flag(int argc, char** argv, const std::string& name) {
  const std::string prefix = "--" + name;
  std::string value;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == prefix) value = "true";
    if (arg.rfind(prefix + "=", 0) == 0) value = arg.substr(prefix.size() + 1);
  }
  return value;
}

bool is_true(const std::string& v) { return v == "true" || v == "yes" || v == "1" || v == "on"; }
bool is_false(const std::string& v) { return v == "false" || v == "no" || v == "0" || v == "off"; }

}  // namespace

void AllocationCounter::Start() {
  g_in_use.store(0, std::memory_order_relaxed);
  g_peak.store(0, std::memory_order_relaxed);
  g_allocs.store(0, std::memory_order_relaxed);
  g_allocated.store(0, std::memory_order_relaxed);
  g_active.store(true, std::memory_order_seq_cst);
}

void AllocationCounter::Stop(Result& result) {
  g_active.store(false, std::memory_order_seq_cst);
  result.num_allocs = g_allocs.load(std::memory_order_relaxed);
  result.max_bytes_used = g_peak.load(std::memory_order_relaxed);
  result.total_allocated_bytes = g_allocated.load(std::memory_order_relaxed);
  result.net_heap_growth = g_in_use.load(std::memory_order_relaxed);
  peaks_.push_back(result.max_bytes_used);
}

std::vector<std::int64_t> AllocationCounter::take_peaks() {
  std::vector<std::int64_t> peaks;
  peaks.swap(peaks_);
  return peaks;
}

void AllocationCounter::Stop(Result* result) { Stop(*result); }

int run_benchmarks(int argc, char** argv) {
  // Read before Initialize, which removes the flags it knows from argv. The library makes its own
  // reporter for another --benchmark_format; the console one is replaced, honouring its two options.
  const std::string format = flag(argc, argv, "benchmark_format");
  const std::string color = flag(argc, argv, "benchmark_color");
  const bool tabular = is_true(flag(argc, argv, "benchmark_counters_tabular"));
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  static AllocationCounter counter;
  benchmark::RegisterMemoryManager(&counter);
  if (!format.empty() && format != "console") {
    benchmark::RunSpecifiedBenchmarks();
  } else {
    const bool use_color = is_true(color) || (!is_false(color) && isatty(fileno(stdout)) != 0);
    int options = benchmark::ConsoleReporter::OO_None;
    if (use_color) options |= benchmark::ConsoleReporter::OO_Color;
    if (tabular) options |= benchmark::ConsoleReporter::OO_Tabular;
    MemoryConsoleReporter reporter(static_cast<benchmark::ConsoleReporter::OutputOptions>(options), counter);
    benchmark::RunSpecifiedBenchmarks(&reporter);
  }
  benchmark::RegisterMemoryManager(nullptr);
  benchmark::Shutdown();
  return 0;
}

}  // namespace fleetslam::bench

// Replacement global allocation functions ([new.delete]): every form, so that no allocation escapes
// the count and every block is released by the matching deallocation.
void* operator new(std::size_t n) { return fleetslam::bench::allocate(n, fleetslam::bench::kDefault); }
void* operator new[](std::size_t n) { return fleetslam::bench::allocate(n, fleetslam::bench::kDefault); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return fleetslam::bench::allocate_nothrow(n, fleetslam::bench::kDefault);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  return fleetslam::bench::allocate_nothrow(n, fleetslam::bench::kDefault);
}
void* operator new(std::size_t n, std::align_val_t a) {
  return fleetslam::bench::allocate(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a) {
  return fleetslam::bench::allocate(n, static_cast<std::size_t>(a));
}
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return fleetslam::bench::allocate_nothrow(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return fleetslam::bench::allocate_nothrow(n, static_cast<std::size_t>(a));
}

void operator delete(void* p) noexcept { fleetslam::bench::release(p); }
void operator delete[](void* p) noexcept { fleetslam::bench::release(p); }
void operator delete(void* p, std::size_t) noexcept { fleetslam::bench::release(p); }
void operator delete[](void* p, std::size_t) noexcept { fleetslam::bench::release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { fleetslam::bench::release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { fleetslam::bench::release(p); }
void operator delete(void* p, std::align_val_t) noexcept { fleetslam::bench::release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { fleetslam::bench::release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { fleetslam::bench::release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { fleetslam::bench::release(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { fleetslam::bench::release(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { fleetslam::bench::release(p); }
