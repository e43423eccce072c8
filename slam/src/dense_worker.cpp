// The dense mapping worker thread (threaded mode).

#include "dense_worker.hpp"

#include <spdlog/logger.h>

namespace fleetslam::slam {

DenseWorker::DenseWorker(const DenseMapper& mapper, core::Logger logger)
    : mapper_(mapper), logger_(std::move(logger)), thread_([this] { run(); }) {}

DenseWorker::~DenseWorker() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void DenseWorker::push(KeyframeId keyframe, core::SensorFrame sensor) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (failure_) std::rethrow_exception(failure_);
    queue_.emplace_back(keyframe, std::move(sensor));
  }
  wake_.notify_one();
}

std::vector<std::pair<KeyframeId, core::PointCloud>> DenseWorker::take_ready() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (failure_) std::rethrow_exception(failure_);
  std::vector<std::pair<KeyframeId, core::PointCloud>> out;
  out.swap(ready_);
  return out;
}

void DenseWorker::wait_idle() {
  std::unique_lock<std::mutex> lock(mutex_);
  idle_.wait(lock, [this] { return queue_.empty() && !busy_; });
  if (failure_) std::rethrow_exception(failure_);
}

void DenseWorker::run() {
  for (;;) {
    std::pair<KeyframeId, core::SensorFrame> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
      busy_ = true;
    }
    core::PointCloud cloud;
    std::exception_ptr failure;
    try {
      cloud = mapper_.keyframe_cloud(job.second);
    } catch (...) {
      // An exception must not escape the thread (std::terminate): it goes to the agent's thread instead,
      // and the keyframes queued behind it are dropped.
      failure = std::current_exception();
      logger_->error("dense cloud of keyframe {} failed; the agent's next call rethrows the error", job.first);
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      busy_ = false;
      if (!failure) {
        ready_.emplace_back(job.first, std::move(cloud));
      } else if (!failure_) {
        failure_ = failure;
        queue_.clear();
      }
    }
    idle_.notify_all();
  }
}

}  // namespace fleetslam::slam
