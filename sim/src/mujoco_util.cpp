#include "mujoco_util.hpp"

#include <cstring>

#include "fleetslam/core/error.hpp"

namespace fleetslam::sim::detail {
namespace {

thread_local std::vector<std::string> pending_warnings;

[[noreturn]] void throw_mujoco_error(const char* message) {
  throw Error(std::string("MuJoCo error: ") + message);
}

void queue_mujoco_warning(const char* message) { pending_warnings.emplace_back(message); }

struct VfsDeleter {
  void operator()(mjVFS* vfs) const {
    mj_deleteVFS(vfs);
    delete vfs;
  }
};

}  // namespace

void install_mujoco_handlers() {
  mju_user_error = throw_mujoco_error;
  mju_user_warning = queue_mujoco_warning;
}

std::vector<std::string> take_mujoco_warnings() {
  std::vector<std::string> out;
  out.swap(pending_warnings);
  return out;
}

ModelPtr load_model_from_string(const std::string& xml, const std::string& virtual_path,
                                const std::string& described_as) {
  install_mujoco_handlers();
  // mjVFS is a few MB of fixed arrays: heap only.
  std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), virtual_path.c_str(), static_cast<int>(xml.size())) != 0) {
    throw InputError(described_as, "cannot stage the model in MuJoCo's virtual file system");
  }
  const int index = mj_findFileVFS(vfs.get(), virtual_path.c_str());
  std::memcpy(vfs->filedata[index], xml.data(), xml.size());
  char error[1024] = "";
  mjModel* model = mj_loadXML(virtual_path.c_str(), vfs.get(), error, sizeof error);
  if (model == nullptr) throw InputError(described_as, std::string("MuJoCo cannot load the scene: ") + error);
  return ModelPtr(model);
}

}  // namespace fleetslam::sim::detail
