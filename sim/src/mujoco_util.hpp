#pragma once
// Internal: owning handles and loading for MuJoCo (only sim/src includes MuJoCo).

#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

namespace fleetslam::sim::detail {

struct ModelDeleter {
  void operator()(mjModel* model) const { mj_deleteModel(model); }
};
struct DataDeleter {
  void operator()(mjData* data) const { mj_deleteData(data); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// MuJoCo reports errors through process-wide function pointers (its API offers nothing else). The
// handlers installed here turn mju_error into a fleetslam::Error exception (the default handler
// exits, and may wait on stdin) and queue warnings per thread for the caller to log. Idempotent.
void install_mujoco_handlers();
std::vector<std::string> take_mujoco_warnings();

// Compiles MJCF text held in memory as if it were the file `virtual_path`: includes and asset files
// resolve relative to that path's folder. `described_as` names the input in error messages.
ModelPtr load_model_from_string(const std::string& xml, const std::string& virtual_path,
                                const std::string& described_as);

}  // namespace fleetslam::sim::detail
