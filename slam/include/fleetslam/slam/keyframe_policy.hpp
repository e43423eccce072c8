#pragma once
// When does the current frame become a keyframe? Policies behind one interface (PAPER.md section 3):
//  - orbslam3: ORB-SLAM3's rules (max/min frames since the last keyframe, tracked-point ratio against the
//    reference keyframe, close-point criterion for RGB-D/stereo, local mapping idle):
//      c1a  frames since the last keyframe >= max frames (orbslam_max_frames, 0: fps)
//      c1b  frames since the last keyframe >= min frames and local mapping idle
//      c1c  depth sensor and (tracked < orbslam_weak_ratio * reference or the close-point need)
//      c2   tracked < ratio * reference, or the close-point need; and tracked > min_inliers (ORB-SLAM3's > 15)
//    close-point need: close_tracked < orbslam_close_tracked_max and close_untracked > orbslam_close_untracked_min
//    (depth sensors only). ratio: orbslam_ratio_rgbd / _mono, orbslam_ratio_few_keyframes with < 2 keyframes.
//    A keyframe when (c1a or c1b or c1c) and c2 and, when local mapping is busy, a depth sensor with fewer
//    than orbslam_max_queued keyframes waiting (monocular waits for local mapping).
//  - exponential: T_H = sum_x w_x (exp(x) - 1) over X = [alpha T_I, beta R_A, gamma T_R, delta R_O];
//    a keyframe when T_H > Q. Factors normalised so that 1 means "a keyframe is clearly due":
//      T_I = time since the last keyframe / time_scale_s
//      R_A = 1 - tracked reference points / reference points (1 when the reference has no points)
//      T_R = distance since the reference keyframe / (reference median depth * translation_ratio)
//      R_O = rotation angle since the reference keyframe / rotation_scale_rad
//    Local mapping's state does not enter (the paper's rule has no such term).
//  - fixed_interval: a keyframe when frames_since_last_keyframe >= interval_frames (baseline).
// Hard gates shared by all, applied after the policy: no keyframe with fewer than min_inliers tracked points;
// none on the first relocalization_hold_frames frames after a relocalisation (0: fps; -1: off) while the
// component holds more keyframes than that (ORB-SLAM3's rule: a relocalised pose rests on few inliers,
// and a keyframe there would build new points on it); a keyframe is forced when tracking gets weak
// (tracked points below weak_tracking_inliers) and enough inliers remain (weak_tracking_inliers 0
// switches that gate off), except under orbslam3, whose c1c is ORB-SLAM3's own answer to weak tracking.
// Every decision carries its factors so a run can show why a keyframe was (not) taken:
//  exponential: T_I R_A T_R R_O, term_T_I term_R_A term_T_R term_R_O, T_H, Q
//  orbslam3:    tracked, reference, ratio, c1a c1b c1c c2 need_close (0/1)
//  fixed:       frames, interval

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/time.hpp"

namespace fleetslam::slam {

struct KeyframeContext {
  core::TimeNs t_ns = 0;
  core::TimeNs last_keyframe_t_ns = 0;
  int frames_since_last_keyframe = 0;
  int frames_since_relocalization = -1;  // 0 on the relocalised frame itself; -1: no relocalisation yet
  int keyframes_in_map = 0;
  int tracked_inliers = 0;              // map points tracked in the current frame (after pose optimisation)
  int reference_points = 0;             // map points of the reference keyframe seen by >= 2 keyframes
                                        // (>= 3 once the map has 3): exponential's R_A
  int tracked_reference_points = 0;     // of those, tracked in the current frame
  int reference_points_weighted = 0;    // ORB-SLAM3's count (orbslam3): the reference's map points with
                                        // >= 2 (>= 3) weighted observations (Map::weighted_observations)
  double translation_since_reference_m = 0.0;
  double rotation_since_reference_rad = 0.0;
  double reference_median_depth_m = 1.0;
  int close_tracked = 0;                // close features (depth < close_depth) matched to map points
  int close_untracked = 0;              // close features with depth but no map point
  bool has_depth = false;               // RGB-D or stereo
  bool local_mapping_idle = true;
  int local_mapping_queue = 0;          // keyframes waiting for local mapping (orbslam3 when it is busy)
  double fps = 30.0;
};

struct KeyframeDecision {
  bool insert = false;
  std::string reason;                                  // short, e.g. "T_H 1.83 > Q 1.0"
  double score = 0.0;                                  // policy's own score (T_H for exponential)
  std::vector<std::pair<std::string, double>> factors;  // named inputs and terms
};

enum class KeyframePolicyKind { kOrbslam3, kExponential, kFixedInterval };

struct KeyframePolicyConfig {
  KeyframePolicyKind policy = KeyframePolicyKind::kExponential;
  // Shared gates.
  int min_inliers = 15;
  int weak_tracking_inliers = 50;
  int relocalization_hold_frames = 0;    // 0: fps; -1: no hold
  // orbslam3
  double orbslam_ratio_rgbd = 0.75;      // thRefRatio for RGB-D/stereo (0.9 monocular)
  double orbslam_ratio_mono = 0.9;
  int orbslam_max_frames = 0;            // 0: use fps
  int orbslam_min_frames = 0;
  double orbslam_ratio_few_keyframes = 0.4;  // thRefRatio while the map has fewer than 2 keyframes
  double orbslam_weak_ratio = 0.25;          // c1c: tracking much weaker than the reference
  int orbslam_close_tracked_max = 100;       // close-point need: few close points tracked ...
  int orbslam_close_untracked_min = 70;      // ... and many close points that could become map points
  int orbslam_max_queued = 3;                // busy local mapping still takes keyframes below this queue
  // exponential
  double alpha = 1.0, beta = 1.0, gamma = 1.0, delta = 1.0;    // factor gains inside exp
  double w_time = 0.25, w_covisibility = 1.0, w_translation = 1.0, w_rotation = 1.0;  // weights w_x
  double q_threshold = 1.0;              // Q
  double time_scale_s = 1.0;
  double translation_ratio = 0.1;        // distance of 10 % of the median scene depth counts as 1
  double rotation_scale_rad = 0.26;      // about 15 degrees counts as 1
  // fixed_interval
  int interval_frames = 10;

  template <class V>
  void visit(V& v) {
    v.choice("policy", policy,
             {{"orbslam3", KeyframePolicyKind::kOrbslam3}, {"exponential", KeyframePolicyKind::kExponential},
              {"fixed_interval", KeyframePolicyKind::kFixedInterval}});
    v("min_inliers", min_inliers, core::Limits<int>{0, 10000});
    v("weak_tracking_inliers", weak_tracking_inliers, core::Limits<int>{0, 10000});
    v("relocalization_hold_frames", relocalization_hold_frames, core::Limits<int>{-1, 100000});
    v("orbslam_ratio_rgbd", orbslam_ratio_rgbd, core::Limits<double>{0.0, 1.0});
    v("orbslam_ratio_mono", orbslam_ratio_mono, core::Limits<double>{0.0, 1.0});
    v("orbslam_max_frames", orbslam_max_frames, core::Limits<int>{0, 100000});
    v("orbslam_min_frames", orbslam_min_frames, core::Limits<int>{0, 100000});
    v("orbslam_ratio_few_keyframes", orbslam_ratio_few_keyframes, core::Limits<double>{0.0, 1.0});
    v("orbslam_weak_ratio", orbslam_weak_ratio, core::Limits<double>{0.0, 1.0});
    v("orbslam_close_tracked_max", orbslam_close_tracked_max, core::Limits<int>{0, 100000});
    v("orbslam_close_untracked_min", orbslam_close_untracked_min, core::Limits<int>{0, 100000});
    v("orbslam_max_queued", orbslam_max_queued, core::Limits<int>{0, 1000});
    v("alpha", alpha, core::Limits<double>{0.0, 100.0});
    v("beta", beta, core::Limits<double>{0.0, 100.0});
    v("gamma", gamma, core::Limits<double>{0.0, 100.0});
    v("delta", delta, core::Limits<double>{0.0, 100.0});
    v("w_time", w_time, core::Limits<double>{0.0, 100.0});
    v("w_covisibility", w_covisibility, core::Limits<double>{0.0, 100.0});
    v("w_translation", w_translation, core::Limits<double>{0.0, 100.0});
    v("w_rotation", w_rotation, core::Limits<double>{0.0, 100.0});
    v("q_threshold", q_threshold, core::Limits<double>{0.0, 1e6});
    v("time_scale_s", time_scale_s, core::Limits<double>{1e-3, 1e4});
    v("translation_ratio", translation_ratio, core::Limits<double>{1e-4, 100.0});
    v("rotation_scale_rad", rotation_scale_rad, core::Limits<double>{1e-4, 10.0});
    v("interval_frames", interval_frames, core::Limits<int>{1, 100000});
  }
};

class KeyframePolicy {
 public:
  virtual ~KeyframePolicy() = default;
  virtual KeyframeDecision decide(const KeyframeContext& context) const = 0;
  virtual std::string name() const = 0;
};

std::unique_ptr<KeyframePolicy> make_keyframe_policy(const KeyframePolicyConfig& config);

}  // namespace fleetslam::slam
