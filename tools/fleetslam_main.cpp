// The fleetslam command line: thin parsing over the libraries; each command lives in its own file.

#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "fleetslam/core/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"fleetslam: a multi-robot visual SLAM testbed"};
  app.require_subcommand(1);
  // -q and -v may also come after the command (subcommands created below pass options they lack up).
  app.fallthrough();
  fleetslam::tools::GlobalOptions global;
  app.add_flag("-v,--verbose", global.verbose, "More log output");
  app.add_flag("-q,--quiet", global.quiet, "Only warnings and errors");

  fleetslam::tools::add_eval_command(app, global);
  fleetslam::tools::add_experiment_command(app, global);
  fleetslam::tools::add_dataset_command(app, global);
  fleetslam::tools::add_generate_command(app, global);
  fleetslam::tools::add_replay_command(app, global);
  fleetslam::tools::add_run_command(app, global);
  fleetslam::tools::add_vocab_command(app, global);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help exits 0; every usage error (missing, unknown or out-of-range option) is bad input: 2, as the
    // README promises (CLI11's own codes run from 100 up).
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const fleetslam::tools::CriteriaFailed& e) {
    std::cerr << "fleetslam: " << e.what() << "\n";
    return 1;
  } catch (const fleetslam::InputError& e) {
    std::cerr << "fleetslam: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "fleetslam: internal error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
