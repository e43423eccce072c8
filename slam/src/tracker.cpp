// Tracking state machine: initialisation, the stages of a tracked frame, the motion model.

#include "fleetslam/slam/tracker.hpp"

#include <algorithm>

#include <spdlog/logger.h>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/se3.hpp"
#include "tracker_working.hpp"

namespace fleetslam::slam {

std::string to_string(TrackingState state) {
  switch (state) {
    case TrackingState::kNotInitialized: return "not_initialized";
    case TrackingState::kOk: return "ok";
    case TrackingState::kLost: return "lost";
  }
  return "unknown";
}

// Tuned on TUM fr1_rpy (fast, jerky hand-held rotation), median ATE over ten runs with 850..1150
// features: radius 7 px (ORB-SLAM's) 2.6 cm, 10 px 2.2 cm; with cross-validation the constant-velocity
// guess is often off by more than r2, where the second stage drops correct matches (7 px: 3.3 cm over
// five runs, 13 px: 2.6 cm).
MatcherConfig TrackingConfig::default_matcher() {
  MatcherConfig c;
  c.radius_px = 10.0;
  c.nn_ratio = 0.9;
  c.cross_validation = false;
  return c;
}

Tracker::Tracker(const TrackingConfig& config, const KeyframePolicyConfig& keyframes, core::Logger logger)
    : config_(config), policy_(make_keyframe_policy(keyframes)), logger_(std::move(logger)) {
  FLEETSLAM_CHECK(logger_ != nullptr, "Tracker needs a logger (core::null_logger() discards)");
}

TrackingResult Tracker::track(Frame& frame, Map& map, const TrackingInputs& inputs) {
  FLEETSLAM_CHECK(frame.map_points.size() == frame.size() && frame.outlier.size() == frame.size(),
                  "Frame::finalize() must run before tracking");
  accumulate_gyro(frame.t_ns, inputs);
  if (state_ == TrackingState::kNotInitialized) {
    if (!inputs.localization_only) return initialize(frame, inputs);
    TrackingResult result;
    result.features = static_cast<int>(frame.size());
    result.reason = "localisation only: no map to localise in";
    return result;
  }
  if (lost_before_first_frame_) {
    // A loaded map's keyframes are from another session: this session's clocks start now (T_I was the
    // first frame's absolute stamp, 1.3e9 s on TUM data, and forced a keyframe).
    lost_since_ns_ = frame.t_ns;
    last_keyframe_t_ns_ = frame.t_ns;
    lost_before_first_frame_ = false;
  }
  // Lost: a few frames try the reference keyframe from the last good pose (a blurred frame or two should
  // not cost the map); after that a new component starts.
  const bool recovering = state_ == TrackingState::kLost;
  const bool can_relocalize = config_.relocalization.enabled && inputs.vocabulary != nullptr &&
                              inputs.database != nullptr && inputs.database->size() > 0;
  const bool relocalizing = recovering && ++lost_frames_ > config_.recovery_frames;
  // The gyro keeps the orientation through the loss: the last local map seen from there comes first.
  const bool gyro_recovery = recovering && gyro_prediction_valid() &&
                             core::ns_to_seconds(frame.t_ns - lost_since_ns_) <= config_.gyro.recovery_s;
  const bool start_new_map = relocalizing && !can_relocalize && !inputs.localization_only;
  if (start_new_map && !gyro_recovery) {
    dead_reckon(map, frame.t_ns);
    return initialize(frame, inputs);
  }

  TrackingResult result;
  result.features = static_cast<int>(frame.size());
  Working w(frame);
  bool ok = false;
  if (relocalizing) {
    ok = gyro_recovery && track_from_gyro(w, map, result);
    if (!ok && start_new_map) {
      w.clear_matches();
      dead_reckon(map, frame.t_ns);
      return initialize(frame, inputs);
    }
    if (!ok) {
      w.clear_matches();
      ok = relocalize(w, map, inputs, result);
    }
    // Only consecutive frames with features count: a blank frame restarts the count (the time it spanned
    // counted, and one failed textured frame after a long blank stretch started a new map at once).
    if (!ok && static_cast<int>(frame.size()) < config_.init_min_features) relocalization_failing_since_ns_.reset();
    if (!ok && !inputs.localization_only && static_cast<int>(frame.size()) >= config_.init_min_features) {
      if (!relocalization_failing_since_ns_) relocalization_failing_since_ns_ = frame.t_ns;
      const double failing_s = core::ns_to_seconds(frame.t_ns - *relocalization_failing_since_ns_);
      if (failing_s >= config_.relocalization.new_map_after_s) {
        w.clear_matches();
        dead_reckon(map, frame.t_ns);
        TrackingResult started = initialize(frame, inputs);
        if (started.initialized) {
          started.reason = "relocalisation failed for " + core::format_seconds(
              frame.t_ns - *relocalization_failing_since_ns_, 3) + " s: new map component";
          logger_->warn("t={} {}", core::format_seconds(frame.t_ns, 6), started.reason);
        }
        return started;
      }
    }
  } else {
    ok = !recovering && track_last_frame(w, map, result);
    if (!ok && gyro_recovery) {
      w.clear_matches();
      ok = track_from_gyro(w, map, result);
    }
    if (!ok) {
      w.clear_matches();
      ok = track_reference_keyframe(w, map, result, recovering);
    }
  }
  if (ok) ok = track_local_map(w, map, result);
  if (!ok) {
    lose(w, map, result);
    return result;
  }
  if (recovering) {
    result.lost_s = core::ns_to_seconds(frame.t_ns - lost_since_ns_);
    result.reason = std::string(result.relocalized ? "relocalised" : "recovered") +
                    (in_loaded_map_ ? std::string(" in the loaded map")
                                    : " after " + std::to_string(lost_frames_ - 1) + " lost frame(s) (" +
                                          core::format_seconds(frame.t_ns - lost_since_ns_, 3) + " s)");
    in_loaded_map_ = false;
    logger_->info("t={} {}", core::format_seconds(frame.t_ns, 6), result.reason);
  }
  relocalization_failing_since_ns_.reset();
  if (result.relocalized) {
    last_frame_.reset();  // no velocity across the gap
    velocity_.reset();
    frames_since_relocalization_ = 0;
  } else if (frames_since_relocalization_ >= 0) {
    ++frames_since_relocalization_;
  }
  state_ = TrackingState::kOk;
  lost_frames_ = 0;
  result.state = state_;
  result.T_world_cam = frame.T_world_cam;
  result.reference_keyframe = reference_keyframe_;
  ++frames_since_keyframe_;
  decide_keyframe(w, map, inputs, result);
  if (inputs.localization_only) result.insert_keyframe = false;
  w.drop_outliers();
  remember(w, map, true);
  return result;
}

// The frame is not tracked. The last good frame stays the prior for recovery; the constant-velocity
// guess is where a new component would start.
void Tracker::lose(Working& w, const Map& map, TrackingResult& result) {
  if (state_ == TrackingState::kOk) {
    if (const auto T_cw = predicted_pose(map, w.frame.t_ns)) last_T_world_cam_ = T_cw->inverse();
    lost_frames_ = 1;
    lost_since_ns_ = w.frame.t_ns;
    relocalization_failing_since_ns_.reset();
  } else {
    dead_reckon(map, w.frame.t_ns);
  }
  state_ = TrackingState::kLost;  // the velocity stays: recovery predicts with it
  result.state = state_;
  result.stage.clear();
  if (result.reason.empty()) result.reason = "too few matches";
  w.clear_matches();
  w.frame.T_world_cam.reset();
}

TrackingResult Tracker::initialize(Frame& frame, const TrackingInputs& inputs) {
  TrackingResult result;
  result.state = state_;
  result.features = static_cast<int>(frame.size());
  int with_depth = 0;
  for (std::size_t i = 0; i < frame.size(); ++i) with_depth += frame.has_depth(i) ? 1 : 0;
  if (result.features < config_.init_min_features || with_depth < config_.init_min_depth_features) {
    result.reason = std::to_string(result.features) + " features (" + std::to_string(with_depth) +
                    " with depth); a map needs " + std::to_string(config_.init_min_features) + " (" +
                    std::to_string(config_.init_min_depth_features) + ")";
    frame.T_world_cam.reset();  // an earlier stage of this call (relocalisation, gyro) may have left one
    return result;
  }
  // A new component starts where the camera was last believed to be, so the trajectory stays continuous
  // (the true link between components is unknown until relocalisation / map merging).
  component_ = ++newest_component_;  // after every component a loaded map holds, whichever it tracked in
  in_loaded_map_ = false;  // placed in none of them: relocalisation searches this component from now on
  lost_frames_ = 0;
  relocalization_failing_since_ns_.reset();
  frames_since_relocalization_ = -1;
  frame.T_world_cam = last_T_world_cam_.value_or(inputs.initial_T_world_cam);
  state_ = TrackingState::kOk;
  velocity_.reset();
  result.state = state_;
  result.initialized = true;
  result.stage = "init";
  result.T_world_cam = frame.T_world_cam;
  result.insert_keyframe = true;
  logger_->info("map component {} started at t={} s with {} features with depth", component_,
                core::format_seconds(frame.t_ns, 6), with_depth);
  return result;
}

void Tracker::keyframe_inserted(KeyframeId id, const Map& map) {
  const Keyframe* kf = map.keyframe(id);
  FLEETSLAM_CHECK(kf != nullptr, "keyframe_inserted: unknown keyframe");
  reference_keyframe_ = id;
  last_keyframe_t_ns_ = kf->t_ns;
  frames_since_keyframe_ = 0;
  // The next frame matches against the keyframe's points (the new ones from depth included).
  if (!last_frame_ || last_frame_->t_ns != kf->t_ns) {
    last_frame_ = kf->frame;
    velocity_.reset();
    gyro_steps_ = 0;
    gyro_R_last_cur_.reset();
    if (previous_input_t_ns_ == kf->t_ns) gyro_R_last_cur_ = Eigen::Matrix3d::Identity();
  }
  last_frame_->map_points = kf->frame.map_points;
  last_frame_->T_world_cam = kf->T_world_cam;
  last_reference_ = id;
  T_ref_last_ = Eigen::Isometry3d::Identity();
  last_T_world_cam_ = kf->T_world_cam;
  last_depth_points_.assign(last_frame_->size(), std::nullopt);
}

void Tracker::start_in_map(int component) {
  state_ = TrackingState::kLost;
  component_ = component;
  newest_component_ = std::max(newest_component_, component);
  lost_frames_ = config_.recovery_frames;  // the next frame counts one more: relocalisation at once
  lost_before_first_frame_ = true;
  in_loaded_map_ = true;
  relocalization_failing_since_ns_.reset();
  last_frame_.reset();
  velocity_.reset();
  gyro_R_last_cur_.reset();
  gyro_steps_ = 0;
  last_T_world_cam_.reset();
  reference_keyframe_ = -1;
  last_reference_ = -1;
}

void Tracker::remember(const Working& w, const Map& map, bool tracked) {
  const Eigen::Isometry3d T_wc = *w.frame.T_world_cam;
  const std::optional<Eigen::Isometry3d> T_wl = last_frame_pose(map);
  if (tracked && last_frame_ && T_wl && w.frame.t_ns > last_frame_->t_ns) {
    velocity_ = T_wc.inverse() * *T_wl;
    velocity_dt_ns_ = w.frame.t_ns - last_frame_->t_ns;
    // Bias: what the gyro says beyond the visual rotation between consecutive tracked frames.
    if (gyro_raw_step_ && gyro_steps_ == 1) {
      const double dt_s = core::ns_to_seconds(velocity_dt_ns_);
      const Eigen::Matrix3d R_visual = T_wl->linear().transpose() * T_wc.linear();
      const Eigen::Vector3d residual = core::so3_log(R_visual.transpose() * *gyro_raw_step_) / dt_s - gyro_bias_cam_;
      if (residual.norm() <= config_.gyro.max_bias_residual_radps) {
        gyro_bias_cam_ += std::min(1.0, dt_s / config_.gyro.bias_time_constant_s) * residual;
      }
    }
  }
  last_frame_ = w.frame;
  gyro_steps_ = 0;
  gyro_R_last_cur_.reset();
  if (config_.gyro.enabled) gyro_R_last_cur_ = Eigen::Matrix3d::Identity();
  last_reference_ = reference_keyframe_;
  const std::optional<Eigen::Isometry3d> T_w_ref = map.keyframe_pose(reference_keyframe_);
  T_ref_last_ = T_w_ref ? T_w_ref->inverse() * T_wc : Eigen::Isometry3d::Identity();
  last_T_world_cam_ = T_wc;
  last_depth_points_.assign(w.frame.size(), std::nullopt);
  if (!config_.last_frame_depth_points) return;
  for (std::size_t i = 0; i < w.frame.size(); ++i) {
    if (w.frame.map_points[i] != kNoMapPoint || !w.frame.has_depth(i)) continue;
    // Near points only: far depth is noisy (ORB-SLAM's close threshold).
    if (w.frame.close_depth_m > 0.0 && w.frame.depth_m[i] > w.frame.close_depth_m) continue;
    last_depth_points_[i] = w.frame.unproject(i);
  }
}

std::optional<Eigen::Isometry3d> Tracker::last_frame_pose(const Map& map) const {
  if (!last_frame_) return std::nullopt;
  if (const auto T_w_ref = map.keyframe_pose(last_reference_)) return *T_w_ref * T_ref_last_;
  return last_frame_->T_world_cam;
}

// T_cam_world of a frame at t_ns under constant velocity. The velocity is rescaled when the time step
// differs (a dropped frame), through the SE(3) logarithm. With the gyro the rotation is the integrated
// one (and a prediction exists without a velocity: rotation only); while lost, the translation is then
// extrapolated for gyro.max_translation_extrapolation_s at most.
std::optional<Eigen::Isometry3d> Tracker::predicted_pose(const Map& map, core::TimeNs t_ns) const {
  const std::optional<Eigen::Isometry3d> T_wl = last_frame_pose(map);
  const bool gyro = gyro_prediction_valid();
  const bool moving = velocity_ && velocity_dt_ns_ > 0;
  if (!T_wl || (!moving && !gyro)) return std::nullopt;
  core::TimeNs dt_ns = t_ns - last_frame_->t_ns;
  if (gyro && state_ == TrackingState::kLost) {
    dt_ns = std::min(dt_ns, core::seconds_to_ns(config_.gyro.max_translation_extrapolation_s));
  }
  Eigen::Isometry3d step = moving ? *velocity_ : Eigen::Isometry3d::Identity();  // T_cur_last
  if (moving && dt_ns != velocity_dt_ns_) {
    const double ratio = static_cast<double>(dt_ns) / static_cast<double>(velocity_dt_ns_);
    step = core::se3_exp(ratio * core::se3_log(*velocity_));
  }
  if (!gyro) return step * T_wl->inverse();
  Eigen::Isometry3d T_last_cur = step.inverse();
  T_last_cur.linear() = *gyro_R_last_cur_;
  return (*T_wl * T_last_cur).inverse();
}

// Chains this frame's gyro rotation (bias removed) onto the rotation since the last tracked frame; a frame
// without one ends the chain until the next tracked frame.
void Tracker::accumulate_gyro(core::TimeNs t_ns, const TrackingInputs& inputs) {
  gyro_raw_step_.reset();
  const std::optional<core::TimeNs> previous_t_ns = previous_input_t_ns_;
  previous_input_t_ns_ = t_ns;
  if (!config_.gyro.enabled || !inputs.gyro_R_prev_cur || !previous_t_ns || t_ns <= *previous_t_ns) {
    gyro_R_last_cur_.reset();
    return;
  }
  gyro_raw_step_ = inputs.gyro_R_prev_cur;
  if (!gyro_R_last_cur_) return;
  const double dt_s = core::ns_to_seconds(t_ns - *previous_t_ns);
  gyro_R_last_cur_ = *gyro_R_last_cur_ * *inputs.gyro_R_prev_cur * core::so3_exp(-gyro_bias_cam_ * dt_s);
  ++gyro_steps_;
}

void Tracker::dead_reckon(const Map& map, core::TimeNs t_ns) {
  if (!gyro_prediction_valid()) return;
  if (const auto T_cw = predicted_pose(map, t_ns)) last_T_world_cam_ = T_cw->inverse();
}

bool Tracker::gyro_prediction_valid() const {
  return config_.gyro.enabled && gyro_R_last_cur_.has_value() && gyro_steps_ > 0 && last_frame_.has_value();
}

}  // namespace fleetslam::slam
