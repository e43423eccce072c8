// The committed scenes (scenes/): every MJCF file loads with MuJoCo, directly and through a wrapper model
// beside it (as the World composes its scenario model), stays static and shadow-free, finds all its
// textures; the scenario files parse and start their robots in free space, on routes that stay free; the
// committed textures are what the generator writes.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fleetslam/sim/scenario.hpp"

namespace fs = std::filesystem;
using fleetslam::sim::RobotType;

namespace {

const fs::path kScenes = fs::path(FLEETSLAM_SOURCE_DIR) / "scenes";

struct SceneCase {
  const char* scene;      // relative to scenes/
  const char* scenario;   // relative to scenes/
  bool routes_are_loops;  // every robot comes back near its start
};

const SceneCase kCases[] = {
    {"office/office.xml", "office/office_2robots.yaml", true},
    {"apartment/apartment.xml", "apartment/apartment_3robots.yaml", true},
    {"warehouse/warehouse.xml", "warehouse/warehouse_2robots.yaml", true},
};

// MuJoCo's default error handler waits for Enter on stdin: throw instead, and keep warnings.
std::vector<std::string>& warnings() {
  static std::vector<std::string> list;
  return list;
}
void throw_mujoco_error(const char* message) { throw std::runtime_error(message); }
void keep_mujoco_warning(const char* message) { warnings().emplace_back(message); }

class MujocoHandlers : public ::testing::Environment {
 public:
  void SetUp() override {
    mju_user_error = throw_mujoco_error;
    mju_user_warning = keep_mujoco_warning;
  }
};
const auto* const kHandlers = ::testing::AddGlobalTestEnvironment(new MujocoHandlers);

using ModelPtr = std::unique_ptr<mjModel, decltype(&mj_deleteModel)>;
using DataPtr = std::unique_ptr<mjData, decltype(&mj_deleteData)>;

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

ModelPtr load_file(const fs::path& file, std::string* error) {
  char buffer[1000] = "";
  mjModel* model = mj_loadXML(file.string().c_str(), nullptr, buffer, sizeof buffer);
  *error = buffer;
  return ModelPtr(model, mj_deleteModel);
}

// Loads `xml` as a virtual file at `virtual_path`: MuJoCo resolves its <include> and the included
// scene's asset files relative to that folder, which is how the World loads its wrapper model.
ModelPtr load_string(const std::string& xml, const fs::path& virtual_path, std::string* error) {
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  const std::string name = virtual_path.string();
  if (mj_makeEmptyFileVFS(&vfs, name.c_str(), static_cast<int>(xml.size())) != 0) {
    *error = "cannot create the VFS file";
    return ModelPtr(nullptr, mj_deleteModel);
  }
  const int index = mj_findFileVFS(&vfs, name.c_str());
  std::memcpy(vfs.filedata[index], xml.data(), xml.size());
  char buffer[1000] = "";
  mjModel* model = mj_loadXML(name.c_str(), &vfs, buffer, sizeof buffer);
  mj_deleteVFS(&vfs);
  *error = buffer;
  return ModelPtr(model, mj_deleteModel);
}

// A wrapper like the World's: the scene included by file name, a <visual> section, a robot with joints.
std::string wrapper_xml(const std::string& scene_file_name, const std::string& extra_bodies = "") {
  return "<mujoco model=\"test_wrapper\">\n"
         "  <include file=\"" + scene_file_name + "\"/>\n"
         "  <visual><global offwidth=\"640\" offheight=\"480\"/><quality offsamples=\"0\"/></visual>\n"
         "  <worldbody>\n" + extra_bodies +
         "  </worldbody>\n"
         "</mujoco>\n";
}

std::vector<std::string> texture_files(const std::string& scene_xml) {
  std::vector<std::string> files;
  const std::regex attribute(R"re(file\s*=\s*"([^"]+)")re");
  for (auto it = std::sregex_iterator(scene_xml.begin(), scene_xml.end(), attribute); it != std::sregex_iterator();
       ++it) {
    files.push_back((*it)[1].str());
  }
  return files;
}

std::string geom_name(const mjModel* m, int id) {
  const char* name = mj_id2name(m, mjOBJ_GEOM, id);
  return name ? name : "geom #" + std::to_string(id);
}

// Scene plus two probe bodies on free joints: a cylinder of radius 0.4 m covering a ground robot's height
// (0.05..0.5 m), a sphere of radius 0.3 m for a hand-held rig. A probe touching a scene geom (decorations
// without collision excepted) is not in free space.
class FreeSpaceProbe {
 public:
  static constexpr double kGroundRadius = 0.4;
  static constexpr double kRigRadius = 0.3;

  explicit FreeSpaceProbe(const fs::path& scene) : model_(nullptr, mj_deleteModel), data_(nullptr, mj_deleteData) {
    const std::string bodies =
        "    <body name=\"probe_ground\" pos=\"0 0 50\"><freejoint/>"
        "<geom name=\"probe_ground\" type=\"cylinder\" size=\"0.4 0.225\"/></body>\n"
        "    <body name=\"probe_rig\" pos=\"0 0 60\"><freejoint/><geom name=\"probe_rig\" type=\"sphere\" size=\"0.3\"/></body>\n";
    std::string error;
    model_ = load_string(wrapper_xml(scene.filename().string(), bodies), scene.parent_path() / "__test_probe.xml",
                         &error);
    if (!model_) throw std::runtime_error("probe model: " + error);
    data_ = DataPtr(mj_makeData(model_.get()), mj_deleteData);
    ground_ = mj_name2id(model_.get(), mjOBJ_GEOM, "probe_ground");
    rig_ = mj_name2id(model_.get(), mjOBJ_GEOM, "probe_rig");
  }

  // Names of the scene geoms the ground probe touches at (x, y); empty when free.
  std::string ground_hits(double x, double y) { return hits(ground_, x, y, 0.275); }
  // Names of the scene geoms the rig probe touches at (x, y, z); empty when free.
  std::string rig_hits(double x, double y, double z) { return hits(rig_, x, y, z); }

 private:
  std::string hits(int geom, double x, double y, double z) {
    const mjModel* m = model_.get();
    mjData* d = data_.get();
    mj_resetData(m, d);
    for (int probe : {ground_, rig_}) {
      const int adr = m->jnt_qposadr[m->body_jntadr[m->geom_bodyid[probe]]];
      const double park_z = probe == ground_ ? 50.0 : 60.0;
      const double p[7] = {probe == geom ? x : 0.0, probe == geom ? y : 0.0, probe == geom ? z : park_z, 1, 0, 0, 0};
      for (int k = 0; k < 7; ++k) d->qpos[adr + k] = p[k];
    }
    mj_forward(m, d);
    std::set<std::string> names;
    for (int i = 0; i < d->ncon; ++i) {
      const mjContact& c = d->contact[i];
      if (c.geom1 == geom && c.geom2 != ground_ && c.geom2 != rig_) names.insert(geom_name(m, c.geom2));
      if (c.geom2 == geom && c.geom1 != ground_ && c.geom1 != rig_) names.insert(geom_name(m, c.geom1));
    }
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    return list;
  }

  ModelPtr model_;
  DataPtr data_;
  int ground_ = -1;
  int rig_ = -1;
};

class SceneTest : public ::testing::TestWithParam<SceneCase> {};

TEST_P(SceneTest, TexturesExistAndDecode) {
  const fs::path scene = kScenes / GetParam().scene;
  ASSERT_TRUE(fs::is_regular_file(scene)) << scene;
  const auto files = texture_files(read_text(scene));
  ASSERT_FALSE(files.empty());
  for (const std::string& file : files) {
    const fs::path path = scene.parent_path() / file;
    ASSERT_TRUE(fs::is_regular_file(path)) << scene.filename() << " refers to missing " << path;
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(image.empty()) << path << " does not decode";
    EXPECT_LE(std::max(image.cols, image.rows), 2048) << path;
  }
}

TEST_P(SceneTest, LoadsDirectlyStaticAndShadowFree) {
  const fs::path scene = kScenes / GetParam().scene;
  std::string error;
  warnings().clear();
  const ModelPtr model = load_file(scene, &error);
  ASSERT_TRUE(model) << error;
  const mjModel* m = model.get();
  EXPECT_TRUE(warnings().empty()) << warnings().front();
  // Static geometry only: no joints, every geom in the world body, no mocap or moving bodies.
  EXPECT_EQ(m->njnt, 0);
  EXPECT_EQ(m->nbody, 1);
  for (int g = 0; g < m->ngeom; ++g) EXPECT_EQ(m->geom_bodyid[g], 0) << geom_name(m, g);
  // Hundreds of geoms, not thousands, so that llvmpipe renders quickly.
  EXPECT_GE(m->ngeom, 50);
  EXPECT_LE(m->ngeom, 1000);
  // Lights without shadows (a shadow costs ~20 ms per frame), few enough for fixed-function OpenGL.
  EXPECT_GE(m->nlight, 1);
  EXPECT_LE(m->nlight, 6);
  for (int l = 0; l < m->nlight; ++l) EXPECT_EQ(m->light_castshadow[l], 0) << "light " << l;
  // The scene leaves the offscreen buffer and multisampling to the World (MuJoCo defaults untouched).
  EXPECT_EQ(m->vis.global.offwidth, 640);
  EXPECT_EQ(m->vis.global.offheight, 480);
  EXPECT_EQ(m->vis.quality.offsamples, 4);
  // Every texture file became a texture; a floor plane lies at z = 0 facing up.
  const auto files = texture_files(read_text(scene));
  EXPECT_EQ(m->ntex, static_cast<int>(std::set<std::string>(files.begin(), files.end()).size()));
  DataPtr data(mj_makeData(m), mj_deleteData);
  mj_forward(m, data.get());
  bool floor = false;
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_type[g] != mjGEOM_PLANE) continue;
    const mjtNum* xpos = data->geom_xpos + 3 * g;
    const mjtNum* xmat = data->geom_xmat + 9 * g;
    floor = floor || (std::fabs(xpos[2]) < 1e-9 && xmat[8] > 0.999);
  }
  EXPECT_TRUE(floor) << "no upward plane at z = 0";
  // z up, floor at z = 0: nothing below the floor.
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_type[g] == mjGEOM_PLANE) continue;
    EXPECT_GE(data->geom_xpos[3 * g + 2] + m->geom_rbound[g], 0.0) << geom_name(m, g);
  }
}

TEST_P(SceneTest, LoadsThroughAWrapperBesideTheScene) {
  // The World writes a wrapper that includes the scene by file name and loads it from a virtual file in
  // the scene's folder, so that MuJoCo finds the scene and its ../textures/ files there.
  const fs::path scene = kScenes / GetParam().scene;
  const std::string robot =
      "    <body name=\"fs_robot\" pos=\"0 0 0\"><joint name=\"fs_robot_x\" type=\"slide\" axis=\"1 0 0\"/>"
      "<geom name=\"fs_robot_base\" type=\"cylinder\" size=\"0.2 0.08\" pos=\"0 0 0.1\"/>"
      "<camera name=\"fs_robot_cam\" pos=\"0.15 0 0.3\" xyaxes=\"0 -1 0 0 0 1\" fovy=\"45\"/></body>\n";
  std::string error;
  warnings().clear();
  const ModelPtr model =
      load_string(wrapper_xml(scene.filename().string(), robot), scene.parent_path() / "__test_wrapper.xml", &error);
  ASSERT_TRUE(model) << error;
  EXPECT_TRUE(warnings().empty()) << warnings().front();
  EXPECT_EQ(model->vis.global.offwidth, 640);
  EXPECT_EQ(model->vis.quality.offsamples, 0);
  EXPECT_EQ(model->ncam, 1);
  EXPECT_EQ(model->njnt, 1);
  // Relative asset paths resolve against the wrapper's folder, not the process's working directory.
  EXPECT_GT(model->ntex, 0);
}

TEST_P(SceneTest, ScenarioParsesAndItsRobotsStayInFreeSpace) {
  const SceneCase& c = GetParam();
  const fs::path scenario_file = kScenes / c.scenario;
  fleetslam::sim::ScenarioConfig scenario;
  ASSERT_NO_THROW(scenario = fleetslam::sim::load_scenario(scenario_file));
  EXPECT_TRUE(fs::equivalent(scenario.scene_path(), kScenes / c.scene)) << scenario.scene_path();
  ASSERT_GE(scenario.robots.size(), 2u);
  ASSERT_LE(scenario.robots.size(), 3u);

  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    for (std::size_t j = i + 1; j < scenario.robots.size(); ++j) {
      const auto& a = scenario.robots[i].initial_pose;
      const auto& b = scenario.robots[j].initial_pose;
      EXPECT_GE(std::hypot(a.x - b.x, a.y - b.y), 1.0)
          << scenario.robots[i].name << " and " << scenario.robots[j].name << " start too close";
    }
  }

  FreeSpaceProbe probe(kScenes / c.scene);
  // The probes do see the scene: every scene has walls along x = 0 and y = 0.
  ASSERT_NE(probe.ground_hits(0.1, 1.5), "");
  ASSERT_NE(probe.rig_hits(1.5, 0.1, 1.0), "");
  for (const auto& robot : scenario.robots) {
    const auto& start = robot.initial_pose;
    ASSERT_GE(robot.waypoints.size(), 2u) << robot.name;
    if (robot.type == RobotType::kDiffDrive) {
      EXPECT_EQ(start.z, 0.0) << robot.name;
      EXPECT_EQ(probe.ground_hits(start.x, start.y), "") << robot.name << " starts within "
                                                         << FreeSpaceProbe::kGroundRadius << " m of these";
      // The route, sampled every 5 cm from the start through every waypoint, keeps the same clearance.
      double px = start.x, py = start.y;
      for (std::size_t k = 0; k < robot.waypoints.size(); ++k) {
        const auto& w = robot.waypoints[k];
        const double length = std::hypot(w.x - px, w.y - py);
        const int steps = std::max(1, static_cast<int>(std::ceil(length / 0.05)));
        for (int s = 1; s <= steps; ++s) {
          const double x = px + (w.x - px) * s / steps, y = py + (w.y - py) * s / steps;
          const std::string hit = probe.ground_hits(x, y);
          ASSERT_EQ(hit, "") << robot.name << " route to waypoint " << k << " passes (" << x << ", " << y
                             << ") within " << FreeSpaceProbe::kGroundRadius << " m of these";
        }
        px = w.x;
        py = w.y;
      }
    } else {
      // Timed knots starting at the initial pose; straight lines between knots keep the rig free.
      const auto& first = robot.waypoints.front();
      EXPECT_EQ(first.t_s, 0.0) << robot.name;
      EXPECT_NEAR(std::hypot(first.x - start.x, first.y - start.y), 0.0, 1e-9) << robot.name;
      EXPECT_NEAR(first.z, start.z, 1e-9) << robot.name;
      for (std::size_t k = 1; k < robot.waypoints.size(); ++k) {
        const auto& a = robot.waypoints[k - 1];
        const auto& b = robot.waypoints[k];
        EXPECT_GT(b.t_s, a.t_s) << robot.name;
        // Hand-held speeds: under 1 m/s between knots.
        EXPECT_LT(std::hypot(b.x - a.x, b.y - a.y, b.z - a.z) / (b.t_s - a.t_s), 1.0) << robot.name << " knot " << k;
        for (int s = 0; s <= 20; ++s) {
          const double t = s / 20.0;
          const double x = a.x + (b.x - a.x) * t, y = a.y + (b.y - a.y) * t, z = a.z + (b.z - a.z) * t;
          ASSERT_EQ(probe.rig_hits(x, y, z), "") << robot.name << " between knots " << k - 1 << " and " << k;
        }
      }
    }
    if (c.routes_are_loops) {
      // Some waypoint in the second half of the route comes back near the start (loop closure).
      double closest = 1e9;
      for (std::size_t k = robot.waypoints.size() / 2; k < robot.waypoints.size(); ++k) {
        closest = std::min(closest, std::hypot(robot.waypoints[k].x - start.x, robot.waypoints[k].y - start.y));
      }
      EXPECT_LE(closest, 0.5) << robot.name << " does not come back to its start";
    }
  }
}

std::string scene_test_name(const ::testing::TestParamInfo<SceneCase>& param) {
  const std::string scene = param.param.scene;
  return scene.substr(0, scene.find('/'));
}

INSTANTIATE_TEST_SUITE_P(Scenes, SceneTest, ::testing::ValuesIn(kCases), scene_test_name);

TEST(SceneTextures, EveryTextureIsUsedAndTheFolderStaysSmall) {
  std::set<std::string> used;
  for (const SceneCase& c : kCases) {
    const fs::path scene = kScenes / c.scene;
    for (const auto& file : texture_files(read_text(scene))) {
      used.insert(fs::weakly_canonical(scene.parent_path() / file).filename().string());
    }
  }
  std::uintmax_t total = 0;
  for (const auto& entry : fs::directory_iterator(kScenes / "textures")) {
    if (entry.path().extension() != ".png") continue;
    total += entry.file_size();
    EXPECT_TRUE(used.count(entry.path().filename().string())) << entry.path() << " is not used by any scene";
  }
  EXPECT_LT(total, 7u * 1024u * 1024u) << "textures total " << total << " bytes";
}

TEST(SceneTextures, GeneratorReproducesTheCommittedFiles) {
#ifndef FLEETSLAM_MAKE_TEXTURES
  GTEST_SKIP() << "fleetslam_make_textures is not built";
#else
  const fs::path out = fs::temp_directory_path() / ("fleetslam_textures_" + std::to_string(::getpid()));
  fs::create_directories(out);
  // A few quick ones: a poster, a book shelf, a carton label, a sign, a wall.
  for (const std::string name : {"poster_5", "books_3", "carton_7", "sign_B2", "wall_blocks_C"}) {
    const std::string command =
        std::string("\"") + FLEETSLAM_MAKE_TEXTURES + "\" \"" + out.string() + "\" --only=" + name + " > /dev/null";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    const cv::Mat made = cv::imread((out / (name + ".png")).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat committed = cv::imread((kScenes / "textures" / (name + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(made.empty()) << name;
    ASSERT_FALSE(committed.empty()) << name;
    ASSERT_EQ(made.size(), committed.size()) << name;
    ASSERT_EQ(made.type(), committed.type()) << name;
    EXPECT_EQ(cv::norm(made, committed, cv::NORM_INF), 0.0) << name << " differs from the committed file";
  }
  // An unknown option is no output folder, and a filter that matches nothing is an error (exit 2).
  const std::string tool = std::string("\"") + FLEETSLAM_MAKE_TEXTURES + "\"";
  EXPECT_EQ(WEXITSTATUS(std::system((tool + " \"" + out.string() + "\" --verbose 2> /dev/null").c_str())), 2);
  EXPECT_EQ(WEXITSTATUS(std::system((tool + " \"" + out.string() + "\" --only=no_such_texture 2> /dev/null").c_str())), 2);
  EXPECT_FALSE(fs::exists(fs::path("--verbose")));
  fs::remove_all(out);
#endif
}

}  // namespace
