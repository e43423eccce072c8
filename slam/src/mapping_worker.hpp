#pragma once
// Threaded mode: local mapping's steps on one worker thread, fed with keyframe ids through a queue.
// The map is shared with tracking under `map_mutex`; the worker holds it for each step except the local
// BA solve, which runs on a copy of the problem. Lock order: the worker never holds its queue lock while
// taking the map lock, and the agent takes the queue lock only inside the map lock.

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/slam/local_mapping.hpp"
#include "fleetslam/slam/map.hpp"

namespace fleetslam::slam {

// Keyframes moved or removed by local mapping since the agent last reported (guarded by the map mutex).
struct MappingChanges {
  std::set<KeyframeId> changed;
  std::vector<KeyframeId> removed;

  void record(const MappingReport& report);
};

class MappingWorker {
 public:
  // Called on the worker after each keyframe's local mapping, without any lock held (loop closing).
  using AfterMapping = std::function<void(KeyframeId)>;
  MappingWorker(LocalMapper& mapper, Map& map, std::mutex& map_mutex, MappingChanges& changes, core::Logger logger,
                AfterMapping after = {});
  ~MappingWorker();
  MappingWorker(const MappingWorker&) = delete;
  MappingWorker& operator=(const MappingWorker&) = delete;

  // push, pending and wait_idle rethrow, on the agent's thread, the first exception local mapping (or
  // `after`) threw on the worker, as the inline mode throws it from Agent::process; the worker maps
  // nothing after it.
  void push(KeyframeId keyframe);
  // Keyframes queued or being processed.
  int pending() const;
  // Blocks until the queue is empty and the worker is idle.
  void wait_idle();

 private:
  void run();
  void process(KeyframeId keyframe);

  LocalMapper& mapper_;
  Map& map_;
  std::mutex& map_mutex_;
  MappingChanges& changes_;
  core::Logger logger_;
  AfterMapping after_;

  mutable std::mutex queue_mutex_;
  std::condition_variable wake_;
  std::condition_variable idle_;
  std::deque<KeyframeId> queue_;
  bool busy_ = false;
  bool stop_ = false;
  std::exception_ptr failure_;  // guarded by queue_mutex_
  std::thread thread_;  // last: starts after every member it uses exists
};

}  // namespace fleetslam::slam
