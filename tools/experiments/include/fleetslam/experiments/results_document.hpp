#pragma once
// docs/RESULTS.md: the tables of one `fleetslam experiment all` run beside the paper's own (paper.md
// Tables 1-3), links to the plots (copied next to the document), the machine, date and exact command,
// and where ours and the paper's disagree, said from the numbers.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fleetslam/experiments/keyframes.hpp"
#include "fleetslam/experiments/matching.hpp"
#include "fleetslam/experiments/sampling.hpp"

namespace fleetslam::experiments {

// This machine as the document names it (Linux: /proc/cpuinfo, /etc/os-release, uname).
struct MachineInfo {
  std::string hostname;
  std::string cpu_model;
  int cpu_cores = 0;  // logical processors in /proc/cpuinfo
  std::string os;
  std::string kernel;
  std::string date_utc;  // YYYY-MM-DD HH:MM UTC

  static MachineInfo probe();
};

// The command line of this process (/proc/self/cmdline), arguments quoted where needed.
std::string current_command_line();

struct ResultsInput {
  MachineInfo machine;
  std::string command;
  std::vector<SequenceSpec> sequences;  // every sequence the run used
  std::optional<MatchingResult> matching;
  std::optional<KeyframesResult> keyframes;
  std::optional<SamplingResult> sampling;
  std::vector<std::filesystem::path> plots;  // SVGs to copy into <document folder>/results/ and link
  double total_seconds = 0.0;
};

// Writes the document to `file` and the plots to its folder's results/. Throws InputError when it cannot.
void write_results_document(const ResultsInput& input, const std::filesystem::path& file);

}  // namespace fleetslam::experiments
