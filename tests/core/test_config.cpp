#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "fleetslam/core/config.hpp"
#include "fleetslam/core/error.hpp"

namespace fleetslam::core {
namespace {

enum class Policy { kOrbslam3, kExponential, kFixedInterval };

struct InnerConfig {
  double radius_m = 0.5;
  std::vector<double> weights = {1.0, 2.0};
  template <class V>
  void visit(V& v) {
    v("radius_m", radius_m, Limits<double>{0.0, 10.0});
    v("weights", weights);
  }
};

struct OuterConfig {
  int levels = 8;
  bool enabled = true;
  std::string name = "agent";
  std::int64_t seed = 7;
  Policy policy = Policy::kOrbslam3;
  double required_value = 0.0;
  InnerConfig inner;
  template <class V>
  void visit(V& v) {
    v("levels", levels, Limits<int>{1, 16});
    v("enabled", enabled);
    v("name", name);
    v("seed", seed);
    v.choice("policy", policy,
             {{"orbslam3", Policy::kOrbslam3}, {"exponential", Policy::kExponential},
              {"fixed_interval", Policy::kFixedInterval}});
    v.required("required_value", required_value);
    v("inner", inner);
  }
};

OuterConfig load(const std::string& text, const std::string& section = "") {
  return load_config<OuterConfig>(ConfigReader::from_string(text, "agent.yaml"), section);
}

std::string error_of(const std::string& text, const std::string& section = "") {
  try {
    load(text, section);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Config, AbsentKeysKeepDefaults) {
  const OuterConfig c = load("required_value: 1.5\n");
  EXPECT_EQ(c.levels, 8);
  EXPECT_TRUE(c.enabled);
  EXPECT_EQ(c.policy, Policy::kOrbslam3);
  EXPECT_DOUBLE_EQ(c.inner.radius_m, 0.5);
  EXPECT_DOUBLE_EQ(c.required_value, 1.5);
}

TEST(Config, ReadsEveryType) {
  const OuterConfig c = load(
      "levels: 4\nenabled: false\nname: robot_a\nseed: 123456789012\npolicy: exponential\n"
      "required_value: -2\ninner: {radius_m: 0.25, weights: [3, 4.5]}\n");
  EXPECT_EQ(c.levels, 4);
  EXPECT_FALSE(c.enabled);
  EXPECT_EQ(c.name, "robot_a");
  EXPECT_EQ(c.seed, 123456789012);
  EXPECT_EQ(c.policy, Policy::kExponential);
  EXPECT_DOUBLE_EQ(c.inner.radius_m, 0.25);
  EXPECT_EQ(c.inner.weights, (std::vector<double>{3.0, 4.5}));
}

TEST(Config, ReadsASection) {
  const OuterConfig c = load("agent:\n  tracking:\n    levels: 3\n    required_value: 1\nother: 5\n",
                             "agent.tracking");
  EXPECT_EQ(c.levels, 3);
}

TEST(Config, ErrorsNameFileAndKey) {
  EXPECT_EQ(error_of("levels: 4\n"), "agent.yaml:required_value: required key is missing");
  EXPECT_EQ(error_of("required_value: 1\nlevles: 4\n").rfind("agent.yaml:levles: unknown key (line 2)", 0), 0u);
  EXPECT_EQ(error_of("required_value: 1\nlevels: four\n"),
            "agent.yaml:levels: expected an integer, got 'four' (line 2)");
  EXPECT_EQ(error_of("required_value: 1\nlevels: 2.5\n"),
            "agent.yaml:levels: expected an integer, got '2.5' (line 2)");
  EXPECT_EQ(error_of("required_value: 1\nlevels: 17\n"), "agent.yaml:levels: 17 is outside [1, 16] (line 2)");
  EXPECT_EQ(error_of("required_value: 1\nenabled: maybe\n"),
            "agent.yaml:enabled: expected true or false, got 'maybe' (line 2)");
  EXPECT_EQ(error_of("required_value: 1\npolicy: greedy\n"),
            "agent.yaml:policy: unknown value 'greedy' (expected one of: orbslam3, exponential, "
            "fixed_interval) (line 2)");
  EXPECT_EQ(error_of("required_value: 1\ninner:\n  radius_m: 11\n"),
            "agent.yaml:inner.radius_m: 11 is outside [0.0, 10.0] (line 3)");
  EXPECT_EQ(error_of("required_value: 1\ninner:\n  radius: 1\n").rfind("agent.yaml:inner.radius: unknown key", 0), 0u);
  EXPECT_EQ(error_of("required_value: 1\ninner: 3\n"), "agent.yaml:inner: expected a map, got '3' (line 2)");
  EXPECT_EQ(error_of("required_value: 1\ninner: {weights: [1, x]}\n"),
            "agent.yaml:inner.weights[1]: expected a number, got 'x' (line 2)");
  EXPECT_EQ(error_of("required_value: .nan\n"),
            "agent.yaml:required_value: expected a finite number, got '.nan' (line 1)");
  EXPECT_EQ(error_of("required_value: [1]\n"),
            "agent.yaml:required_value: expected a number, got a list (line 1)");
  EXPECT_EQ(error_of("- 1\n- 2\n"), "agent.yaml: expected a YAML map at the top level, got a list");
  EXPECT_EQ(error_of("a: [1, 2\n").rfind("agent.yaml:", 0), 0u);
  EXPECT_NE(error_of("a: [1, 2\n").find("malformed YAML"), std::string::npos);
  // A key given twice (the second was dropped unread, even out of range), a second document (dropped) and
  // an octal-looking integer (010 read as 8) are refused.
  EXPECT_EQ(error_of("required_value: 1\nlevels: 5\nlevels: 2000\n"),
            "agent.yaml:3: key 'levels' given twice (first on line 2)");
  EXPECT_EQ(error_of("required_value: 1\ninner:\n  radius_m: 1\n  radius_m: 2\n"),
            "agent.yaml:4: key 'radius_m' given twice (first on line 3)");
  // An alias inside the node it names makes a node that contains itself (it overflowed the stack); an
  // alias to a node elsewhere is fine.
  for (const char* cycle : {"a: &x [*x]\n", "a: &x {b: *x}\n", "a: &x {b: [1, {c: *x}]}\n"}) {
    const std::string error = error_of(std::string("required_value: 1\n") + cycle);
    EXPECT_EQ(error.rfind("agent.yaml:2:", 0), 0u) << error;
    EXPECT_NE(error.find("contains it"), std::string::npos) << error;
  }
  EXPECT_NO_THROW(ConfigReader::from_string("a: &x [1, {c: 2}]\nb: [*x, *x]\nc: {d: *x}\n", "t.yaml"));
  // A folder given as a config file is not an empty config.
  const std::filesystem::path folder = std::filesystem::temp_directory_path() / "fleetslam_test_config_folder.yaml";
  std::filesystem::create_directories(folder);
  try {
    ConfigReader::from_file(folder);
    ADD_FAILURE() << "a folder was read as a config";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), folder.string() + ": is a folder, not a config file");
  }
  EXPECT_EQ(error_of("required_value: 1\n---\nlevels: 2000\n").rfind("agent.yaml:", 0), 0u);
  EXPECT_NE(error_of("required_value: 1\n---\nlevels: 2000\n").find("2 YAML documents"), std::string::npos);
  EXPECT_EQ(error_of("required_value: 1\nlevels: 010\n"),
            "agent.yaml:levels: '010' has a leading zero (octal in YAML); write it without (line 2)");
  EXPECT_EQ(error_of("required_value: 1\nlevels: 0\n"), "agent.yaml:levels: 0 is outside [1, 16] (line 2)");
  // An empty value is reported on its key's line (a null node has no line of its own).
  EXPECT_EQ(error_of("required_value: 1\nlevels:\n\n\n\nenabled: true\n"),
            "agent.yaml:levels: expected an integer, got nothing (line 2)");
}

struct RobotConfig {
  std::string name;
  double speed_mps = 0.5;
  template <class V>
  void visit(V& v) {
    v.required("name", name);
    v("speed_mps", speed_mps, Limits<double>{0.0, 5.0});
  }
};

struct FleetConfig {
  std::vector<RobotConfig> robots;
  template <class V>
  void visit(V& v) {
    v("robots", robots);
  }
};

TEST(Config, ReadsListsOfStructs) {
  const auto fleet = load_config<FleetConfig>(
      ConfigReader::from_string("robots:\n  - {name: a}\n  - {name: b, speed_mps: 1.5}\n", "fleet.yaml"));
  ASSERT_EQ(fleet.robots.size(), 2u);
  EXPECT_EQ(fleet.robots[0].name, "a");
  EXPECT_DOUBLE_EQ(fleet.robots[0].speed_mps, 0.5);
  EXPECT_DOUBLE_EQ(fleet.robots[1].speed_mps, 1.5);
  const auto back = load_config<FleetConfig>(ConfigReader::from_string(config_to_yaml(fleet), "back.yaml"));
  ASSERT_EQ(back.robots.size(), 2u);
  EXPECT_EQ(back.robots[1].name, "b");
}

TEST(Config, ListErrorsNameTheItem) {
  auto error_of_fleet = [](const std::string& text) -> std::string {
    try {
      load_config<FleetConfig>(ConfigReader::from_string(text, "fleet.yaml"));
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error_of_fleet("robots:\n  - {name: a}\n  - {speed_mps: 1}\n"),
            "fleet.yaml:robots[1].name: required key is missing");
  EXPECT_EQ(error_of_fleet("robots:\n  - {name: a, speed_mps: 9}\n"),
            "fleet.yaml:robots[0].speed_mps: 9 is outside [0.0, 5.0] (line 2)");
  EXPECT_EQ(error_of_fleet("robots: 3\n"), "fleet.yaml:robots: expected a list of maps, got '3' (line 1)");
  EXPECT_EQ(error_of_fleet("robots: [1]\n"), "fleet.yaml:robots[0]: expected a map, got '1' (line 1)");
  EXPECT_EQ(error_of_fleet("robots:\n  - {name: a, colour: red}\n").rfind("fleet.yaml:robots[0].colour: unknown key", 0), 0u);
}

// A config built in code is held to what its YAML would be: the limits of its visit, finite numbers,
// nested structs and list items named by their path.
TEST(Config, CheckConfigHoldsConfigsBuiltInCodeToTheirLimits) {
  const auto error_of_check = [](const auto& config, const std::string& name) -> std::string {
    try {
      check_config(config, name);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  OuterConfig outer;
  EXPECT_EQ(error_of_check(outer, "agent"), "no error");
  outer.levels = 0;
  EXPECT_EQ(error_of_check(outer, "agent"), "agent.levels: 0 is outside [1, 16]");
  outer = OuterConfig{};
  outer.inner.radius_m = 11.0;
  EXPECT_EQ(error_of_check(outer, "agent"), "agent.inner.radius_m: 11.0 is outside [0.0, 10.0]");
  outer.inner.radius_m = std::nan("");
  EXPECT_EQ(error_of_check(outer, "agent").rfind("agent.inner.radius_m: expected a finite number", 0), 0u);
  outer = OuterConfig{};
  outer.inner.weights[1] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of_check(outer, "agent").rfind("agent.inner.weights[1]: expected a finite number", 0), 0u);
  outer = OuterConfig{};
  outer.required_value = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of_check(outer, "agent").rfind("agent.required_value: expected a finite number", 0), 0u);
  FleetConfig fleet;
  fleet.robots = {RobotConfig{"a", 1.0}, RobotConfig{"b", 6.0}};
  EXPECT_EQ(error_of_check(fleet, "fleet"), "fleet.robots[1].speed_mps: 6.0 is outside [0.0, 5.0]");
  fleet.robots[1].speed_mps = 5.0;  // the limits are inclusive
  EXPECT_EQ(error_of_check(fleet, "fleet"), "no error");
  EXPECT_EQ(error_of_check(InnerConfig{}, ""), "no error");
  InnerConfig inner;
  inner.radius_m = -1.0;
  EXPECT_EQ(error_of_check(inner, ""), "radius_m: -1.0 is outside [0.0, 10.0]");
}

TEST(Config, MissingFileIsAnInputError) {
  EXPECT_THROW(ConfigReader::from_file("/nonexistent/agent.yaml"), InputError);
}

TEST(Config, WrittenConfigReadsBackIdentically) {
  OuterConfig c = load("required_value: 0.1\nlevels: 5\npolicy: fixed_interval\ninner: {radius_m: 0.3}\n");
  c.inner.weights = {0.1, 1.0 / 3.0, 1e-300};
  const std::string yaml = config_to_yaml(c);
  const OuterConfig back = load(yaml);
  EXPECT_EQ(back.levels, 5);
  EXPECT_EQ(back.policy, Policy::kFixedInterval);
  EXPECT_EQ(back.required_value, 0.1);
  EXPECT_EQ(back.inner.weights, c.inner.weights);  // bit-exact doubles
  EXPECT_EQ(config_to_yaml(back), yaml);
}

}  // namespace
}  // namespace fleetslam::core
