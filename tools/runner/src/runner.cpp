// The closed loop of `fleetslam run` (runner.hpp).

#include "fleetslam/runner/runner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <spdlog/logger.h>
#include <spdlog/sinks/basic_file_sink.h>

#include "fleetslam/central/link.hpp"
#include "fleetslam/central/map_evaluation.hpp"
#include "fleetslam/central/server.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "fleetslam/core/trajectory.hpp"
#include "fleetslam/core/trajectory_metrics.hpp"
#include "fleetslam/runner/criteria.hpp"
#include "fleetslam/runner/mission.hpp"
#include "fleetslam/runner/outputs.hpp"
#include "fleetslam/runner/report_html.hpp"
#include "fleetslam/sim/world.hpp"
#include "fleetslam/slam/agent.hpp"

namespace fleetslam::runner {
namespace {

namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;

// The prior of a robot whose true first camera pose is T_true: shifted by (dx, dy, dz) in the world and
// turned by yaw about the world's vertical through the camera (so the error is what it says it is).
Eigen::Isometry3d perturbed_prior(const Eigen::Isometry3d& T_true, const std::vector<double>& e) {
  if (e.empty()) return T_true;
  Eigen::Isometry3d T = T_true;
  T.translation() += Eigen::Vector3d(e[0], e[1], e[2]);
  T.linear() = Eigen::AngleAxisd(e[3] * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * T_true.linear();
  return T;
}

nlohmann::json alignment_error_json(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return {{"translation_m", (estimate.translation() - truth.translation()).norm()},
          {"rotation_deg", core::rotation_angle_rad(estimate.linear().transpose() * truth.linear()) * 180.0 / kPi}};
}

nlohmann::json accuracy_json(const central::MapAccuracy& a) {
  return {{"map_points", a.map_points}, {"truth_points", a.truth_points}, {"far_points", a.far_points},
          {"mean_m", a.mean_m}, {"median_m", a.median_m}, {"p95_m", a.p95_m}, {"completeness", a.completeness}};
}

// The pose of a ground robot's body in the plane from its camera pose.
planners::Pose2d body_pose_2d(const Eigen::Isometry3d& T_world_cam, const Eigen::Isometry3d& T_body_cam) {
  const Eigen::Isometry3d T_world_body = T_world_cam * T_body_cam.inverse();
  const Eigen::Vector3d forward = T_world_body.linear().col(0);
  return {T_world_body.translation().x(), T_world_body.translation().y(), std::atan2(forward.y(), forward.x())};
}

// The files a run writes in its folder and in each robot's folder (central::Server::write_outputs and the
// ground truth). An earlier run's are removed first, so that what the folder holds afterwards is this
// run's: a stale occupancy.pgm, or the folder of a robot the new scenario does not have, read as this
// run's. Only these names are touched: a robot folder goes only when it held some of them and nothing else.
std::size_t remove_earlier_outputs(const fs::path& out) {
  const std::vector<std::string> run_files = {"scenario.yaml", "occupancy.pgm", "mission.json", "metrics.json",
                                              "report.html", "merged_map.ply", "merge.json"};
  const std::vector<std::string> robot_files = {"map.ply", "trajectory.txt", "trajectory_robot.txt", "groundtruth.txt"};
  std::size_t removed = remove_files_named(out, run_files);
  std::error_code ec;
  std::vector<fs::path> robot_folders;
  for (fs::directory_iterator it(out, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_directory(ec) || it->is_symlink(ec)) continue;
    bool only_robot_files = true;
    std::size_t files = 0;
    for (fs::directory_iterator f(it->path(), ec); !ec && f != end; f.increment(ec)) {
      only_robot_files = only_robot_files && f->is_regular_file(ec) && !f->is_symlink(ec) &&
                         std::count(robot_files.begin(), robot_files.end(), f->path().filename().string()) > 0;
      ++files;
    }
    if (!ec && only_robot_files && files > 0) robot_folders.push_back(it->path());  // an empty folder is the user's
    ec.clear();
  }
  for (const fs::path& folder : robot_folders) {
    removed += remove_files_named(folder, robot_files);
    fs::remove(folder, ec);  // empty now, unless something appeared meanwhile
  }
  return removed;
}

// A copy of `logger` that also writes to `file`.

core::Logger with_file_sink(const core::Logger& logger, const fs::path& file) {
  std::vector<spdlog::sink_ptr> sinks = logger->sinks();
  for (const spdlog::sink_ptr& sink : sinks) sink->set_level(std::max(sink->level(), logger->level()));
  try {
    auto sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(file.string(), true);
    sink->set_level(spdlog::level::info);
    sinks.push_back(sink);
  } catch (const spdlog::spdlog_ex& e) {
    throw InputError(file.string(), std::string("cannot open the log file: ") + e.what());
  }
  auto combined = std::make_shared<spdlog::logger>(logger->name(), sinks.begin(), sinks.end());
  combined->set_level(std::min(logger->level(), spdlog::level::info));
  return combined;
}

// The free floor a robot can reach, from the true surfaces: the denominator of coverage.
struct TruthFreeSpace {
  planners::OccupancyGrid grid;
  std::vector<std::uint8_t> reachable;  // per grid cell
  std::size_t cells = 0;
};

TruthFreeSpace truth_free_space(const planners::OccupancyGridConfig& base, const std::vector<Eigen::Vector3f>& surfaces,
                                const std::vector<Eigen::Vector2d>& starts) {
  planners::OccupancyGridConfig config = base;
  config.bounds_xy_m.clear();
  config.margin_m = 0.0;
  core::PointCloud cloud;
  for (const Eigen::Vector3f& p : surfaces) cloud.push_back(p);
  TruthFreeSpace truth{planners::OccupancyGrid(config), {}, 0};
  truth.grid.update(cloud);
  truth.reachable.assign(static_cast<std::size_t>(truth.grid.width()) * static_cast<std::size_t>(truth.grid.height()), 0);
  for (const Eigen::Vector2d& start : starts) {
    const std::optional<Eigen::Vector2d> from = planners::nearest_traversable(truth.grid, start, 0.5, planners::UnknownCells::kOccupied);
    if (!from) continue;
    const std::vector<double> d = truth.grid.geodesic_distances_m(*from, planners::UnknownCells::kOccupied);
    for (std::size_t i = 0; i < d.size(); ++i) truth.reachable[i] |= std::isfinite(d[i]) ? 1 : 0;
  }
  for (std::uint8_t r : truth.reachable) truth.cells += r;
  return truth;
}

// Share of the reachable true free floor that the planning grid has seen free.
double coverage(const TruthFreeSpace& truth, const planners::OccupancyGrid& estimate) {
  if (truth.cells == 0) return 0.0;
  std::size_t seen = 0;
  for (int y = 0; y < truth.grid.height(); ++y) {
    for (int x = 0; x < truth.grid.width(); ++x) {
      const planners::CellIndex cell{x, y};
      if (!truth.reachable[truth.grid.index(cell)]) continue;
      const std::optional<planners::CellIndex> e = estimate.cell_of(truth.grid.center_of(cell));
      if (e && estimate.state(*e) == planners::CellState::kFree) ++seen;
    }
  }
  return static_cast<double>(seen) / static_cast<double>(truth.cells);
}

// The grid as an 8-bit PGM (row 0 at the top = largest y): free white, occupied black, unknown grey.
void write_grid_pgm(const fs::path& file, const planners::OccupancyGrid& grid) {
  std::string text = "P5\n" + std::to_string(grid.width()) + " " + std::to_string(grid.height()) + "\n255\n";
  for (int y = grid.height() - 1; y >= 0; --y) {
    for (int x = 0; x < grid.width(); ++x) {
      const planners::CellState s = grid.state({x, y});
      text.push_back(static_cast<char>(s == planners::CellState::kFree ? 255 : s == planners::CellState::kOccupied ? 0 : 128));
    }
  }
  write_text_file(file, text);
}

struct RobotRun {
  std::string name;
  bool ground = false;
  std::unique_ptr<slam::Agent> agent;
  Eigen::Isometry3d T_body_cam = Eigen::Isometry3d::Identity();
  core::Trajectory groundtruth;
  std::optional<Eigen::Isometry3d> T_world_robot_true;  // the camera's true pose at its first frame
  Eigen::Isometry3d T_world_robot_prior = Eigen::Isometry3d::Identity();
  std::size_t frames = 0, tracked = 0, lost = 0, relocalizations = 0, keyframes = 0;
  bool tracking = false;
  std::optional<Eigen::Isometry3d> T_map_cam;  // the agent's latest camera pose in its own map
  int map_component = 0;                       // ... and the map component it belongs to
  std::string tracking_state = "waiting";
  nlohmann::json loops = nlohmann::json::array();
  nlohmann::json keyframe_decisions = nlohmann::json::array();  // [t_s, score, inserted]
  std::vector<double> tracking_ms, mapping_ms, dense_ms, loop_ms, total_ms;
  int collisions = 0;        // times it started touching the scene or another robot
  double contact_s = 0.0;    // simulated time spent in contact (resolution: the world's steps, the sensor ticks)
  bool in_contact = false;
  nlohmann::json collision_events = nlohmann::json::array();
  // The mission judges goals from estimates: how far the true body was from the spot each goal reached by
  // proximity was accepted at (MissionRobotReport::reached_at_world).
  std::vector<double> reached_true_distance_m;
};

// Each frame through its robot's agent, in order: the updates, one per frame. With threads > 1 and
// frames of different robots, the robots' agents process them concurrently (each agent's frames still in
// order); agents share nothing mutable, and the updates come back in frame order either way.
std::vector<slam::AgentUpdate> process_frames(std::vector<RobotRun>& robots, const std::vector<core::SensorFrame>& frames,
                                              int threads) {
  std::vector<slam::AgentUpdate> updates(frames.size());
  // Frame indices per robot, robots in order of first appearance.
  std::vector<std::vector<std::size_t>> per_robot;
  std::vector<int> robot_of_group;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const auto it = std::find(robot_of_group.begin(), robot_of_group.end(), frames[f].robot_id);
    if (it == robot_of_group.end()) {
      robot_of_group.push_back(frames[f].robot_id);
      per_robot.push_back({f});
    } else {
      per_robot[static_cast<std::size_t>(it - robot_of_group.begin())].push_back(f);
    }
  }
  const auto run_group = [&](std::size_t g) {
    for (std::size_t f : per_robot[g]) {
      updates[f] = robots.at(static_cast<std::size_t>(frames[f].robot_id)).agent->process(frames[f]);
    }
  };
  const std::size_t workers = std::min(per_robot.size(), static_cast<std::size_t>(std::max(1, threads)));
  if (workers <= 1) {
    for (std::size_t g = 0; g < per_robot.size(); ++g) run_group(g);
    return updates;
  }
  // Groups g, g + workers, ... on worker w (worker 0 is this thread); an exception is rethrown here.
  std::vector<std::future<void>> running;
  const auto run_share = [&](std::size_t w) {
    for (std::size_t g = w; g < per_robot.size(); g += workers) run_group(g);
  };
  for (std::size_t w = 1; w < workers; ++w) running.push_back(std::async(std::launch::async, run_share, w));
  std::exception_ptr first_error;
  try {
    run_share(0);
  } catch (...) {
    first_error = std::current_exception();
  }
  for (std::future<void>& r : running) {
    try {
      r.get();
    } catch (...) {
      if (!first_error) first_error = std::current_exception();
    }
  }
  if (first_error) std::rethrow_exception(first_error);
  return updates;
}

}  // namespace

Runner::Runner(RunScenarioConfig config, RunnerOptions options, core::Logger logger)
    : config_(std::move(config)), options_(std::move(options)), logger_(logger ? std::move(logger) : core::null_logger()) {
  if (!options_.prior_error.empty() && options_.prior_error.size() != 4) {
    throw InputError("--prior-error", "needs 4 values: dx dy dz (m) yaw (deg)");
  }
  for (const double v : options_.prior_error) {
    if (!std::isfinite(v)) throw InputError("--prior-error", "values must be finite numbers");
  }
  create_output_folder(options_.out);
}

RunOutcome Runner::run(const ProgressSink& progress) {
  const fs::path out = options_.out;
  const std::size_t removed = remove_earlier_outputs(out);
  const core::Logger logger = with_file_sink(logger_, out / "run.log");
  if (removed > 0) logger->info("removed {} output file(s) of an earlier run from {}", removed, out.string());
  // The effective scenario runs again from the output folder: its scene path is absolute.
  RunScenarioConfig effective = config_;
  effective.world.scene = config_.world.absolute_scene_path().string();
  write_text_file(out / "scenario.yaml", core::config_to_yaml(effective));

  sim::World world(config_.world, logger);
  central::Server server(config_.central, logger);
  central::InProcessLink link;
  std::vector<RobotRun> robots(world.robot_count());
  std::vector<MissionRobot> mission_robots;
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const sim::RobotConfig& rc = world.robot_config(r);
    robots[r].name = rc.name;
    robots[r].ground = rc.type == sim::RobotType::kDiffDrive;
    slam::AgentConfig agent_config = config_.agent;
    if (robots[r].ground) {
      // A lost ground robot cannot have moved faster than its controller drives it: relocalisation's
      // reach follows the robot's limits, with half again as margin (a pose farther away is a repeated
      // texture elsewhere, not the robot).
      slam::RelocalizationConfig& reloc = agent_config.tracking.relocalization;
      constexpr double kDegreesPerRadian = 57.29577951308232;
      reloc.max_jump_m_per_s = std::min(reloc.max_jump_m_per_s, 1.5 * rc.controller.max_speed_mps);
      reloc.max_jump_deg_per_s = std::min(reloc.max_jump_deg_per_s, 1.5 * rc.controller.max_yaw_rate_radps * kDegreesPerRadian);
    }
    // The robot's agent logs under the robot's name (same sinks): "[bravo] frame 672 lost: ...".
    auto agent_logger = std::make_shared<spdlog::logger>(rc.name, logger->sinks().begin(), logger->sinks().end());
    agent_logger->set_level(logger->level());
    robots[r].agent = std::make_unique<slam::Agent>(agent_config, world.sensor_rig(r), agent_logger);
    robots[r].T_body_cam = world.T_body_cam(r);
    MissionRobot mr{rc.name, robots[r].ground, {}};
    for (const sim::WaypointConfig& w : rc.waypoints) mr.waypoints_world.emplace_back(w.x, w.y);
    mission_robots.push_back(std::move(mr));
  }
  // The deconfliction times every path at one speed: no faster than the slowest planned robot drives, or
  // its schedule would run ahead of that robot and check the robots' separation at the wrong places.
  // Likewise its turns, at the slowest robot's yaw rate (or the config's, when given and slower), and on the
  // spot from the smallest heading change that makes any planned robot's controller turn on the spot.
  PlanningConfig planning = config_.planner;
  double slowest_mps = std::numeric_limits<double>::infinity();
  double slowest_radps = std::numeric_limits<double>::infinity();
  double on_spot_deg = std::numeric_limits<double>::infinity();
  for (std::size_t r = 0; r < robots.size(); ++r) {
    if (!robots[r].ground) continue;
    const sim::PurePursuitConfig& controller = world.robot_config(r).controller;
    if (controller.max_speed_mps > 0.0) slowest_mps = std::min(slowest_mps, controller.max_speed_mps);
    if (controller.max_yaw_rate_radps > 0.0) slowest_radps = std::min(slowest_radps, controller.max_yaw_rate_radps);
    on_spot_deg = std::min(on_spot_deg, std::max(controller.rotate_in_place_deg, sim::PurePursuit::kMinRotateInPlaceDeg));
  }
  planners::DeconflictionConfig& deconfliction = planning.deconfliction;
  if (slowest_mps < deconfliction.speed_m_per_s) deconfliction.speed_m_per_s = slowest_mps;
  if (std::isfinite(slowest_radps) && (deconfliction.yaw_rate_radps == 0.0 || slowest_radps < deconfliction.yaw_rate_radps)) {
    deconfliction.yaw_rate_radps = slowest_radps;
  }
  if (on_spot_deg < deconfliction.turn_on_spot_deg) deconfliction.turn_on_spot_deg = on_spot_deg;
  if (config_.mission.kind != MissionKind::kScripted) {
    logger->info("deconfliction: paths timed at {:.3f} m/s, turns at {:.3f} rad/s, on the spot beyond {:.1f} deg "
                 "(planner.deconfliction, held to the planned robots' controller limits)",
                 deconfliction.speed_m_per_s, deconfliction.yaw_rate_radps, deconfliction.turn_on_spot_deg);
  }
  MissionPlanner mission(config_.mission, planning, mission_robots, logger);
  if (mission.planned()) {
    for (std::size_t r = 0; r < robots.size(); ++r) {
      if (robots[r].ground) world.set_path(r, {});  // they wait for the central unit's first plan
    }
  }
  // The truth that judges the run: the static scene's surfaces and the floor the robots can reach.
  const std::vector<Eigen::Vector3f> truth_surfaces = world.surface_points(options_.truth_spacing_m);
  std::vector<Eigen::Vector2d> starts;
  for (std::size_t r = 0; r < robots.size(); ++r) {
    if (robots[r].ground) starts.push_back(world.truth(r).T_world_body.translation().head<2>());
  }
  const TruthFreeSpace truth_space = truth_free_space(config_.planner.grid, truth_surfaces, starts);
  nlohmann::json coverage_series = nlohmann::json::array();
  double merge_ms_during_run = 0.0, mission_ms = 0.0;
  std::size_t mission_updates = 0;

  const auto wall_start = std::chrono::steady_clock::now();  // reported only (real-time factor)
  const auto wall_s = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count(); };
  double last_update_s = -1e9;
  double next_update_s = config_.mission.first_plan_s;
  double next_progress_s = 0.0;
  const double duration_s = core::ns_to_seconds(world.end_ns());

  const auto mission_update = [&](double t_s) {
    const auto t0 = std::chrono::steady_clock::now();
    const central::ServerMergeReport& merged = server.merge();
    merge_ms_during_run += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const auto t1 = std::chrono::steady_clock::now();
    std::vector<RobotObservation> seen(robots.size());
    for (std::size_t r = 0; r < robots.size(); ++r) {
      RobotObservation& o = seen[r];
      o.tracking = robots[r].tracking;
      o.path_done = robots[r].ground ? world.path_done(r) : true;
      if (!robots[r].T_world_robot_true) {  // its map has not started: no pose yet
        o.tracking = false;
        continue;
      }
      const core::Trajectory trajectory = server.world_trajectory(static_cast<int>(r));
      if (trajectory.empty()) {
        o.tracking = false;
        continue;
      }
      o.has_pose = true;
      o.pose_world = body_pose_2d(trajectory.back().T_world_body, robots[r].T_body_cam);
      Eigen::Vector2d last = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
      for (const core::StampedPose& p : trajectory) {
        const Eigen::Vector2d xy = body_pose_2d(p.T_world_body, robots[r].T_body_cam).xy();
        if (!((xy - last).norm() < 0.1)) {
          o.footprint_world.push_back(xy);
          last = xy;
        }
      }
    }
    // Where each keyframe's cloud was seen from, placed as the merge placed its robot: free-space carving.
    std::vector<planners::SensorView> views;
    for (std::size_t r = 0; r < robots.size() && config_.planner.grid.carve_rays; ++r) {
      if (!robots[r].T_world_robot_true) continue;
      for (const central::ServerKeyframe* kf : server.robot_keyframe_clouds(static_cast<int>(r))) {
        const Eigen::Isometry3d T_world_cam = server.T_world_component(static_cast<int>(r), kf->component) * kf->T_robot_cam;
        views.push_back({T_world_cam.translation().cast<float>(), core::transformed_points(kf->dense_cam.points, T_world_cam)});
      }
    }
    std::vector<std::size_t> reached_before(robots.size());
    for (std::size_t r = 0; r < robots.size(); ++r) reached_before[r] = mission.reports()[r].reached_at_world.size();
    for (const PathCommand& c : mission.update(t_s, merged.merge.cloud_world, seen, views)) world.set_path(c.robot, c.path_world);
    for (std::size_t r = 0; r < robots.size(); ++r) {
      // The truth against each spot the mission accepted from the estimate.
      const std::vector<Eigen::Vector2d>& reached_at = mission.reports()[r].reached_at_world;
      const Eigen::Vector2d true_xy = world.truth(r).T_world_body.translation().head<2>();
      for (std::size_t k = reached_before[r]; k < reached_at.size(); ++k) {
        robots[r].reached_true_distance_m.push_back((true_xy - reached_at[k]).norm());
      }
    }
    coverage_series.push_back({t_s, coverage(truth_space, mission.grid())});
    mission_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
    ++mission_updates;
    last_update_s = t_s;
  };

  double previous_step_s = core::ns_to_seconds(world.time_ns());  // contact time: simulated time between steps
  while (!world.finished()) {
    std::vector<core::SensorFrame> frames = world.step();
    for (core::SensorFrame& frame : frames) {
      RobotRun& robot = robots.at(static_cast<std::size_t>(frame.robot_id));
      FLEETSLAM_CHECK(frame.T_world_cam_gt.has_value(), "simulated frames carry ground truth");
      robot.groundtruth.push_back({frame.t_ns, *frame.T_world_cam_gt});
    }
    std::vector<slam::AgentUpdate> updates = process_frames(robots, frames, options_.threads);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      const core::SensorFrame& frame = frames[f];
      RobotRun& robot = robots.at(static_cast<std::size_t>(frame.robot_id));
      const double t_s = core::ns_to_seconds(frame.t_ns);
      slam::AgentUpdate& update = updates[f];
      // The robot's frame is its agent's world: cam0 of the frame that started its map, which need not be
      // its first frame (one without texture or depth starts none). Its prior and truth are that frame's.
      if (!robot.T_world_robot_true && update.status == slam::FrameStatus::kInitialized) {
        robot.T_world_robot_true = *frame.T_world_cam_gt;
        robot.T_world_robot_prior =
            frame.robot_id == 0 ? *frame.T_world_cam_gt : perturbed_prior(*frame.T_world_cam_gt, options_.prior_error);
        const sim::BodyCylinder body = world.body_cylinder(static_cast<std::size_t>(frame.robot_id));
        server.add_robot(central::RobotSpec{frame.robot_id, robot.name, robot.T_world_robot_prior,
                                            central::RobotBody{robot.T_body_cam.inverse(), body.radius_m, body.z_min_m, body.z_max_m}});
      }
      if (update.T_world_cam) {
        robot.T_map_cam = *update.T_world_cam;
        robot.map_component = update.component;
      }
      ++robot.frames;
      robot.tracking = update.has_pose();
      robot.tracked += update.has_pose() ? 1 : 0;
      robot.lost += update.status == slam::FrameStatus::kLost ? 1 : 0;
      robot.tracking_state = update.has_pose() ? "tracking" : update.status == slam::FrameStatus::kLost ? "lost" : "no pose";
      robot.relocalizations += update.relocalized ? 1 : 0;
      robot.keyframes += update.new_keyframes.size();
      for (const slam::LoopEvent& loop : update.loops) robot.loops.push_back(loop_event_json(loop));
      if (update.keyframe_decision) {
        robot.keyframe_decisions.push_back({t_s, update.keyframe_decision->score, update.keyframe_decision->insert ? 1 : 0});
      }
      robot.tracking_ms.push_back(update.timings.tracking_ms);
      robot.mapping_ms.push_back(update.timings.mapping_ms);
      robot.dense_ms.push_back(update.timings.dense_ms);
      robot.loop_ms.push_back(update.timings.loop_ms);
      robot.total_ms.push_back(update.timings.total_ms);
      if (robot.T_world_robot_true) link.send(std::move(update));  // before its map starts, nothing to send
    }
    server.integrate_all(link);
    const double t_s = core::ns_to_seconds(world.time_ns());
    const double step_s = t_s - previous_step_s;  // to the next sensor tick of any robot
    previous_step_s = t_s;
    for (std::size_t r = 0; r < robots.size(); ++r) {
      RobotRun& robot = robots[r];
      const sim::RobotTruth truth = world.truth(r);
      const bool contact = truth.contacts_with_scene > 0;
      if (contact && !robot.in_contact) {
        ++robot.collisions;
        const Eigen::Vector3d p = truth.T_world_body.translation();
        robot.collision_events.push_back({{"t_s", t_s}, {"x", p.x()}, {"y", p.y()}});
        logger->warn("run: {} touches the scene at {:.2f} s ({:.2f}, {:.2f})", robot.name, t_s, p.x(), p.y());
      }
      if (contact) robot.contact_s += step_s;
      robot.in_contact = contact;
    }
    // Early updates: a robot that finished its path with work left, or whose estimate reached its goal.
    bool early = false;
    for (std::size_t r = 0; r < robots.size(); ++r) {
      if (!robots[r].ground) continue;
      early = early || (world.path_done(r) && mission.wants_plan(r));
      const std::optional<Eigen::Vector2d> goal = mission.goal_of(r);
      if (goal && robots[r].T_map_cam) {
        // The robot's map component in the world as the central unit has it now (the last merge, else the prior).
        const Eigen::Isometry3d T_world_cam =
            server.T_world_component(static_cast<int>(r), robots[r].map_component) * *robots[r].T_map_cam;
        early = early || (body_pose_2d(T_world_cam, robots[r].T_body_cam).xy() - *goal).norm() <= config_.mission.goal_reached_m;
      }
    }
    if (t_s >= config_.mission.first_plan_s &&
        (t_s >= next_update_s || (early && t_s - last_update_s >= config_.mission.min_replan_interval_s))) {
      mission_update(t_s);
      next_update_s = t_s + config_.mission.replan_period_s;
    }
    if (progress && t_s >= next_progress_s) {
      RunProgress p{t_s, duration_s, 0.0, {}};
      const double w = wall_s();
      p.real_time_factor = w > 0.0 ? t_s / w : 0.0;
      for (std::size_t r = 0; r < robots.size(); ++r) {
        p.robot_states.push_back(robots[r].name + ": " + robots[r].tracking_state + ", " + mission.reports()[r].status);
      }
      progress(p);
      next_progress_s = t_s + 1.0;
    }
  }
  // The mapping workers' last changes (threaded mode) reach the server only through finish().
  for (RobotRun& robot : robots) {
    slam::AgentUpdate last = robot.agent->finish();
    if (robot.T_world_robot_true) link.send(std::move(last));
  }
  server.integrate_all(link);
  const double run_wall_s = wall_s();

  mission_update(core::ns_to_seconds(world.time_ns()));  // the final fused map: coverage, the last grid
  const central::ServerMergeReport& report = *server.last_merge();
  server.write_outputs(out);
  const central::MapAccuracy merged_accuracy = central::evaluate_map(report.merge.cloud_world, truth_surfaces);
  if (mission.grid().width() > 0) write_grid_pgm(out / "occupancy.pgm", mission.grid());

  nlohmann::json robots_json = nlohmann::json::array();
  nlohmann::json series_robots = nlohmann::json::array();
  for (std::size_t r = 0; r < robots.size(); ++r) {
    RobotRun& robot = robots[r];
    const int id = static_cast<int>(r);
    const MissionRobotReport& m = mission.reports()[r];
    nlohmann::json entry = {{"name", robot.name}, {"type", robot.ground ? "diff_drive" : "free_rig"},
                            {"status", robot.tracking_state + ", " + m.status}, {"frames", robot.frames},
                            {"tracked", robot.tracked}, {"lost", robot.lost}, {"relocalizations", robot.relocalizations},
                            {"keyframes", robot.keyframes}, {"loops", robot.loops},
                            {"loops_refused", loop_rejections_json(robot.agent->map_stats().loop_rejections)},
                            {"collisions", robot.collisions},
                            {"contact_s", robot.contact_s}, {"collision_events", robot.collision_events},
                            {"planned", mission.planned() && robot.ground}, {"goals_total", m.goals_total},
                            {"goals_reached", m.goals_reached}, {"goals_given_up", m.goals_given_up},
                            {"goals_reached_true_distance_m", robot.reached_true_distance_m},
                            {"plans", m.plans}, {"plan_failures", m.plan_failures}, {"mission_events", m.events},
                            {"timings_ms", {{"tracking", timing_stats_json(robot.tracking_ms)}, {"mapping", timing_stats_json(robot.mapping_ms)},
                                            {"dense", timing_stats_json(robot.dense_ms)}, {"loop", timing_stats_json(robot.loop_ms)},
                                            {"total", timing_stats_json(robot.total_ms)}}}};
    nlohmann::json series = {{"name", robot.name}, {"keyframe_decisions", robot.keyframe_decisions}};
    nlohmann::json plans = nlohmann::json::array();
    for (const PlanRecord& plan : m.plan_log) {
      nlohmann::json path = nlohmann::json::array();
      for (const Eigen::Vector2d& p : plan.path_world) path.push_back({p.x(), p.y()});
      plans.push_back({{"t_s", plan.t_s}, {"status", plan.status}, {"goal_xy", {plan.goal_world.x(), plan.goal_world.y()}}, {"path_xy", path}});
    }
    series["plans"] = plans;
    nlohmann::json goals = nlohmann::json::array();
    if (config_.mission.kind == MissionKind::kWaypoints && robot.ground) {
      for (const Eigen::Vector2d& g : mission_robots[r].waypoints_world) goals.push_back({g.x(), g.y()});
    } else {
      for (const PlanRecord& plan : m.plan_log) goals.push_back({plan.goal_world.x(), plan.goal_world.y()});
    }
    series["goals_xy"] = goals;
    if (robot.T_world_robot_true) {
      core::write_trajectory(out / robot.name / "groundtruth.txt", robot.groundtruth, core::TrajectoryFormat::kTum);
      const core::Trajectory world_trajectory = server.world_trajectory(id);
      for (const auto& [mode, key] : {std::pair{core::AlignmentMode::kNone, "ate_world_m"}, std::pair{core::AlignmentMode::kSe3, "ate_se3_m"}}) {
        const core::AteResult ate = core::compute_ate(robot.groundtruth, world_trajectory,
                                                      core::associate_by_time(robot.groundtruth, world_trajectory), mode);
        if (!ate.measured()) continue;
        entry[key] = {{"rmse", ate.stats.rmse}, {"mean", ate.stats.mean}, {"max", ate.stats.max}};
        if (mode != core::AlignmentMode::kNone) continue;
        nlohmann::json over_time = nlohmann::json::array();
        for (std::size_t i = 0; i < ate.errors_m.size(); ++i) over_time.push_back({core::ns_to_seconds(ate.t_ns[i]), ate.errors_m[i]});
        series["ate_over_time"] = over_time;
      }
      nlohmann::json estimated = nlohmann::json::array(), truth = nlohmann::json::array();
      for (const core::StampedPose& p : world_trajectory) {
        estimated.push_back({core::ns_to_seconds(p.t_ns), p.T_world_body.translation().x(), p.T_world_body.translation().y()});
      }
      for (const core::StampedPose& p : robot.groundtruth) {
        truth.push_back({core::ns_to_seconds(p.t_ns), p.T_world_body.translation().x(), p.T_world_body.translation().y()});
      }
      series["estimated_xy"] = estimated;
      series["truth_xy"] = truth;
      for (const central::RobotFusionReport& fused : report.robots) {
        if (fused.robot_id != id) continue;
        entry["merge_status"] = fused.merge_status;
        entry["prior_error"] = alignment_error_json(robot.T_world_robot_prior, *robot.T_world_robot_true);
        entry["refined_error"] = alignment_error_json(fused.T_world_robot, *robot.T_world_robot_true);
        entry["map_accuracy"] = accuracy_json(
            central::evaluate_map(server.world_cloud(id), truth_surfaces));
      }
    }
    robots_json.push_back(entry);
    series_robots.push_back(series);
  }
  nlohmann::json mission_json = {{"robots", nlohmann::json::array()}};
  for (std::size_t r = 0; r < robots.size(); ++r) {
    mission_json["robots"].push_back({{"name", robots[r].name}, {"events", mission.reports()[r].events},
                                      {"plans", series_robots[r]["plans"]}});
  }
  write_text_file(out / "mission.json", mission_json.dump(1) + "\n");
  const double sim_s = core::ns_to_seconds(world.time_ns());
  nlohmann::json metrics = {
      {"command", "fleetslam run"}, {"scenario", options_.scenario_name}, {"seed", config_.world.seed},
      {"mission", config_.mission.kind == MissionKind::kScripted ? "scripted"
                  : config_.mission.kind == MissionKind::kWaypoints ? "waypoints" : "explore"},
      {"simulated_s", sim_s}, {"wall_s", run_wall_s}, {"real_time_factor", run_wall_s > 0.0 ? sim_s / run_wall_s : 0.0},
      {"prior_error", options_.prior_error}, {"robots", robots_json},
      {"merged_map_accuracy", accuracy_json(merged_accuracy)},
      {"coverage", {{"final", coverage_series.empty() ? nlohmann::json() : coverage_series.back()[1]},
                    {"free_cells_truth", truth_space.cells}, {"cell_m", config_.planner.grid.resolution_m}}},
      {"mission_updates", mission_updates},
      {"central_timings_ms", {{"merges_during_run", merge_ms_during_run}, {"planning_and_coverage", mission_ms},
                              {"final_merge", report.merge.timings.total_ms}}},
      {"merge", central::to_json(report.merge)}};
  metrics["verdict"] = judge(config_.criteria, metrics);
  write_text_file(out / "metrics.json", metrics.dump(2) + "\n");

  // The report: the metrics plus the series, the merged map thinned for drawing.
  nlohmann::json map_points = nlohmann::json::array();
  const core::PointCloud& cloud = report.merge.cloud_world;
  const std::size_t step = std::max<std::size_t>(1, (cloud.size() + 29999) / 30000);
  for (std::size_t i = 0; i < cloud.size(); i += step) {
    const Eigen::Vector3f& p = cloud.points[i];
    const bool rgb = cloud.has_colors();
    map_points.push_back({p.x(), p.y(), p.z(), rgb ? cloud.colors[i][0] : 128, rgb ? cloud.colors[i][1] : 128,
                          rgb ? cloud.colors[i][2] : 128});
  }
  const nlohmann::json report_json = {
      {"title", "fleetslam run: " + options_.scenario_name}, {"metrics", metrics},
      {"series", {{"robots", series_robots}, {"coverage_over_time", coverage_series}, {"map_points", map_points}}}};
  write_report_html(out / "report.html", report_json);
  logger->info("run: verdict {}", metrics["verdict"]["passed"].get<bool>() ? "PASS" : "FAIL");
  return {metrics, metrics["verdict"]["passed"].get<bool>()};
}

}  // namespace fleetslam::runner
