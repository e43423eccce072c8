// One frame through the agent once its input is accepted: tracking, keyframe insertion, local mapping.

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <spdlog/logger.h>

#include "agent_impl.hpp"
#include "stopwatch.hpp"

namespace fleetslam::slam {

bool Agent::Impl::is_rejection(FrameBuildStatus status) const {
  return status == FrameBuildStatus::kEmptyImage || status == FrameBuildStatus::kUnsupportedImage ||
         status == FrameBuildStatus::kWrongImageSize;
}

void Agent::Impl::reject(AgentUpdate& u) const {
  u.status = FrameStatus::kRejected;
  u.tracking_state = tracker.state();
  logger->warn("frame {} rejected: {}", u.sequence, u.reason);
}

void Agent::Impl::note_gap(core::TimeNs dt_ns, std::string& notes) const {
  if (!(rig.fps > 0.0)) return;
  const double periods = core::ns_to_seconds(dt_ns) * rig.fps;
  if (periods <= config.dropped_frame_periods) return;
  char text[96];
  std::snprintf(text, sizeof text, "gap of %.1f frame periods (dropped frames?)", periods);
  notes += notes.empty() ? text : std::string("; ") + text;
}

Eigen::Isometry3d Agent::Impl::to_cam0(const Eigen::Isometry3d& T_world_cam) const {
  return T_world_cam * builder.T_cam0_rect0().inverse();
}

void Agent::Impl::buffer_imu(const std::vector<core::ImuSample>& samples) {
  // Bounded: a stream of rejected frames must not grow it without end (a minute at 1 kHz).
  constexpr std::size_t kMaxBuffered = 60000;
  imu_buffer.insert(imu_buffer.end(), samples.begin(), samples.end());
  if (imu_buffer.size() > kMaxBuffered) {
    imu_buffer.erase(imu_buffer.begin(), imu_buffer.end() - static_cast<std::ptrdiff_t>(kMaxBuffered));
  }
}

std::optional<Eigen::Matrix3d> Agent::Impl::gyro_rotation(core::TimeNs t_ns) {
  if (!gyro) return std::nullopt;
  std::optional<Eigen::Matrix3d> R;
  if (last_t_ns) R = gyro->rotation(imu_buffer, *last_t_ns, t_ns);
  const auto used = std::find_if(imu_buffer.begin(), imu_buffer.end(),
                                 [t_ns](const core::ImuSample& s) { return s.t_ns > t_ns; });
  imu_buffer.erase(imu_buffer.begin(), used);
  return R;
}

void Agent::Impl::track_and_map(Frame& frame, const std::optional<Eigen::Matrix3d>& gyro_R_prev_cur, AgentUpdate& u) {
  TrackingInputs inputs;
  inputs.gyro_R_prev_cur = gyro_R_prev_cur;
  inputs.fps = rig.fps;
  inputs.local_mapping_queue = worker ? worker->pending() : 0;
  inputs.local_mapping_idle = inputs.local_mapping_queue == 0;
  inputs.initial_T_world_cam = builder.T_cam0_rect0();  // the world is cam0 of the first frame
  inputs.vocabulary = vocabulary.get();
  inputs.database = vocabulary ? &database : nullptr;
  inputs.bow_levels_up = config.place_recognition.levels_up;
  inputs.localization_only = config.localization_only;
  const Stopwatch watch;
  const TrackingResult tracked = tracker.track(frame, map, inputs);
  u.timings.tracking_ms = u.timings.extract_ms + watch.elapsed_ms();
  u.timings.match_ms = tracked.timings.match_ms;
  u.timings.pose_ms = tracked.timings.pose_ms;
  u.timings.local_map_ms = tracked.timings.local_map_ms;
  u.tracking_state = tracked.state;
  u.inliers = tracked.inliers;
  u.reason = tracked.reason;
  u.relocalized = tracked.relocalized;
  u.keyframe_decision = tracked.decision;
  u.component = tracker.component();
  u.status = tracked.initialized                          ? FrameStatus::kInitialized
             : tracked.state == TrackingState::kOk         ? FrameStatus::kTracked
             : tracked.state == TrackingState::kLost       ? FrameStatus::kLost
                                                           : FrameStatus::kNotInitialized;
  if (!tracked.T_world_cam) {
    if (tracked.state == TrackingState::kLost) logger->warn("frame {} lost: {}", u.sequence, u.reason);
    return;
  }
  KeyframeId reference = tracked.reference_keyframe;
  const bool is_keyframe =
      tracked.insert_keyframe && !config.localization_only && insert_keyframe(frame, tracked, u, reference);
  // The logged decision says what happened: a keyframe the policy wanted but the busy worker refused, or
  // localisation-only mode, is no keyframe (the keyframe counts of the experiments come from it).
  if (u.keyframe_decision && u.keyframe_decision->insert && !is_keyframe) {
    u.keyframe_decision->insert = false;
    u.keyframe_decision->reason += config.localization_only ? "; not inserted: localization only"
                                                            : "; not inserted: local mapping busy";
  }
  const std::optional<Eigen::Isometry3d> T_w_ref = map.keyframe_pose(reference);
  if (!T_w_ref) return;  // cannot happen: the reference is alive while the lock is held
  // A keyframe's own frame is its keyframe: it follows it through local BA and loop correction, which
  // inline mapping has already applied (relative to the moved pose, the tracked one kept the old error).
  const Eigen::Isometry3d T_ref_cam =
      is_keyframe ? Eigen::Isometry3d::Identity() : Eigen::Isometry3d(T_w_ref->inverse() * *tracked.T_world_cam);
  records.push_back(FrameRecord{frame.t_ns, reference, T_ref_cam});
  // The pose after inline mapping.
  u.T_world_cam = to_cam0(*T_w_ref * T_ref_cam);
}

bool Agent::Impl::insert_keyframe(Frame& frame, const TrackingResult& tracked, AgentUpdate& u, KeyframeId& reference) {
  if (worker && !tracked.initialized && worker->pending() >= config.max_mapping_queue) {
    const std::string why = "keyframe not inserted: local mapping busy";
    u.reason = u.reason.empty() ? why : u.reason + "; " + why;
    return false;
  }
  MappingReport report;
  const KeyframeId id = mapper.insert_keyframe(frame, tracker.component(), tracked.initialized, map, &report);
  tracker.keyframe_inserted(id, map);
  compute_bow(id);
  new_keyframes.push_back(id);
  reference = id;
  if (worker) {
    worker->push(id);
    return true;
  }
  const Stopwatch watch;
  mapper.process(id, map, report);
  u.timings.mapping_ms = watch.elapsed_ms();
  changes.record(report);
  const Stopwatch loop_watch;
  close_loop_inline(id);
  u.timings.loop_ms = loop_watch.elapsed_ms();
  return true;
}

void Agent::Impl::compute_bow(KeyframeId id) {
  Keyframe* kf = map.keyframe(id);
  if (!vocabulary || kf == nullptr) return;
  BowTransform t = vocabulary->transform(kf->frame.descriptors, config.place_recognition.levels_up);
  kf->bow = std::move(t.bow);
  kf->bow_features = std::move(t.features);
}

void Agent::Impl::close_loop_inline(KeyframeId id) {
  if (!vocabulary) return;
  if (loop_closer) {
    std::optional<LoopEvent> event = loop_closer->detect_and_correct(id, map, database, changes.changed);
    if (event && config.loop_closing.global_ba) {
      if (const auto problem = loop_closer->prepare_global_ba(map.keyframe(id)->component, map)) {
        event->global_ba = loop_closer->apply_global_ba(*problem, loop_closer->solve_global_ba(*problem), map, changes.changed);
      }
    }
    if (event) loops.push_back(*event);
  }
  if (const Keyframe* kf = map.keyframe(id); kf != nullptr && !kf->bow.empty()) database.add(id, kf->bow);
}

// Threaded mode: detection and correction hold the map lock (tracking waits for them), the global BA
// solves on a copy without it; what changed meanwhile is skipped when the result is written back.
void Agent::Impl::close_loop_threaded(KeyframeId id) {
  std::optional<LoopEvent> event;
  std::optional<GlobalBaProblem> problem;
  {
    const std::lock_guard<std::mutex> lock(map_mutex);
    if (loop_closer) event = loop_closer->detect_and_correct(id, map, database, changes.changed);
    if (const Keyframe* kf = map.keyframe(id); kf != nullptr && !kf->bow.empty()) database.add(id, kf->bow);
    if (!event) return;
    if (config.loop_closing.global_ba) problem = loop_closer->prepare_global_ba(map.keyframe(id)->component, map);
    if (!problem) loops.push_back(*event);
  }
  if (!problem) return;
  const BaResult result = loop_closer->solve_global_ba(*problem);
  const std::lock_guard<std::mutex> lock(map_mutex);
  event->global_ba = loop_closer->apply_global_ba(*problem, result, map, changes.changed);
  loops.push_back(*event);
}

KeyframeSnapshot Agent::Impl::snapshot(const Keyframe& kf, bool with_dense) const {
  KeyframeSnapshot s;
  s.id = kf.id;
  s.t_ns = kf.t_ns;
  s.component = kf.component;
  s.T_world_cam = to_cam0(kf.T_world_cam);
  for (MapPointId id : kf.frame.map_points) {
    const MapPoint* p = id == kNoMapPoint ? nullptr : map.point(id);
    if (p == nullptr) continue;
    s.point_ids.push_back(id);
    s.points_world.push_back(p->position);
  }
  if (with_dense) {
    const core::PointCloud* cloud = dense.keyframe_cloud_of(kf.id);
    s.dense_cam = cloud == nullptr ? core::PointCloud{} : core::transformed(*cloud, builder.T_cam0_rect0());
  }
  return s;
}

void Agent::Impl::insert_dense(KeyframeId id, const core::PointCloud& cloud_cam) {
  if (const Keyframe* kf = map.keyframe(id)) {
    dense.add_keyframe(id, kf->T_world_cam, cloud_cam);
    dense_changed.insert(id);
    return;
  }
  // Culled while its cloud was being computed: the points go to the keyframe that inherited it.
  const std::optional<Eigen::Isometry3d> T_world_kf = map.keyframe_pose(id);
  const auto heir = map.live_keyframe(id);
  if (!T_world_kf || !heir) return;
  dense.add_keyframe(id, *T_world_kf, cloud_cam);
  dense.remove_keyframe(id, heir);
  dense_changed.insert(heir->first);
}

void Agent::Impl::update_dense(const core::SensorFrame& sensor) {
  if (!config.dense.enabled) return;
  for (KeyframeId id : new_keyframes) {
    if (dense_worker) {
      dense_worker->push(id, sensor);
    } else {
      insert_dense(id, dense.keyframe_cloud(sensor));
    }
  }
  if (dense_worker) {
    for (const auto& [id, cloud] : dense_worker->take_ready()) insert_dense(id, cloud);
  }
}

void Agent::Impl::report_changes(AgentUpdate& u) {
  for (KeyframeId id : changes.removed) {
    database.erase(id);
    dense_changed.erase(id);
    const auto heir = map.live_keyframe(id);
    dense.remove_keyframe(id, heir);
    if (heir && dense.keyframe_cloud_of(heir->first) != nullptr) dense_changed.insert(heir->first);
  }
  for (KeyframeId id : new_keyframes) {
    if (const Keyframe* kf = map.keyframe(id)) u.new_keyframes.push_back(snapshot(*kf, dense_changed.count(id) > 0));
    changes.changed.erase(id);
    dense_changed.erase(id);
  }
  new_keyframes.clear();
  changes.changed.insert(dense_changed.begin(), dense_changed.end());
  for (KeyframeId id : changes.changed) {
    if (const Keyframe* kf = map.keyframe(id)) u.changed_keyframes.push_back(snapshot(*kf, dense_changed.count(id) > 0));
  }
  dense_changed.clear();
  u.removed_keyframes = std::move(changes.removed);
  u.loops = std::move(loops);
  loops.clear();
  changes.changed.clear();
  changes.removed.clear();
}

}  // namespace fleetslam::slam
