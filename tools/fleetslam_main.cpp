// The fleetslam command line: thin parsing over the libraries; each command lives in its own file.

#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "fleetslam/core/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"fleetslam: a multi-robot visual SLAM testbed"};
  app.require_subcommand(1);
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
    return app.exit(e);
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
