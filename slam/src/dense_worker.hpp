#pragma once
// Threaded mode: keyframe clouds (back-projection, stereo block matching) computed on their own worker
// thread. The worker touches no shared state: it reads the DenseMapper's immutable set-up
// (keyframe_cloud is const and uses only the config, cameras and ray table) and hands the clouds back
// through a queue; the agent inserts them into the dense map under its own lock (take_ready()).

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "fleetslam/core/log.hpp"
#include "fleetslam/core/point_cloud.hpp"
#include "fleetslam/core/sensor_frame.hpp"
#include "fleetslam/slam/dense_mapping.hpp"

namespace fleetslam::slam {

class DenseWorker {
 public:
  DenseWorker(const DenseMapper& mapper, core::Logger logger);
  ~DenseWorker();
  DenseWorker(const DenseWorker&) = delete;
  DenseWorker& operator=(const DenseWorker&) = delete;

  // push, take_ready and wait_idle rethrow, on the agent's thread, the first exception a cloud threw on
  // the worker, as the inline mode throws it from Agent::process; the worker computes nothing after it.
  void push(KeyframeId keyframe, core::SensorFrame sensor);
  // Clouds finished since the last call, in the order their keyframes were pushed.
  std::vector<std::pair<KeyframeId, core::PointCloud>> take_ready();
  // Blocks until every pushed keyframe's cloud is ready.
  void wait_idle();

 private:
  void run();

  const DenseMapper& mapper_;
  core::Logger logger_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable idle_;
  std::deque<std::pair<KeyframeId, core::SensorFrame>> queue_;
  std::vector<std::pair<KeyframeId, core::PointCloud>> ready_;
  bool busy_ = false;
  bool stop_ = false;
  std::exception_ptr failure_;  // guarded by mutex_
  std::thread thread_;  // last: starts after every member it uses exists
};

}  // namespace fleetslam::slam
