// The threaded mode's local mapping worker hands an exception thrown on its thread to the agent's thread,
// as the inline mode throws it from Agent::process, instead of logging it and mapping on.
#include <future>
#include <mutex>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "../../slam/src/mapping_worker.hpp"  // private to the slam library
#include "fleetslam/core/log.hpp"

namespace fleetslam::slam {
namespace {

// Local mapping with every step off: the worker's own queue and error handling remain.
LocalMappingConfig idle_config() {
  LocalMappingConfig config;
  config.triangulate = false;
  config.fuse = false;
  config.local_ba = false;
  config.cull_keyframes = false;
  return config;
}

// What a worker maps into: an empty map under its mutex, and the changes it records.
struct Mapped {
  core::Logger logger = core::make_logger("mapping_worker_test", core::LogLevel::kOff);
  LocalMapper mapper{idle_config(), logger};
  Map map;
  std::mutex map_mutex;
  MappingChanges changes;
};

TEST(MappingWorker, RethrowsAWorkerExceptionOnTheCallersThreadAndDropsTheQueue) {
  Mapped m;
  std::promise<void> queued;
  std::shared_future<void> all_queued = queued.get_future().share();
  std::mutex seen_mutex;
  std::vector<KeyframeId> seen;
  MappingWorker worker(m.mapper, m.map, m.map_mutex, m.changes, m.logger, [&](KeyframeId id) {
    {
      const std::lock_guard<std::mutex> lock(seen_mutex);
      seen.push_back(id);
    }
    if (id == 1) {
      all_queued.wait();  // keyframes 2 and 3 are queued behind the failing one
      throw std::runtime_error("loop closing failed");
    }
  });
  worker.push(1);
  worker.push(2);
  worker.push(3);
  queued.set_value();
  try {
    worker.wait_idle();
    FAIL() << "wait_idle returned after the worker threw";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "loop closing failed");
  }
  EXPECT_THROW(worker.pending(), std::runtime_error);
  EXPECT_THROW(worker.push(4), std::runtime_error);
  EXPECT_THROW(worker.wait_idle(), std::runtime_error);
  const std::lock_guard<std::mutex> lock(seen_mutex);
  EXPECT_EQ(seen, std::vector<KeyframeId>{1});  // 2 and 3 were dropped, 4 never queued
}

TEST(MappingWorker, MapsEveryQueuedKeyframeWithoutAnError) {
  Mapped m;
  std::mutex seen_mutex;
  std::vector<KeyframeId> seen;
  MappingWorker worker(m.mapper, m.map, m.map_mutex, m.changes, m.logger, [&](KeyframeId id) {
    const std::lock_guard<std::mutex> lock(seen_mutex);
    seen.push_back(id);
  });
  for (KeyframeId id = 1; id <= 5; ++id) worker.push(id);
  worker.wait_idle();
  EXPECT_EQ(worker.pending(), 0);
  const std::lock_guard<std::mutex> lock(seen_mutex);
  EXPECT_EQ(seen, (std::vector<KeyframeId>{1, 2, 3, 4, 5}));
}

}  // namespace
}  // namespace fleetslam::slam
