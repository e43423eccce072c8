#include "fleetslam/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>
#include <spdlog/fmt/fmt.h>
#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "mjcf_builder.hpp"
#include "mujoco_util.hpp"
#include "renderer.hpp"
#include "surface_sampler.hpp"

namespace fleetslam::sim {
namespace {

// splitmix64: independent, reproducible seeds for each noise source of a robot.
std::uint64_t derive_seed(std::int64_t robot_seed, std::uint64_t stream) {
  std::uint64_t z = static_cast<std::uint64_t>(robot_seed) * 0x9E3779B97F4A7C15ULL + stream;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

constexpr double kNearPlaneM = 0.05;

enum NoiseStream : std::uint64_t { kImuStream = 1, kDepthStream = 2, kLeftImageStream = 3, kRightImageStream = 4 };

// The physics instant nearest to k / rate_hz (computed from k: no accumulated drift).
core::TimeNs tick_time(std::int64_t k, double rate_hz, core::TimeNs step_ns) {
  const auto exact = static_cast<core::TimeNs>(std::llround(static_cast<double>(k) * 1e9 / rate_hz));
  return (exact + step_ns / 2) / step_ns * step_ns;
}

Eigen::Isometry3d body_pose(const mjData* data, int body_id) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const mjtNum* q = data->xquat + 4 * body_id;
  T.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  T.translation() = Eigen::Map<const Eigen::Vector3d>(data->xpos + 3 * body_id);
  return T;
}

std::vector<TimedWaypoint> rig_knots(const RobotConfig& robot) {
  std::vector<TimedWaypoint> knots;
  constexpr double kDegToRad = M_PI / 180.0;
  for (const auto& w : robot.waypoints) {
    TimedWaypoint knot;
    knot.t_ns = core::seconds_to_ns(w.t_s);
    knot.p_world = Eigen::Vector3d(w.x, w.y, w.z);
    knot.rpy_rad = Eigen::Vector3d(w.roll_deg, w.pitch_deg, w.yaw_deg) * kDegToRad;
    knots.push_back(knot);
  }
  return knots;
}

int require_id(const mjModel* model, int type, const std::string& name) {
  const int id = mj_name2id(model, type, name.c_str());
  FLEETSLAM_CHECK(id >= 0, "inserted MJCF element '" + name + "' not found");
  return id;
}

}  // namespace

struct RobotRuntime {
  RobotConfig config;
  int body_id = -1;
  int mocap_id = -1;
  int camera_id = -1;
  int camera_right_id = -1;
  int qpos_x = -1, qpos_y = -1, qpos_yaw = -1;
  int dof_x = -1, dof_y = -1, dof_yaw = -1;
  int actuator_vx = -1, actuator_vy = -1, actuator_wz = -1;
  int accel_adr = -1, gyro_adr = -1;
  core::PinholeCamera camera;
  Eigen::Isometry3d T_body_cam = Eigen::Isometry3d::Identity();
  std::optional<SmoothTrajectory> trajectory;
  std::optional<PurePursuit> controller;
  ImuModel imu;
  DepthNoiseModel depth_noise;
  ImageNoiseModel left_noise;
  ImageNoiseModel right_noise;
  std::int64_t next_camera_tick = 0;
  std::int64_t next_imu_tick = 0;
  std::int64_t frames_emitted = 0;
  std::vector<core::ImuSample> pending_imu;
  std::vector<core::ImuTruth> pending_imu_truth;  // one per pending_imu sample

  explicit RobotRuntime(const RobotConfig& robot)
      : config(robot),
        imu(robot.imu, derive_seed(robot.seed, kImuStream)),
        depth_noise(robot.camera.depth_noise, derive_seed(robot.seed, kDepthStream)),
        left_noise(robot.camera.image_noise, derive_seed(robot.seed, kLeftImageStream)),
        right_noise(robot.camera.image_noise, derive_seed(robot.seed, kRightImageStream)) {}
};

struct World::Impl {
  ScenarioConfig scenario;
  core::Logger logger;
  detail::ModelPtr model;
  detail::DataPtr data;
  std::unique_ptr<detail::Renderer> renderer;
  std::vector<RobotRuntime> robots;
  core::TimeNs step_ns = 1'000'000;
  core::TimeNs time_ns = 0;
  core::TimeNs end_ns = 0;
  core::TimeNs prepared_ns = -1;  // controls and mocap poses are set for this time

  void load();
  void bind_robot(RobotRuntime& robot) const;
  void prepare(core::TimeNs t_ns);
  std::vector<core::SensorFrame> process_events(core::TimeNs t_ns);
  core::ImuSample imu_sample(RobotRuntime& robot, core::TimeNs t_ns);
  core::SensorFrame render_frame(RobotRuntime& robot, std::size_t index, core::TimeNs t_ns);
  // Velocity of the robot's body frame origin in the world at t_ns (the state's time).
  Eigen::Vector3d velocity_world(const RobotRuntime& robot, core::TimeNs t_ns) const;
  void log_mujoco_warnings() const;
  void check_actuator_stability() const;
};

void World::Impl::load() {
  const std::filesystem::path scene = scenario.scene_path();
  if (!std::filesystem::is_regular_file(scene)) {
    throw InputError(scene.string(), "scene file not found");
  }
  const std::string xml = detail::build_scenario_mjcf(scenario, scene.filename().string());
  // The wrapper lives (virtually) beside the scene, so its include and the scene's assets resolve there.
  const std::filesystem::path wrapper = std::filesystem::absolute(scene).parent_path() / "__fleetslam_scenario.xml";
  model = detail::load_model_from_string(xml, wrapper.string(), scene.string());
  // MuJoCo's near plane is a fraction of the model's size (0.26 m in a 20 m warehouse), which clips
  // views of nearby walls; a fixed 5 cm suits robot cameras. The renderer linearises depth with the
  // same value.
  model->vis.map.znear = static_cast<float>(kNearPlaneM / model->stat.extent);
  data.reset(mj_makeData(model.get()));
  if (!data) throw Error("MuJoCo: cannot allocate the simulation data");
  step_ns = static_cast<core::TimeNs>(std::llround(scenario.physics_step_s * 1e9));
  end_ns = core::seconds_to_ns(scenario.duration_s);
}

void World::Impl::bind_robot(RobotRuntime& robot) const {
  const mjModel* m = model.get();
  const RobotConfig& config = robot.config;
  const std::string prefix = detail::robot_prefix(config);
  robot.body_id = require_id(m, mjOBJ_BODY, prefix);
  if (config.camera.enabled) {
    robot.camera_id = require_id(m, mjOBJ_CAMERA, prefix + "_cam");
    const double f = detail::focal_length_px(config.camera);
    robot.camera = core::PinholeCamera(config.camera.width, config.camera.height, f, f,
                                       0.5 * (config.camera.width - 1), 0.5 * (config.camera.height - 1));
    robot.T_body_cam = detail::T_body_optical(config.camera);
    if (config.stereo.enabled) robot.camera_right_id = require_id(m, mjOBJ_CAMERA, prefix + "_cam_right");
  }
  if (config.type == RobotType::kFreeRig) {
    robot.mocap_id = m->body_mocapid[robot.body_id];
    robot.trajectory.emplace(rig_knots(config));
    return;
  }
  const int jx = require_id(m, mjOBJ_JOINT, prefix + "_x");
  const int jy = require_id(m, mjOBJ_JOINT, prefix + "_y");
  const int jyaw = require_id(m, mjOBJ_JOINT, prefix + "_yaw");
  robot.qpos_x = m->jnt_qposadr[jx];
  robot.qpos_y = m->jnt_qposadr[jy];
  robot.qpos_yaw = m->jnt_qposadr[jyaw];
  robot.dof_x = m->jnt_dofadr[jx];
  robot.dof_y = m->jnt_dofadr[jy];
  robot.dof_yaw = m->jnt_dofadr[jyaw];
  robot.actuator_vx = require_id(m, mjOBJ_ACTUATOR, prefix + "_vx");
  robot.actuator_vy = require_id(m, mjOBJ_ACTUATOR, prefix + "_vy");
  robot.actuator_wz = require_id(m, mjOBJ_ACTUATOR, prefix + "_wz");
  robot.accel_adr = m->sensor_adr[require_id(m, mjOBJ_SENSOR, prefix + "_accel")];
  robot.gyro_adr = m->sensor_adr[require_id(m, mjOBJ_SENSOR, prefix + "_gyro")];
  robot.controller.emplace(config.controller);
  std::vector<Eigen::Vector2d> path;
  for (const auto& w : config.waypoints) path.emplace_back(w.x, w.y);
  robot.controller->set_path(std::move(path));
}

// Sets what drives each robot over the step starting at t_ns: mocap poses of rigs, and diff-drive
// velocity commands from their controllers (world-frame x/y velocity and yaw rate).
void World::Impl::prepare(core::TimeNs t_ns) {
  if (prepared_ns == t_ns) return;
  prepared_ns = t_ns;
  mjData* d = data.get();
  const double dt_s = core::ns_to_seconds(step_ns);
  for (auto& robot : robots) {
    if (robot.trajectory) {
      const auto state = robot.trajectory->evaluate(t_ns);
      const Eigen::Quaterniond q(state.T_world_body.linear());
      Eigen::Map<Eigen::Vector3d>(d->mocap_pos + 3 * robot.mocap_id) = state.T_world_body.translation();
      mjtNum* mq = d->mocap_quat + 4 * robot.mocap_id;
      mq[0] = q.w();
      mq[1] = q.x();
      mq[2] = q.y();
      mq[3] = q.z();
      continue;
    }
    const Eigen::Vector2d p(model->body_pos[3 * robot.body_id] + d->qpos[robot.qpos_x],
                            model->body_pos[3 * robot.body_id + 1] + d->qpos[robot.qpos_y]);
    const double yaw = d->qpos[robot.qpos_yaw];
    const auto command = robot.controller->update(p, yaw, dt_s);
    d->ctrl[robot.actuator_vx] = command.v_mps * std::cos(yaw);
    d->ctrl[robot.actuator_vy] = command.v_mps * std::sin(yaw);
    d->ctrl[robot.actuator_wz] = command.omega_radps;
  }
}

Eigen::Vector3d World::Impl::velocity_world(const RobotRuntime& robot, core::TimeNs t_ns) const {
  if (robot.trajectory) return robot.trajectory->evaluate(t_ns).v_world_mps;
  // Diff drive: slide joints along the world's x and y axes carry the body; the yaw hinge and the IMU site
  // are at its origin.
  return Eigen::Vector3d(data->qvel[robot.dof_x], data->qvel[robot.dof_y], 0.0);
}

core::ImuSample World::Impl::imu_sample(RobotRuntime& robot, core::TimeNs t_ns) {
  Eigen::Vector3d gyro;
  Eigen::Vector3d accel;
  if (robot.trajectory) {
    // The rig moves kinematically: its IMU reads the trajectory's exact derivatives.
    const auto state = robot.trajectory->evaluate(t_ns);
    const Eigen::Vector3d gravity_world = Eigen::Map<const Eigen::Vector3d>(model->opt.gravity);  // as MuJoCo's sensors
    gyro = state.omega_body_radps;
    accel = state.T_world_body.linear().transpose() * (state.a_world_mps2 - gravity_world);
  } else {
    gyro = Eigen::Map<const Eigen::Vector3d>(data->sensordata + robot.gyro_adr);
    accel = Eigen::Map<const Eigen::Vector3d>(data->sensordata + robot.accel_adr);
  }
  return robot.imu.measure(t_ns, gyro, accel);
}

core::SensorFrame World::Impl::render_frame(RobotRuntime& robot, std::size_t index, core::TimeNs t_ns) {
  const CameraConfig& camera = robot.config.camera;
  core::SensorFrame frame;
  frame.robot_id = static_cast<int>(index);
  frame.sequence = robot.frames_emitted++;
  frame.t_ns = t_ns;
  detail::RenderOptions options;
  options.shadows = camera.shadows;
  options.want_depth = camera.depth;
  // The noise models' draws in order here; their expansion into pixel noise (most of the models' work,
  // none of which needs the images) on another thread while the images render, using the cores
  // llvmpipe leaves idle. The fields are a pure function of the draws, so the bytes do not depend on
  // the timing.
  const bool stereo = robot.camera_right_id >= 0;
  const cv::Size size(camera.width, camera.height);
  const int channels = camera.gray ? 1 : 3;
  const ImageNoiseDraw left_draw = robot.left_noise.next(t_ns);
  const DepthNoiseDraw depth_draw = camera.depth ? robot.depth_noise.next() : DepthNoiseDraw{};
  ImageNoiseDraw right_draw = stereo ? robot.right_noise.next(t_ns) : ImageNoiseDraw{};
  // A synchronised stereo head has one exposure: the right image takes the left's gain (its own pixel
  // noise stays its own; its model's exposure process still runs, so its draws are as before).
  right_draw.gain = left_draw.gain;
  struct Fields {
    ImageNoiseField left;
    DepthNoiseField depth;
    ImageNoiseField right;
  };
  std::future<Fields> fields = std::async(std::launch::async, [&] {
    return Fields{robot.left_noise.expand(left_draw, size, channels, false),
                  robot.depth_noise.expand(depth_draw, size, false),
                  stereo ? robot.right_noise.expand(right_draw, size, channels, false) : ImageNoiseField{}};
  });
  cv::Mat bgr;
  cv::Mat depth;
  cv::Mat right;
  renderer->render(model.get(), data.get(), robot.camera_id, camera.width, camera.height, options, &bgr, &depth);
  if (stereo) {
    options.want_depth = false;
    renderer->render(model.get(), data.get(), robot.camera_right_id, camera.width, camera.height, options, &right,
                     nullptr);
  }
  const Fields noise = fields.get();
  if (camera.gray) cv::cvtColor(bgr, bgr, cv::COLOR_BGR2GRAY);
  frame.image = robot.left_noise.apply(bgr, noise.left);
  if (camera.depth) frame.depth_m = robot.depth_noise.apply(depth, robot.camera, noise.depth);
  if (stereo) {
    if (camera.gray) cv::cvtColor(right, right, cv::COLOR_BGR2GRAY);
    frame.right = robot.right_noise.apply(right, noise.right);
  }
  frame.imu = std::move(robot.pending_imu);
  robot.pending_imu.clear();
  frame.imu_truth = std::move(robot.pending_imu_truth);
  robot.pending_imu_truth.clear();
  frame.T_world_cam_gt = body_pose(data.get(), robot.body_id) * robot.T_body_cam;
  if (robot.config.imu.enabled) {
    frame.imu_state_gt = core::ImuStateGt{velocity_world(robot, t_ns), robot.imu.gyro_bias_radps(),
                                          robot.imu.accel_bias_mps2()};
  }
  return frame;
}

// Everything due at t_ns: IMU samples and camera frames, from the state at t_ns.
std::vector<core::SensorFrame> World::Impl::process_events(core::TimeNs t_ns) {
  bool due = false;
  for (auto& robot : robots) {
    const bool imu_due = robot.config.imu.enabled &&
                         tick_time(robot.next_imu_tick, robot.config.imu.noise.rate_hz, step_ns) == t_ns;
    const bool camera_due = robot.config.camera.enabled &&
                            tick_time(robot.next_camera_tick, robot.config.camera.rate_hz, step_ns) == t_ns;
    due = due || imu_due || camera_due;
  }
  if (!due) return {};
  prepare(t_ns);
  mj_forward(model.get(), data.get());  // kinematics, sensors and accelerations of the state at t_ns
  std::vector<core::SensorFrame> frames;
  for (std::size_t i = 0; i < robots.size(); ++i) {
    RobotRuntime& robot = robots[i];
    if (robot.config.imu.enabled && tick_time(robot.next_imu_tick, robot.config.imu.noise.rate_hz, step_ns) == t_ns) {
      robot.pending_imu.push_back(imu_sample(robot, t_ns));
      // The IMU site is the body's origin, axes aligned: the body frame is the IMU frame. The biases are
      // those the sample was measured with.
      robot.pending_imu_truth.push_back(core::ImuTruth{
          t_ns, body_pose(data.get(), robot.body_id),
          core::ImuStateGt{velocity_world(robot, t_ns), robot.imu.gyro_bias_radps(), robot.imu.accel_bias_mps2()}});
      ++robot.next_imu_tick;
    }
    if (robot.config.camera.enabled &&
        tick_time(robot.next_camera_tick, robot.config.camera.rate_hz, step_ns) == t_ns) {
      frames.push_back(render_frame(robot, i, t_ns));
      ++robot.next_camera_tick;
    }
  }
  log_mujoco_warnings();
  return frames;
}

// MuJoCo integrates the velocity actuators' gain explicitly (only joint damping is implicit in 2.2): each
// step scales a velocity error by 1 - dt kv / M, with M the dof's mass or inertia (the mass matrix's
// diagonal: body, wheels, camera and armature). Beyond 2 the loop diverges until MuJoCo resets the state
// (the robot jumps to its start); between 1 and 2 it overshoots every step. A light robot (radius 2 cm)
// or a long physics step is refused here instead.
void World::Impl::check_actuator_stability() const {
  const mjModel* m = model.get();
  const double dt = core::ns_to_seconds(step_ns);
  for (const RobotRuntime& robot : robots) {
    if (robot.config.type != RobotType::kDiffDrive) continue;
    const std::pair<int, int> loops[] = {{robot.actuator_vx, robot.dof_x}, {robot.actuator_vy, robot.dof_y},
                                         {robot.actuator_wz, robot.dof_yaw}};
    for (const auto& [actuator, dof] : loops) {
      const double kv = m->actuator_gainprm[actuator * mjNGAIN];
      const double inertia = data->qM[m->dof_Madr[dof]];
      const double factor = dt * kv / inertia;
      if (!(factor < 1.0)) {
        const bool yaw = dof == robot.dof_yaw;
        throw InputError(scenario.scene + ": robot " + robot.config.name,
                         fmt::format("physics_step_s {:.4g} s is too long for its {} {:.4g} {}: its velocity control "
                                     "would overshoot or diverge (step x gain / {} = {:.4g}, at most 1); use "
                                     "physics_step_s below {:.4g} s or a larger robot",
                                     dt, yaw ? "yaw inertia" : "mass", inertia, yaw ? "kg m^2" : "kg",
                                     yaw ? "inertia" : "mass", factor, inertia / kv));
      }
    }
  }
}

void World::Impl::log_mujoco_warnings() const {
  for (const auto& warning : detail::take_mujoco_warnings()) logger->warn("MuJoCo: {}", warning);
}

World::World(ScenarioConfig scenario, core::Logger logger) : impl_(std::make_unique<Impl>()) {
  impl_->scenario = std::move(scenario);
  // Robots without a seed (a config built in code, not validated) would all draw the same noise.
  for (std::size_t i = 0; i < impl_->scenario.robots.size(); ++i) {
    RobotConfig& robot = impl_->scenario.robots[i];
    if (robot.seed < 0) robot.seed = derived_robot_seed(impl_->scenario.seed, i);
  }
  impl_->logger = logger ? std::move(logger) : core::null_logger();
  impl_->load();
  int max_width = 64;
  int max_height = 64;
  // Sensor ticks fall on the nearest physics instant of the integer step (physics_step_s rounded to ns):
  // a rate whose period is shorter than that step puts two ticks on one step, and equality never sees the
  // second.
  const double step_s = core::ns_to_seconds(impl_->step_ns);
  for (const auto& config : impl_->scenario.robots) {
    if (config.camera.enabled && config.camera.rate_hz * step_s > 1.0) {
      throw InputError(impl_->scenario.scene + ": robot " + config.name,
                       "camera rate exceeds the physics rate");
    }
    // Sensors are sampled at physics steps: two IMU ticks in one step would stop the stream for good.
    if (config.imu.enabled && config.imu.noise.rate_hz * step_s > 1.0) {
      throw InputError(impl_->scenario.scene + ": robot " + config.name,
                       "IMU rate " + std::to_string(config.imu.noise.rate_hz) + " Hz exceeds the physics rate " +
                           std::to_string(1.0 / impl_->scenario.physics_step_s) + " Hz (physics_step_s)");
    }
    if (config.imu.enabled && !imu_period_fits_steps(config.imu.noise.rate_hz, step_s)) {
      throw InputError(impl_->scenario.scene + ": robot " + config.name,
                       "IMU rate " + std::to_string(config.imu.noise.rate_hz) +
                           " Hz is not a whole number of physics steps (" + std::to_string(step_s) +
                           " s): its samples would be unevenly spaced");
    }
    impl_->robots.emplace_back(config);
    impl_->bind_robot(impl_->robots.back());
    if (config.camera.enabled) {
      max_width = std::max(max_width, config.camera.width);
      max_height = std::max(max_height, config.camera.height);
    }
  }
  // Diff-drive robots start at their initial yaw (bodies are inserted unrotated so the slide joints
  // move along world x/y).
  for (auto& robot : impl_->robots) {
    if (robot.qpos_yaw >= 0) impl_->data->qpos[robot.qpos_yaw] = robot.config.initial_pose.yaw_deg * M_PI / 180.0;
  }
  mj_forward(impl_->model.get(), impl_->data.get());
  impl_->check_actuator_stability();
  impl_->renderer = std::make_unique<detail::Renderer>(impl_->model.get(), max_width, max_height);
  impl_->logger->info("world: scene {} with {} robot(s), physics step {} ms, duration {} s",
                      impl_->scenario.scene_path().string(), impl_->robots.size(),
                      core::ns_to_seconds(impl_->step_ns) * 1e3, impl_->scenario.duration_s);
}

World::~World() = default;

std::vector<core::SensorFrame> World::step() {
  Impl& w = *impl_;
  while (w.time_ns < w.end_ns) {
    std::vector<core::SensorFrame> frames = w.process_events(w.time_ns);
    if (!frames.empty()) return frames;
    w.prepare(w.time_ns);
    mj_step(w.model.get(), w.data.get());
    w.time_ns += w.step_ns;
  }
  // The end: mj_step left the kinematics (poses, contacts) of the step before; truth() reads the state at
  // end_ns, as after any step that returned frames.
  if (w.prepared_ns != w.time_ns) {
    w.prepare(w.time_ns);
    mj_forward(w.model.get(), w.data.get());
  }
  return {};
}

core::TimeNs World::time_ns() const { return impl_->time_ns; }
core::TimeNs World::end_ns() const { return impl_->end_ns; }
bool World::finished() const { return impl_->time_ns >= impl_->end_ns; }
std::size_t World::robot_count() const { return impl_->robots.size(); }

const RobotConfig& World::robot_config(std::size_t robot) const { return impl_->robots.at(robot).config; }

core::SensorRig World::sensor_rig(std::size_t robot) const {
  const RobotRuntime& r = impl_->robots.at(robot);
  core::SensorRig rig;
  rig.cam0 = r.camera;
  rig.fps = r.config.camera.rate_hz;
  rig.rgb_order = false;  // frames carry BGR
  rig.T_body_cam0 = r.T_body_cam;
  if (r.config.imu.enabled) rig.imu = r.config.imu.noise;
  if (r.config.stereo.enabled) {
    rig.cam1 = r.camera;
    rig.T_cam0_cam1.translation() = Eigen::Vector3d(r.config.stereo.baseline_m, 0.0, 0.0);
    rig.bf = r.config.stereo.baseline_m * r.camera.fx();
    rig.mode = r.config.imu.enabled ? core::SensorMode::kStereoInertial : core::SensorMode::kStereo;
  } else if (r.config.camera.depth) {
    rig.mode = core::SensorMode::kRgbd;
    rig.bf = 0.08 * r.camera.fx();  // Kinect-like virtual baseline for depth uncertainty
  } else {
    rig.mode = r.config.imu.enabled ? core::SensorMode::kMonoInertial : core::SensorMode::kMonocular;
  }
  return rig;
}

Eigen::Isometry3d World::T_body_cam(std::size_t robot) const { return impl_->robots.at(robot).T_body_cam; }

BodyCylinder World::body_cylinder(std::size_t robot) const {
  const mjModel* m = impl_->model.get();
  const int body = impl_->robots.at(robot).body_id;
  BodyCylinder out;
  out.z_min_m = std::numeric_limits<double>::infinity();
  out.z_max_m = -std::numeric_limits<double>::infinity();
  const auto grow = [&out](const Eigen::Vector3d& centre_body, double radius_xy, double half_z) {
    out.radius_m = std::max(out.radius_m, centre_body.head<2>().norm() + radius_xy);
    out.z_min_m = std::min(out.z_min_m, centre_body.z() - half_z);
    out.z_max_m = std::max(out.z_max_m, centre_body.z() + half_z);
  };
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_bodyid[g] != body) continue;
    const Eigen::Vector3d pos(m->geom_pos[3 * g], m->geom_pos[3 * g + 1], m->geom_pos[3 * g + 2]);
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(m->geom_quat[4 * g], m->geom_quat[4 * g + 1], m->geom_quat[4 * g + 2], m->geom_quat[4 * g + 3])
            .normalized()
            .toRotationMatrix();
    const mjtNum* size = m->geom_size + 3 * g;
    const bool upright = std::abs(R(2, 2)) > 1.0 - 1e-9;
    Eigen::Vector3d half;  // the geom's box in its own frame
    switch (m->geom_type[g]) {
      case mjGEOM_SPHERE: grow(pos, size[0], size[0]); continue;
      case mjGEOM_CYLINDER:
        if (upright) {
          grow(pos, size[0], size[1]);
          continue;
        }
        half = Eigen::Vector3d(size[0], size[0], size[1]);
        break;
      case mjGEOM_CAPSULE:
        if (upright) {
          grow(pos, size[0], size[1] + size[0]);
          continue;
        }
        half = Eigen::Vector3d(size[0], size[0], size[1] + size[0]);
        break;
      case mjGEOM_BOX:
      case mjGEOM_ELLIPSOID: half = Eigen::Vector3d(size[0], size[1], size[2]); break;
      default: half = Eigen::Vector3d::Constant(m->geom_rbound[g]); break;  // meshes and the rest: bounding sphere
    }
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d c((corner & 1) ? half.x() : -half.x(), (corner & 2) ? half.y() : -half.y(),
                              (corner & 4) ? half.z() : -half.z());
      grow(pos + R * c, 0.0, 0.0);
    }
  }
  if (out.z_min_m > out.z_max_m) out = BodyCylinder{};  // no geoms
  return out;
}

RobotTruth World::truth(std::size_t robot) const {
  const RobotRuntime& r = impl_->robots.at(robot);
  const mjData* d = impl_->data.get();
  RobotTruth truth;
  truth.T_world_body = body_pose(d, r.body_id);
  truth.v_world_mps = impl_->velocity_world(r, impl_->time_ns);
  truth.gyro_bias_radps = r.imu.gyro_bias_radps();
  truth.accel_bias_mps2 = r.imu.accel_bias_mps2();
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& contact = d->contact[c];
    const int b1 = impl_->model->geom_bodyid[contact.geom1];
    const int b2 = impl_->model->geom_bodyid[contact.geom2];
    if (b1 == r.body_id || b2 == r.body_id) ++truth.contacts_with_scene;
  }
  return truth;
}

void World::set_path(std::size_t robot, std::vector<Eigen::Vector2d> path_xy) {
  if (robot >= impl_->robots.size()) {
    throw std::invalid_argument("set_path: no robot " + std::to_string(robot) + " (the world has " +
                                std::to_string(impl_->robots.size()) + ")");
  }
  RobotRuntime& r = impl_->robots[robot];
  if (!r.controller) throw std::invalid_argument("set_path: robot '" + r.config.name + "' is not a diff_drive robot");
  r.controller->set_path(std::move(path_xy));
}

bool World::path_done(std::size_t robot) const {
  const RobotRuntime& r = impl_->robots.at(robot);
  return r.controller ? r.controller->done() : impl_->time_ns >= r.trajectory->end_ns();
}

std::vector<Eigen::Vector3f> World::surface_points(double spacing_m) const {
  std::vector<int> robot_bodies;
  for (const auto& r : impl_->robots) robot_bodies.push_back(r.body_id);
  return detail::sample_static_surfaces(impl_->model.get(), impl_->data.get(), robot_bodies, spacing_m);
}

}  // namespace fleetslam::sim
