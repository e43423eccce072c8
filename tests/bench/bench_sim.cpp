// Camera frames per second of the simulator's full sensor pipeline (physics between ticks, RGB +
// metric depth, image and depth noise, IMU, ground truth) against bare mjr_render + mjr_readPixels of
// the same scene and camera, and the noise models alone on one rendered frame. Usage:
//   bench_sim [--scenario scenes/office/office_2robots.yaml] [google-benchmark flags]
// The first robot's camera is measured; its resolution is the scenario's (override: --width/--height).
// Time is wall time (llvmpipe renders on its own threads); CPU is the main thread's: the pipeline's
// CPU minus the bare render's is the sensor pipeline's own cost on the main thread (the noise models
// expand their Gaussian draws on another thread while the image renders, not counted there). The pipeline reads the offscreen
// buffer in llvmpipe's own formats (see sim/src/renderer.cpp); BM_BareRender/packed:1 is the bare
// render with that readback, for the overhead of everything else. On a shared machine run with
//   --benchmark_repetitions=6 --benchmark_enable_random_interleaving=true
// (repetitions interleaved, so a slow spell hits every benchmark alike): the "_min" rows are the best
// estimates of the undisturbed costs, the "_median" rows the typical ones.

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES
#endif
#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include "fleetslam/sim/scenario.hpp"
#include "fleetslam/sim/sensor_noise.hpp"
#include "fleetslam/sim/world.hpp"
#include "memory_counter.hpp"

namespace {

std::string g_scenario = FLEETSLAM_SOURCE_DIR "/scenes/office/office_2robots.yaml";
int g_width = 0;
int g_height = 0;

fleetslam::sim::ScenarioConfig one_robot_scenario(bool noise = true) {
  auto scenario = fleetslam::sim::load_scenario(g_scenario);
  scenario.robots.resize(1);
  scenario.robots[0].camera.image_noise.enabled = noise && scenario.robots[0].camera.image_noise.enabled;
  scenario.robots[0].camera.depth_noise.enabled = noise && scenario.robots[0].camera.depth_noise.enabled;
  if (g_width > 0) scenario.robots[0].camera.width = g_width;
  if (g_height > 0) scenario.robots[0].camera.height = g_height;
  scenario.duration_s = 1e5;
  return scenario;
}

double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

// OpenCV's thread count for a scope.
class OpenCvThreads {
 public:
  explicit OpenCvThreads(int threads) : previous_(cv::getNumThreads()) { cv::setNumThreads(threads); }
  ~OpenCvThreads() { cv::setNumThreads(previous_); }
  OpenCvThreads(const OpenCvThreads&) = delete;
  OpenCvThreads& operator=(const OpenCvThreads&) = delete;

 private:
  int previous_;
};

// The full pipeline: World::step() renders one frame per call (one robot); range(0) = noise models on,
// range(1) = OpenCV's thread count (the renderer's row work and the noise models' row bands).
void BM_SensorPipeline(benchmark::State& state) {
  const OpenCvThreads threads(static_cast<int>(state.range(1)));
  fleetslam::sim::World world(one_robot_scenario(state.range(0) != 0), nullptr);
  for (auto _ : state) {
    auto frames = world.step();
    benchmark::DoNotOptimize(frames);
  }
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// Bare rendering: the scene with one fixed camera placed where the robot's camera starts. range(0) = 0:
// mjr_readPixels (RGB bytes, float depth); 1: glReadPixels in the formats the pipeline reads (BGRA
// bytes, packed 24-bit depth and stencil), without the pipeline's conversions.
void BM_BareRender(benchmark::State& state) {
  const bool packed = state.range(0) != 0;
  const auto scenario = one_robot_scenario();
  fleetslam::sim::World world(scenario, nullptr);  // for the camera's start pose only
  const auto& camera = scenario.robots[0].camera;
  const Eigen::Isometry3d T_world_cam = world.truth(0).T_world_body * world.T_body_cam(0);
  const Eigen::Matrix3d R_mj = T_world_cam.linear() * Eigen::Vector3d(1, -1, -1).asDiagonal();
  const Eigen::Quaterniond q(R_mj);
  const Eigen::Vector3d p = T_world_cam.translation();
  const std::string scene = std::filesystem::absolute(scenario.scene_path()).string();
  const std::string xml = "<mujoco><include file=\"" + scenario.scene_path().filename().string() +
                          "\"/><visual><global offwidth=\"" + std::to_string(camera.width) + "\" offheight=\"" +
                          std::to_string(camera.height) + "\"/><quality offsamples=\"0\"/></visual><worldbody>" +
                          "<camera name=\"bench\" pos=\"" + std::to_string(p.x()) + " " + std::to_string(p.y()) +
                          " " + std::to_string(p.z()) + "\" quat=\"" + std::to_string(q.w()) + " " +
                          std::to_string(q.x()) + " " + std::to_string(q.y()) + " " + std::to_string(q.z()) +
                          "\" fovy=\"" + std::to_string(camera.fovy_deg) + "\"/></worldbody></mujoco>";
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const std::string name = std::filesystem::path(scene).parent_path().string() + "/__bench.xml";
  mj_makeEmptyFileVFS(vfs.get(), name.c_str(), static_cast<int>(xml.size()));
  std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), name.c_str())], xml.data(), xml.size());
  char error[1000] = "";
  mjModel* m = mj_loadXML(name.c_str(), vfs.get(), error, sizeof error);
  mj_deleteVFS(vfs.get());
  if (m == nullptr) {
    state.SkipWithError(error);
    return;
  }
  mjData* d = mj_makeData(m);
  mj_forward(m, d);
  OSMesaContext gl = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  std::vector<unsigned char> buffer(static_cast<std::size_t>(camera.width) * camera.height * 4);
  OSMesaMakeCurrent(gl, buffer.data(), GL_UNSIGNED_BYTE, camera.width, camera.height);
  mjvScene scn;
  mjv_defaultScene(&scn);
  mjv_makeScene(m, &scn, 4000);
  mjrContext con;
  mjr_defaultContext(&con);
  mjr_makeContext(m, &con, mjFONTSCALE_100);
  mjr_setBuffer(mjFB_OFFSCREEN, &con);
  mjvOption opt;
  mjv_defaultOption(&opt);
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FIXED;
  cam.fixedcamid = mj_name2id(m, mjOBJ_CAMERA, "bench");
  const mjrRect viewport{0, 0, camera.width, camera.height};
  std::vector<unsigned char> rgb(static_cast<std::size_t>(camera.width) * camera.height * 3);
  std::vector<float> depth(static_cast<std::size_t>(camera.width) * camera.height);
  std::vector<unsigned char> bgra(static_cast<std::size_t>(camera.width) * camera.height * 4);
  std::vector<std::uint32_t> depth_stencil(static_cast<std::size_t>(camera.width) * camera.height);
  for (auto _ : state) {
    mjv_updateScene(m, d, &opt, nullptr, &cam, mjCAT_ALL, &scn);
    scn.flags[mjRND_SHADOW] = camera.shadows ? 1 : 0;
    mjr_render(viewport, &scn, &con);
    if (packed) {
      glBindFramebuffer(GL_READ_FRAMEBUFFER, con.offFBO);
      glReadBuffer(GL_COLOR_ATTACHMENT0);
      glReadPixels(0, 0, camera.width, camera.height, GL_BGRA, GL_UNSIGNED_BYTE, bgra.data());
      glReadPixels(0, 0, camera.width, camera.height, GL_DEPTH_STENCIL, GL_UNSIGNED_INT_24_8, depth_stencil.data());
      benchmark::DoNotOptimize(bgra.data());
    } else {
      mjr_readPixels(rgb.data(), depth.data(), viewport, &con);
      benchmark::DoNotOptimize(rgb.data());
    }
  }
  state.counters["frames_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  mjr_freeContext(&con);
  mjv_freeScene(&scn);
  OSMesaDestroyContext(gl);
  mj_deleteData(d);
  mj_deleteModel(m);
}

// The first frame of the first robot's camera without noise, and its intrinsics.
struct CleanFrame {
  cv::Mat bgr;
  cv::Mat depth_m;
  fleetslam::core::PinholeCamera camera;
};

const CleanFrame& clean_frame() {
  static const CleanFrame frame = [] {
    fleetslam::sim::World world(one_robot_scenario(false), nullptr);
    const auto frames = world.step();
    return CleanFrame{frames.at(0).image, frames.at(0).depth_m, world.sensor_rig(0).cam0};
  }();
  return frame;
}

// The noise models alone on a rendered frame, with the scenario's settings (main thread only).
// range(0): OpenCV's thread count (the models draw their row bands on its pool).
void BM_DepthNoise(benchmark::State& state) {
  const CleanFrame& frame = clean_frame();
  const OpenCvThreads threads(static_cast<int>(state.range(0)));
  if (frame.depth_m.empty()) {
    state.SkipWithError("the scenario's first camera has no depth");
    return;
  }
  fleetslam::sim::DepthNoiseModel model(one_robot_scenario().robots[0].camera.depth_noise, 1);
  for (auto _ : state) {
    cv::Mat noisy = model.apply(frame.depth_m, frame.camera);
    benchmark::DoNotOptimize(noisy.data);
  }
}

void BM_ImageNoise(benchmark::State& state) {
  const CleanFrame& frame = clean_frame();
  const OpenCvThreads threads(static_cast<int>(state.range(0)));
  fleetslam::sim::ImageNoiseModel model(one_robot_scenario().robots[0].camera.image_noise, 1);
  fleetslam::core::TimeNs t_ns = 0;
  for (auto _ : state) {
    cv::Mat noisy = model.apply(frame.bgr, t_ns);
    benchmark::DoNotOptimize(noisy.data);
    t_ns += 33'333'333;
  }
}

}  // namespace

// Real time: llvmpipe renders on its own threads, which the main thread's CPU time does not see.
BENCHMARK(BM_BareRender)->ArgName("packed")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(3.0)->UseRealTime()->ComputeStatistics("min", min_of);
BENCHMARK(BM_SensorPipeline)
    ->ArgNames({"noise", "threads"})
    ->Args({0, 1})
    ->Args({0, 2})
    ->Args({1, 1})
    ->Args({1, 2})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(3.0)
    ->UseRealTime()
    ->ComputeStatistics("min", min_of);
BENCHMARK(BM_DepthNoise)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->ComputeStatistics("min", min_of);
BENCHMARK(BM_ImageNoise)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->ComputeStatistics("min", min_of);

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--scenario" && i + 1 < argc) {
      g_scenario = argv[++i];
    } else if (arg == "--width" && i + 1 < argc) {
      g_width = std::stoi(argv[++i]);
    } else if (arg == "--height" && i + 1 < argc) {
      g_height = std::stoi(argv[++i]);
    } else {
      rest.push_back(argv[i]);
    }
  }
  int rest_count = static_cast<int>(rest.size());
  return fleetslam::bench::run_benchmarks(rest_count, rest.data());
}
