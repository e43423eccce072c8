#include "commands.hpp"

namespace fleetslam::tools {

void add_eval_command(CLI::App& app, const GlobalOptions& /*global*/) {
  app.add_subcommand("eval", "Evaluate an estimated trajectory against ground truth (ATE, RPE)");
}

}  // namespace fleetslam::tools
