// The agent: front end, tracking and local mapping composed, one frame at a time.

#include "fleetslam/slam/agent.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <spdlog/fmt/fmt.h>
#include <spdlog/logger.h>

#include "agent_impl.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/map_io.hpp"
#include "stopwatch.hpp"

namespace fleetslam::slam {

std::string to_string(FrameStatus status) {
  switch (status) {
    case FrameStatus::kTracked: return "tracked";
    case FrameStatus::kInitialized: return "initialized";
    case FrameStatus::kNotInitialized: return "not_initialized";
    case FrameStatus::kLost: return "lost";
    case FrameStatus::kRejected: return "rejected";
    case FrameStatus::kMapChanges: return "map_changes";
  }
  return "unknown";
}

KeyframePolicyConfig AgentConfig::default_keyframes() {
  KeyframePolicyConfig c;
  c.policy = KeyframePolicyKind::kExponential;
  c.q_threshold = 2.0;
  return c;
}

namespace {

// The rig as the front end should use it: the sensor mode the config asks for.
// Monocular rigs are refused: the agent starts its maps from depth (RGB-D or stereo), and a monocular
// sequence would run to its end with every frame "not initialised".
core::SensorRig rig_for(const AgentConfig& config, core::SensorRig rig) {
  const std::string was = core::to_string(rig.mode);
  switch (config.sensor) {
    case AgentSensor::kRig: break;
    case AgentSensor::kRgbd:
      if (rig.mode != core::SensorMode::kRgbd && !(rig.bf > 0.0)) {
        throw InputError("sensor", "rgbd needs depth images, and this sequence's rig is " + was +
                                       " (no depth, no virtual baseline bf)");
      }
      rig.mode = core::SensorMode::kRgbd;
      break;
    case AgentSensor::kStereo:
      if (!rig.cam1) throw InputError("sensor", "stereo needs a rig with a second camera (cam1); this one is " + was);
      rig.mode = core::SensorMode::kStereo;
      break;
  }
  if (rig.mode == core::SensorMode::kMonocular || rig.mode == core::SensorMode::kMonoInertial) {
    throw InputError("sensor rig", "the rig is " + core::to_string(rig.mode) +
                                       " (one camera, no depth): the agent runs RGB-D or stereo; give a sequence "
                                       "with depth images or a second camera");
  }
  return rig;
}

}  // namespace

Agent::Impl::Impl(const AgentConfig& c, const core::SensorRig& r, core::Logger l)
    : config(c),
      rig(rig_for(c, r)),
      logger(std::move(l)),
      builder(c.frontend, rig),
      tracker(c.tracking, c.keyframes, logger),
      mapper(c.mapping, logger),
      dense(c.dense, builder) {
  if (config.tracking.gyro.enabled && rig.imu && rig.T_body_cam0) {
    // The tracker's camera is the rectified left one; the IMU frame is the body frame of T_body_cam0.
    const Eigen::Matrix3d R_body_cam = (*rig.T_body_cam0 * builder.T_cam0_rect0()).linear();
    gyro.emplace(R_body_cam.transpose(), config.tracking.gyro.max_gap_s);
    logger->info("gyroscope: tracking predicts rotations with it (bias estimated online)");
  }
  if (config.place_recognition.enabled) {
    vocabulary = load_place_vocabulary(config.place_recognition);
    if (config.loop_closing.enabled) {
      LoopClosingConfig loop_config = config.loop_closing;
      loop_config.pose_optimizer = config.tracking.pose_optimizer;
      loop_config.bundle_adjustment = config.mapping.ba;
      loop_config.covisibility_min_weight = config.mapping.covisibility_min_weight;
      loop_closer.emplace(loop_config, logger);
    }
  }
  if (config.threaded) {
    if (config.dense.enabled) dense_worker = std::make_unique<DenseWorker>(dense, logger);
    MappingWorker::AfterMapping after;
    if (vocabulary) after = [this](KeyframeId id) { close_loop_threaded(id); };
    worker = std::make_unique<MappingWorker>(mapper, map, map_mutex, changes, logger, std::move(after));
  }
}

Agent::Agent(const AgentConfig& config, const core::SensorRig& rig, core::Logger logger) {
  FLEETSLAM_CHECK(logger != nullptr, "Agent needs a logger (core::null_logger() discards)");
  impl_ = std::make_unique<Impl>(config, rig, std::move(logger));
  if (!config.load_map.empty()) load_map(config.load_map);
}

Map Agent::map_copy() const {
  Map copy;
  {
    const std::lock_guard<std::mutex> lock(impl_->map_mutex);
    copy = impl_->map;
  }
  // cv::Mat copies share their pixels: the copy gets its own descriptors.
  for (const auto& entry : copy.keyframes()) {
    cv::Mat& descriptors = copy.keyframe(entry.first)->frame.descriptors;
    descriptors = descriptors.clone();
  }
  return copy;
}

void Agent::save_map(const std::filesystem::path& file) {
  // The workers' queued keyframes reach the map first; their changes stay for the next update or finish().
  Impl& s = *impl_;
  if (s.worker) s.worker->wait_idle();
  if (s.dense_worker) s.dense_worker->wait_idle();
  const std::lock_guard<std::mutex> lock(s.map_mutex);
  slam::save_map(s.map, file, s.vocabulary ? vocabulary_fingerprint(*s.vocabulary) : 0);
}

void Agent::load_map(const std::filesystem::path& file) {
  Impl& s = *impl_;
  SavedMap saved = slam::load_map(file);
  // Bundle adjustment projects every keyframe of a window with one camera: a map made with other
  // intrinsics (or another baseline) would have its keyframes' observations rejected as outliers and
  // erode without a word.
  const core::PinholeCamera& camera = s.builder.camera();
  for (const auto& [id, kf] : saved.map.keyframes()) {
    const core::PinholeCamera& c = kf.frame.camera;
    const auto differs = [](double a, double b) { return !(std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b))); };
    if (c.width() != camera.width() || c.height() != camera.height() || differs(c.fx(), camera.fx()) ||
        differs(c.fy(), camera.fy()) || differs(c.cx(), camera.cx()) || differs(c.cy(), camera.cy()) ||
        differs(kf.frame.bf, s.builder.bf())) {
      const auto describe = [](const core::PinholeCamera& cam, double bf) {
        return fmt::format("{}x{}, fx {:.3f} fy {:.3f} cx {:.3f} cy {:.3f}, bf {:.3f}", cam.width(), cam.height(), cam.fx(),
                           cam.fy(), cam.cx(), cam.cy(), bf);
      };
      throw InputError(file.string(), fmt::format("keyframe {} was made with another camera ({}) than this agent's ({})", id,
                                                  describe(c, kf.frame.bf), describe(camera, s.builder.bf())));
    }
  }
  const std::lock_guard<std::mutex> lock(s.map_mutex);
  FLEETSLAM_CHECK(!s.last_t_ns && s.map.keyframe_count() == 0, "Agent::load_map: only before the first frame");
  s.map = std::move(saved.map);
  // BoW vectors are recomputed whatever the file holds: they depend on the vocabulary and on
  // place_recognition.levels_up, and the file records only the former (features grouped at another tree
  // depth share no node with this agent's frames, and relocalisation silently never succeeded). The
  // vectors read are replaced, so a file's own cannot disagree with the database either.
  if (s.vocabulary) {
    const std::uint64_t fingerprint = vocabulary_fingerprint(*s.vocabulary);
    s.logger->info("map {}: BoW vectors computed with this agent's vocabulary{} (levels_up {})", file.string(),
                   fingerprint == saved.vocabulary_fingerprint ? "" : ", not the map's",
                   s.config.place_recognition.levels_up);
    for (const auto& entry : s.map.keyframes()) s.compute_bow(entry.first);
  }
  s.database.clear();
  int component = -1;
  for (const auto& [id, kf] : s.map.keyframes()) {
    if (s.vocabulary && !kf.bow.empty()) s.database.add(id, kf.bow);
    component = kf.component;  // ascending ids: the newest keyframe's at the end
  }
  if (component >= 0) s.tracker.start_in_map(component);
  s.logger->info("map {} loaded: {} keyframes, {} points", file.string(), s.map.keyframe_count(), s.map.point_count());
}

Agent::~Agent() = default;
Agent::Agent(Agent&&) noexcept = default;
Agent& Agent::operator=(Agent&&) noexcept = default;

const AgentConfig& Agent::config() const { return impl_->config; }

AgentUpdate Agent::finish() {
  Impl& s = *impl_;
  if (s.worker) s.worker->wait_idle();
  if (s.dense_worker) s.dense_worker->wait_idle();
  AgentUpdate u;
  u.status = FrameStatus::kMapChanges;
  u.robot_id = s.last_robot_id;
  u.sequence = s.last_sequence;
  u.t_ns = s.last_t_ns.value_or(0);
  const std::lock_guard<std::mutex> lock(s.map_mutex);
  if (s.dense_worker) {
    for (const auto& [id, cloud] : s.dense_worker->take_ready()) s.insert_dense(id, cloud);
  }
  u.tracking_state = s.tracker.state();
  s.report_changes(u);
  return u;
}

core::PointCloud Agent::dense_cloud() const {
  const Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.map_mutex);
  return s.dense.cloud_world([&s](KeyframeId id) -> std::optional<Eigen::Isometry3d> {
    const Keyframe* kf = s.map.keyframe(id);
    if (kf == nullptr) return std::nullopt;
    return kf->T_world_cam;
  });
}

DenseStats Agent::dense_stats() const {
  const std::lock_guard<std::mutex> lock(impl_->map_mutex);
  return impl_->dense.stats();
}

TrackingState Agent::state() const {
  const std::lock_guard<std::mutex> lock(impl_->map_mutex);
  return impl_->tracker.state();
}

AgentUpdate Agent::process(const core::SensorFrame& sensor) {
  Impl& s = *impl_;
  const Stopwatch total;
  AgentUpdate u;
  u.robot_id = sensor.robot_id;
  u.sequence = sensor.sequence;
  u.t_ns = sensor.t_ns;
  s.last_robot_id = sensor.robot_id;
  s.last_sequence = sensor.sequence;
  if (s.gyro) s.buffer_imu(sensor.imu);  // a rejected frame's samples still belong to the next interval
  if (s.last_t_ns && sensor.t_ns <= *s.last_t_ns) {
    u.reason = "timestamp " + core::format_seconds(sensor.t_ns, 6) + " s does not advance past the previous " +
               core::format_seconds(*s.last_t_ns, 6) + " s";
    s.reject(u);
    return u;
  }
  const Stopwatch extract;
  FrameBuildResult built = s.builder.build(sensor);
  u.timings.extract_ms = extract.elapsed_ms();
  u.features = static_cast<int>(built.frame.size());
  u.features_with_depth = built.features_with_depth;
  if (s.is_rejection(built.status)) {
    u.reason = built.reason;
    s.reject(u);
    u.timings.total_ms = total.elapsed_ms();
    return u;
  }
  std::string notes = built.ok() ? "" : built.reason;
  if (s.last_t_ns) s.note_gap(sensor.t_ns - *s.last_t_ns, notes);
  const std::optional<Eigen::Matrix3d> gyro_R_prev_cur = s.gyro_rotation(sensor.t_ns);
  s.last_t_ns = sensor.t_ns;
  {
    const std::lock_guard<std::mutex> lock(s.map_mutex);
    s.track_and_map(built.frame, gyro_R_prev_cur, u);
    const Stopwatch dense;
    s.update_dense(sensor);
    u.timings.dense_ms = dense.elapsed_ms();
    s.report_changes(u);
  }
  if (!notes.empty()) u.reason = u.reason.empty() ? notes : u.reason + "; " + notes;
  u.timings.total_ms = total.elapsed_ms();
  return u;
}

}  // namespace fleetslam::slam
