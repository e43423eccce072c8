#include "commands.hpp"

namespace fleetslam::tools {

void add_dataset_command(CLI::App& app, const GlobalOptions& /*global*/) {
  app.add_subcommand("dataset", "Inspect or convert a TUM RGB-D / EuRoC / TUM-VI sequence");
}

}  // namespace fleetslam::tools
