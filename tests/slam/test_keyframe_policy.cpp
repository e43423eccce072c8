#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/agent.hpp"
#include "fleetslam/slam/keyframe_policy.hpp"

namespace fleetslam::slam {
namespace {

constexpr double kFps = 30.0;
constexpr core::TimeNs kFramePeriodNs = core::kNsPerSecond / 30;

KeyframePolicyConfig config_of(KeyframePolicyKind kind) {
  KeyframePolicyConfig config;
  config.policy = kind;
  return config;
}

// An RGB-D camera that has tracked everything of its reference keyframe `frames` frames after it.
KeyframeContext still_context(int frames) {
  KeyframeContext c;
  c.last_keyframe_t_ns = 5 * core::kNsPerSecond;
  c.t_ns = c.last_keyframe_t_ns + frames * kFramePeriodNs;
  c.frames_since_last_keyframe = frames;
  c.keyframes_in_map = 10;
  c.tracked_inliers = 300;
  c.reference_points = 300;
  c.tracked_reference_points = 300;
  c.reference_points_weighted = 300;
  c.reference_median_depth_m = 2.0;
  c.close_tracked = 250;
  c.close_untracked = 10;
  c.has_depth = true;
  c.fps = kFps;
  return c;
}

double factor(const KeyframeDecision& d, const std::string& name) {
  for (const auto& [key, value] : d.factors) {
    if (key == name) return value;
  }
  ADD_FAILURE() << "factor " << name << " missing";
  return std::nan("");
}

// First frame (frames since the last keyframe) at which the policy takes a keyframe, 0 if none up to max.
int first_keyframe(const KeyframePolicy& policy, int max_frames, KeyframeContext (*make)(int)) {
  for (int frames = 1; frames <= max_frames; ++frames) {
    if (policy.decide(make(frames)).insert) return frames;
  }
  return 0;
}

// ---- exponential ---------------------------------------------------------------------------------------

TEST(ExponentialPolicy, StandingStillWaitsUntilTimeForcesAKeyframe) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kExponential));
  EXPECT_EQ(policy->name(), "exponential");
  // Only T_I grows: w_time (e^T_I - 1) > 1 with w_time 0.25 needs T_I > ln 5 = 1.609 s, i.e. frame 49 at 30 Hz.
  const int first = first_keyframe(*policy, 300, still_context);
  EXPECT_EQ(first, static_cast<int>(std::floor(std::log(5.0) * kFps)) + 1);
  const KeyframeDecision before = policy->decide(still_context(first - 1));
  EXPECT_FALSE(before.insert) << before.reason;
  EXPECT_DOUBLE_EQ(factor(before, "R_A"), 0.0);
  EXPECT_DOUBLE_EQ(factor(before, "T_R"), 0.0);
  EXPECT_DOUBLE_EQ(factor(before, "R_O"), 0.0);
  EXPECT_GT(factor(policy->decide(still_context(first)), "term_T_I"), 1.0);
}

TEST(ExponentialPolicy, FastTranslationTakesAKeyframe) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kExponential));
  KeyframeContext c = still_context(3);
  c.translation_since_reference_m = 0.1;  // 0.5 of 10 % of 2 m: term e^0.5 - 1 = 0.65, not yet
  EXPECT_FALSE(policy->decide(c).insert);
  c.translation_since_reference_m = 0.2;  // T_R = 1: e - 1 = 1.72 > 1
  const KeyframeDecision d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  EXPECT_NEAR(factor(d, "T_R"), 1.0, 1e-12);
}

// The tests above use the policy's own default Q = 1; agents (replay, run, the experiments) ship Q = 2
// (AgentConfig::default_keyframes): the same motions then need larger factors.
TEST(ExponentialPolicy, TheAgentsShippedThresholdNeedsLargerFactors) {
  const KeyframePolicyConfig shipped = AgentConfig::default_keyframes();
  ASSERT_EQ(shipped.policy, KeyframePolicyKind::kExponential);
  ASSERT_DOUBLE_EQ(shipped.q_threshold, 2.0);
  const auto policy = make_keyframe_policy(shipped);
  KeyframeContext c = still_context(3);
  c.translation_since_reference_m = 0.2;  // T_R = 1: e - 1 = 1.72, a keyframe at Q = 1, not at Q = 2
  EXPECT_FALSE(policy->decide(c).insert);
  c.translation_since_reference_m = 0.24;  // T_R = 1.2: e^1.2 - 1 = 2.32 > 2
  const KeyframeDecision d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  // Standing still: 0.25 (e^T_I - 1) > 2 needs T_I > ln 9 = 2.197 s, frame 66 at 30 Hz.
  EXPECT_EQ(first_keyframe(*policy, 300, still_context), static_cast<int>(std::floor(std::log(9.0) * kFps)) + 1);
}

TEST(ExponentialPolicy, FastRotationTakesAKeyframe) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kExponential));
  KeyframeContext c = still_context(3);
  c.rotation_since_reference_rad = 0.1;
  EXPECT_FALSE(policy->decide(c).insert);
  c.rotation_since_reference_rad = -0.3;  // the sign of an angle does not matter
  const KeyframeDecision d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  EXPECT_NEAR(factor(d, "R_O"), 0.3 / 0.26, 1e-12);
}

TEST(ExponentialPolicy, DroppingCovisibilityTakesAKeyframe) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kExponential));
  KeyframeContext c = still_context(3);
  c.tracked_reference_points = 200;  // R_A = 1/3: e^(1/3) - 1 = 0.40
  EXPECT_FALSE(policy->decide(c).insert);
  c.tracked_reference_points = 90;  // R_A = 0.7: e^0.7 - 1 = 1.01
  const KeyframeDecision d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  EXPECT_NEAR(factor(d, "R_A"), 0.7, 1e-12);
}

TEST(ExponentialPolicy, ReferenceWithoutPointsCountsAsLostCovisibility) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kExponential));
  KeyframeContext c = still_context(3);
  c.reference_points = 0;
  c.tracked_reference_points = 0;
  EXPECT_DOUBLE_EQ(factor(policy->decide(c), "R_A"), 1.0);
}

TEST(ExponentialPolicy, ThresholdFunctionMatchesAHandComputation) {
  KeyframePolicyConfig config = config_of(KeyframePolicyKind::kExponential);
  config.alpha = 0.5;
  config.beta = 2.0;
  config.gamma = 1.5;
  config.delta = 0.8;
  config.w_time = 0.3;
  config.w_covisibility = 0.7;
  config.w_translation = 1.2;
  config.w_rotation = 0.9;
  config.q_threshold = 3.0;
  config.time_scale_s = 2.0;
  config.translation_ratio = 0.05;
  config.rotation_scale_rad = 0.2;
  KeyframeContext c = still_context(0);
  c.t_ns = c.last_keyframe_t_ns + 1'500'000'000;  // 1.5 s
  c.reference_points = 400;
  c.tracked_reference_points = 300;
  c.translation_since_reference_m = 0.06;
  c.reference_median_depth_m = 3.0;
  c.rotation_since_reference_rad = 0.1;

  // By hand: T_I = 0.75, R_A = 0.25, T_R = 0.06 / 0.15 = 0.4, R_O = 0.5.
  const double term_t_i = 0.3 * (std::exp(0.5 * 0.75) - 1.0);    // 0.136497
  const double term_r_a = 0.7 * (std::exp(2.0 * 0.25) - 1.0);    // 0.454105
  const double term_t_r = 1.2 * (std::exp(1.5 * 0.4) - 1.0);     // 0.986543
  const double term_r_o = 0.9 * (std::exp(0.8 * 0.5) - 1.0);     // 0.442642
  const double t_h = term_t_i + term_r_a + term_t_r + term_r_o;  // 2.019787
  EXPECT_NEAR(t_h, 2.019787, 1e-6);

  const KeyframeDecision d = make_keyframe_policy(config)->decide(c);
  EXPECT_NEAR(factor(d, "T_I"), 0.75, 1e-12);
  EXPECT_NEAR(factor(d, "R_A"), 0.25, 1e-12);
  EXPECT_NEAR(factor(d, "T_R"), 0.4, 1e-12);
  EXPECT_NEAR(factor(d, "R_O"), 0.5, 1e-12);
  EXPECT_NEAR(factor(d, "term_T_I"), term_t_i, 1e-12);
  EXPECT_NEAR(factor(d, "term_R_A"), term_r_a, 1e-12);
  EXPECT_NEAR(factor(d, "term_T_R"), term_t_r, 1e-12);
  EXPECT_NEAR(factor(d, "term_R_O"), term_r_o, 1e-12);
  EXPECT_NEAR(factor(d, "T_H"), t_h, 1e-12);
  EXPECT_NEAR(d.score, t_h, 1e-12);
  EXPECT_DOUBLE_EQ(factor(d, "Q"), 3.0);
  EXPECT_FALSE(d.insert);
  EXPECT_EQ(d.reason, "T_H 2.020 <= Q 3.000");

  config.q_threshold = 2.0;
  const KeyframeDecision above = make_keyframe_policy(config)->decide(c);
  EXPECT_TRUE(above.insert);
  EXPECT_EQ(above.reason, "T_H 2.020 > Q 2.000");
}

TEST(ExponentialPolicy, ReportsEveryFactorInOrder) {
  const KeyframeDecision d =
      make_keyframe_policy(config_of(KeyframePolicyKind::kExponential))->decide(still_context(1));
  std::vector<std::string> names;
  for (const auto& f : d.factors) names.push_back(f.first);
  EXPECT_EQ(names, (std::vector<std::string>{"T_I", "R_A", "T_R", "R_O", "term_T_I", "term_R_A", "term_T_R", "term_R_O",
                                             "T_H", "Q"}));
}

TEST(ExponentialPolicy, HugeFactorsStayFiniteAndZeroWeightsSilenceThem) {
  KeyframePolicyConfig config = config_of(KeyframePolicyKind::kExponential);
  config.w_time = 0.0;
  KeyframeContext c = still_context(1);
  c.t_ns = c.last_keyframe_t_ns + 100'000 * core::kNsPerSecond;  // a long pause
  const KeyframeDecision d = make_keyframe_policy(config)->decide(c);
  EXPECT_DOUBLE_EQ(factor(d, "term_T_I"), 0.0);
  EXPECT_FALSE(d.insert);
  config.w_time = 1.0;
  const KeyframeDecision weighted = make_keyframe_policy(config)->decide(c);
  EXPECT_TRUE(std::isfinite(weighted.score));
  EXPECT_TRUE(weighted.insert);
}

// ---- gates (shared by every policy) -------------------------------------------------------------------

class Gates : public ::testing::TestWithParam<KeyframePolicyKind> {};

TEST_P(Gates, FewerThanMinInliersNeverMakeAKeyframe) {
  const auto policy = make_keyframe_policy(config_of(GetParam()));
  KeyframeContext c = still_context(500);  // every policy wants one by now
  c.tracked_reference_points = 10;
  c.translation_since_reference_m = 5.0;
  c.tracked_inliers = 14;
  const KeyframeDecision d = policy->decide(c);
  EXPECT_FALSE(d.insert) << d.reason;
  EXPECT_NE(d.reason.find("min_inliers"), std::string::npos) << d.reason;
  EXPECT_FALSE(d.factors.empty());  // the policy's own view is still reported
  c.tracked_inliers = 15;
  // ORB-SLAM3 wants more than 15 (its c2); the other policies take min_inliers itself.
  EXPECT_EQ(policy->decide(c).insert, GetParam() != KeyframePolicyKind::kOrbslam3);
  c.tracked_inliers = 16;
  EXPECT_TRUE(policy->decide(c).insert);
}

// Except under orbslam3: ORB-SLAM3 has no such rule (its c1c takes weak tracking against the reference),
// so 49 tracked points of a reference of 49 make no keyframe there.
TEST_P(Gates, WeakTrackingForcesAKeyframe) {
  const auto policy = make_keyframe_policy(config_of(GetParam()));
  KeyframeContext c = still_context(1);  // nothing else asks for one
  c.tracked_inliers = 49;
  c.tracked_reference_points = 49;
  c.reference_points = c.reference_points_weighted = 49;
  const KeyframeDecision d = policy->decide(c);
  const bool forced = GetParam() != KeyframePolicyKind::kOrbslam3;
  EXPECT_EQ(d.insert, forced) << d.reason;
  EXPECT_EQ(d.reason.find("weak tracking") != std::string::npos, forced) << d.reason;
  c.tracked_inliers = c.tracked_reference_points = c.reference_points = c.reference_points_weighted = 50;
  EXPECT_FALSE(policy->decide(c).insert);
}

// ORB-SLAM3: no keyframe on the first fps frames after a relocalisation once the map holds more
// keyframes than that; the relocalised frame itself is frame 0. Weak tracking does not override it.
TEST_P(Gates, NoKeyframeJustAfterARelocalisationInABigMap) {
  const auto policy = make_keyframe_policy(config_of(GetParam()));
  KeyframeContext c = still_context(500);  // every policy wants one by now
  c.translation_since_reference_m = 5.0;
  c.tracked_reference_points = 10;
  c.tracked_inliers = 40;  // weak, but above min_inliers
  c.keyframes_in_map = 31;
  for (int frames = 0; frames < 30; ++frames) {
    c.frames_since_relocalization = frames;
    const KeyframeDecision d = policy->decide(c);
    EXPECT_FALSE(d.insert) << frames << ": " << d.reason;
    EXPECT_NE(d.reason.find("after a relocalisation"), std::string::npos) << d.reason;
  }
  c.frames_since_relocalization = 30;
  EXPECT_TRUE(policy->decide(c).insert);
  c.frames_since_relocalization = -1;  // never relocalised
  EXPECT_TRUE(policy->decide(c).insert);
  c.frames_since_relocalization = 0;
  c.keyframes_in_map = 30;  // a small map takes keyframes at once
  EXPECT_TRUE(policy->decide(c).insert);

  KeyframePolicyConfig config = config_of(GetParam());
  config.relocalization_hold_frames = 5;
  c.keyframes_in_map = 6;
  c.frames_since_relocalization = 4;
  EXPECT_FALSE(make_keyframe_policy(config)->decide(c).insert);
  c.frames_since_relocalization = 5;
  EXPECT_TRUE(make_keyframe_policy(config)->decide(c).insert);
  config.relocalization_hold_frames = -1;  // off
  c.frames_since_relocalization = 0;
  EXPECT_TRUE(make_keyframe_policy(config)->decide(c).insert);
}

TEST_P(Gates, WeakTrackingGateCanBeSwitchedOff) {
  KeyframePolicyConfig config = config_of(GetParam());
  config.weak_tracking_inliers = 0;
  KeyframeContext c = still_context(1);
  c.tracked_inliers = c.tracked_reference_points = c.reference_points = c.reference_points_weighted = 20;
  EXPECT_FALSE(make_keyframe_policy(config)->decide(c).insert);
}

INSTANTIATE_TEST_SUITE_P(AllPolicies, Gates,
                         ::testing::Values(KeyframePolicyKind::kOrbslam3, KeyframePolicyKind::kExponential,
                                           KeyframePolicyKind::kFixedInterval));

// ---- orbslam3 ------------------------------------------------------------------------------------------

TEST(Orbslam3Policy, StandingStillWithFullTrackingNeverTakesAKeyframe) {
  // ORB-SLAM3 needs c2 (tracking below the ratio) whatever the frame count: a still camera adds nothing.
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3));
  EXPECT_EQ(policy->name(), "orbslam3");
  EXPECT_EQ(first_keyframe(*policy, 300, still_context), 0);
  const KeyframeDecision d = policy->decide(still_context(100));
  EXPECT_DOUBLE_EQ(factor(d, "c1a"), 1.0);
  EXPECT_DOUBLE_EQ(factor(d, "c2"), 0.0);
}

KeyframeContext slowly_losing_points_while_mapping_busy(int frames) {
  KeyframeContext c = still_context(frames);
  c.tracked_inliers = 200;  // 2/3 of the reference: below 0.75, above 0.25
  c.local_mapping_idle = false;
  c.local_mapping_queue = 5;
  return c;
}

TEST(Orbslam3Policy, BusyMappingDefersUntilMaxFramesThenQueueDecides) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3));
  // c2 holds, c1b does not (mapping busy), c1a waits for fps frames; the long queue still holds it back.
  KeyframeDecision d = policy->decide(slowly_losing_points_while_mapping_busy(29));
  EXPECT_FALSE(d.insert);
  EXPECT_DOUBLE_EQ(factor(d, "c1a"), 0.0);
  d = policy->decide(slowly_losing_points_while_mapping_busy(30));
  EXPECT_DOUBLE_EQ(factor(d, "c1a"), 1.0);
  EXPECT_FALSE(d.insert) << d.reason;
  EXPECT_NE(d.reason.find("busy"), std::string::npos);

  KeyframeContext c = slowly_losing_points_while_mapping_busy(30);
  c.local_mapping_queue = 2;
  d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  c.frames_since_last_keyframe = 29;
  EXPECT_FALSE(policy->decide(c).insert);
  c.has_depth = false;  // monocular waits for local mapping
  c.frames_since_last_keyframe = 30;
  c.tracked_inliers = 150;
  EXPECT_FALSE(policy->decide(c).insert);
}

TEST(Orbslam3Policy, MaxFramesFollowConfigOrFps) {
  KeyframePolicyConfig config = config_of(KeyframePolicyKind::kOrbslam3);
  config.orbslam_max_frames = 10;
  EXPECT_EQ(first_keyframe(*make_keyframe_policy(config), 100,
                           [](int frames) {
                             KeyframeContext c = slowly_losing_points_while_mapping_busy(frames);
                             c.local_mapping_queue = 0;
                             return c;
                           }),
            10);
  KeyframeContext c = slowly_losing_points_while_mapping_busy(15);
  c.local_mapping_queue = 0;
  c.fps = 15.0;
  EXPECT_TRUE(make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3))->decide(c).insert);
  c.frames_since_last_keyframe = 14;
  EXPECT_FALSE(make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3))->decide(c).insert);
}

TEST(Orbslam3Policy, IdleMappingTakesAKeyframeOnceTrackingDropsBelowTheRatio) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3));
  KeyframeContext c = still_context(1);
  c.tracked_inliers = 226;  // 0.753 of 300
  EXPECT_FALSE(policy->decide(c).insert);
  c.tracked_inliers = 224;  // 0.747
  const KeyframeDecision d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  EXPECT_DOUBLE_EQ(factor(d, "c1b"), 1.0);
  EXPECT_DOUBLE_EQ(factor(d, "ratio"), 0.75);
  EXPECT_NEAR(d.score, 224.0 / 300.0, 1e-12);
}

TEST(Orbslam3Policy, RatioDependsOnSensorAndMapSize) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3));
  KeyframeContext c = still_context(1);
  c.has_depth = false;
  c.tracked_inliers = 260;  // 0.867: below the monocular 0.9
  EXPECT_DOUBLE_EQ(factor(policy->decide(c), "ratio"), 0.9);
  EXPECT_TRUE(policy->decide(c).insert);
  c.keyframes_in_map = 1;  // right after initialisation ORB-SLAM3 is far more lenient
  EXPECT_DOUBLE_EQ(factor(policy->decide(c), "ratio"), 0.4);
  EXPECT_FALSE(policy->decide(c).insert);
}

TEST(Orbslam3Policy, WeakTrackingAgainstTheReferenceForcesAKeyframeWhileMappingIsBusy) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3));
  KeyframeContext c = slowly_losing_points_while_mapping_busy(2);
  c.local_mapping_queue = 0;
  c.reference_points_weighted = 1000;  // ORB-SLAM3's reference count
  c.tracked_inliers = 260;  // 0.26 of the reference: not c1c yet
  EXPECT_FALSE(policy->decide(c).insert);
  c.tracked_inliers = 240;  // 0.24 < 0.25
  const KeyframeDecision d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  EXPECT_DOUBLE_EQ(factor(d, "c1c"), 1.0);
}

TEST(Orbslam3Policy, ClosePointCriterionForDepthSensorsOnly) {
  const auto policy = make_keyframe_policy(config_of(KeyframePolicyKind::kOrbslam3));
  KeyframeContext c = still_context(1);
  c.local_mapping_idle = false;
  c.close_tracked = 99;
  c.close_untracked = 71;
  KeyframeDecision d = policy->decide(c);
  EXPECT_TRUE(d.insert) << d.reason;
  EXPECT_DOUBLE_EQ(factor(d, "need_close"), 1.0);
  c.close_untracked = 70;
  EXPECT_FALSE(policy->decide(c).insert);
  c.close_untracked = 71;
  c.close_tracked = 100;
  EXPECT_FALSE(policy->decide(c).insert);
  c.close_tracked = 99;
  c.has_depth = false;
  c.local_mapping_idle = true;
  d = policy->decide(c);
  EXPECT_FALSE(d.insert) << d.reason;
  EXPECT_DOUBLE_EQ(factor(d, "need_close"), 0.0);
}

// ---- fixed interval -----------------------------------------------------------------------------------

TEST(FixedIntervalPolicy, KeyframeEveryIntervalFrames) {
  KeyframePolicyConfig config = config_of(KeyframePolicyKind::kFixedInterval);
  config.interval_frames = 7;
  const auto policy = make_keyframe_policy(config);
  EXPECT_EQ(policy->name(), "fixed_interval");
  // Run a sequence, resetting the counter at each keyframe: keyframes at frames 7, 14, 21, ...
  std::vector<int> keyframe_frames;
  int since = 0;
  for (int frame = 1; frame <= 30; ++frame) {
    ++since;
    KeyframeContext c = still_context(since);
    c.translation_since_reference_m = 3.0;  // motion does not matter to this policy
    const KeyframeDecision d = policy->decide(c);
    if (d.insert) {
      keyframe_frames.push_back(frame);
      since = 0;
    }
  }
  EXPECT_EQ(keyframe_frames, (std::vector<int>{7, 14, 21, 28}));
  const KeyframeDecision d = policy->decide(still_context(7));
  EXPECT_EQ(d.reason, "7 frames >= interval 7");
  EXPECT_DOUBLE_EQ(factor(d, "interval"), 7.0);
  EXPECT_DOUBLE_EQ(d.score, 1.0);
}

// ---- configuration -------------------------------------------------------------------------------------

TEST(KeyframePolicyConfig, ReadsFromYaml) {
  const std::string yaml =
      "keyframes:\n"
      "  policy: orbslam3\n"
      "  min_inliers: 20\n"
      "  orbslam_max_frames: 12\n"
      "  alpha: 2.5\n"
      "  q_threshold: 1.5\n"
      "  interval_frames: 4\n";
  const auto config =
      core::load_config<KeyframePolicyConfig>(core::ConfigReader::from_string(yaml, "agent.yaml"), "keyframes");
  EXPECT_EQ(config.policy, KeyframePolicyKind::kOrbslam3);
  EXPECT_EQ(config.min_inliers, 20);
  EXPECT_EQ(config.orbslam_max_frames, 12);
  EXPECT_DOUBLE_EQ(config.alpha, 2.5);
  EXPECT_DOUBLE_EQ(config.q_threshold, 1.5);
  EXPECT_EQ(config.interval_frames, 4);
  EXPECT_DOUBLE_EQ(config.w_time, KeyframePolicyConfig{}.w_time);  // absent keys keep defaults
  EXPECT_EQ(make_keyframe_policy(config)->name(), "orbslam3");
}

TEST(KeyframePolicyConfig, RoundTripsThroughYamlAndRejectsBadValues) {
  KeyframePolicyConfig config;
  config.policy = KeyframePolicyKind::kFixedInterval;
  config.rotation_scale_rad = 0.4;
  const auto back = core::load_config<KeyframePolicyConfig>(
      core::ConfigReader::from_string(core::config_to_yaml(config), "effective.yaml"));
  EXPECT_EQ(back.policy, KeyframePolicyKind::kFixedInterval);
  EXPECT_DOUBLE_EQ(back.rotation_scale_rad, 0.4);

  const auto load = [](const std::string& yaml) {
    return core::load_config<KeyframePolicyConfig>(core::ConfigReader::from_string(yaml, "agent.yaml"));
  };
  EXPECT_THROW(load("policy: sometimes\n"), InputError);
  EXPECT_THROW(load("interval_frames: 0\n"), InputError);
  EXPECT_THROW(load("q_treshold: 1.0\n"), InputError);
}

}  // namespace
}  // namespace fleetslam::slam
