// Pose-only optimisation and local bundle adjustment on synthetic scenes (seeded): time per call.
//   bench_optimizer [google-benchmark flags]

#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "fleetslam/core/se3.hpp"
#include "fleetslam/slam/optimizer.hpp"
#include "memory_counter.hpp"

namespace {

using fleetslam::core::PinholeCamera;
using namespace fleetslam::slam;

const PinholeCamera kCamera(640, 480, 500.0, 500.0, 319.5, 239.5);
constexpr double kBf = 40.0;

Eigen::Vector3d random_point(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> xy(-2.0, 2.0);
  std::uniform_real_distribution<double> z(1.0, 5.0);
  return Eigen::Vector3d(xy(rng), xy(rng), z(rng));
}

Observation observe(const Eigen::Isometry3d& T_cam_world, const Eigen::Vector3d& p_world, std::mt19937_64& rng,
                    bool stereo) {
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Vector3d p = T_cam_world * p_world;
  Observation obs;
  obs.uv = *kCamera.project(p) + Eigen::Vector2d(noise(rng), noise(rng));
  if (stereo) obs.u_right = obs.uv.x() - kBf / p.z() + noise(rng);
  return obs;
}

void BM_OptimizePose(benchmark::State& state) {
  std::mt19937_64 rng(1);
  const Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  std::vector<PoseObservation> observations;
  for (int i = 0; i < state.range(0); ++i) {
    PoseObservation o;
    o.p_world = random_point(rng);
    o.obs = observe(T_cam_world, o.p_world, rng, i % 2 == 0);
    observations.push_back(o);
  }
  fleetslam::core::Vector6d delta;
  delta << 0.05, -0.03, 0.02, 0.03, -0.02, 0.04;
  const Eigen::Isometry3d initial = fleetslam::core::se3_exp(delta) * T_cam_world;
  for (auto _ : state) benchmark::DoNotOptimize(optimize_pose(kCamera, kBf, observations, initial, {}));
}

void BM_LocalBundleAdjustment(benchmark::State& state) {
  std::mt19937_64 rng(2);
  BaProblem problem;
  const int keyframes = 6;
  for (int k = 0; k < keyframes; ++k) {
    BaKeyframe kf;
    fleetslam::core::Vector6d xi;
    xi << 0.1 * k, 0.0, 0.0, 0.0, 0.02 * k, 0.0;
    kf.T_cam_world = fleetslam::core::se3_exp(xi);
    kf.fixed = k < 2;
    problem.keyframes.push_back(kf);
  }
  std::normal_distribution<double> jitter(0.0, 0.02);
  for (int i = 0; i < state.range(0); ++i) {
    const Eigen::Vector3d p = random_point(rng);
    problem.points_world.push_back(p + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng)));
    for (int k = 0; k < keyframes; ++k) {
      problem.observations.push_back({k, i, observe(problem.keyframes[k].T_cam_world, p, rng, true)});
    }
  }
  for (auto _ : state) benchmark::DoNotOptimize(bundle_adjust(kCamera, kBf, problem, {}));
}

}  // namespace

BENCHMARK(BM_OptimizePose)->Arg(100)->Arg(300)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LocalBundleAdjustment)->Arg(400)->Unit(benchmark::kMillisecond);
int main(int argc, char** argv) { return fleetslam::bench::run_benchmarks(argc, argv); }
