// The local mapping worker thread (threaded mode).

#include "mapping_worker.hpp"

#include <optional>

#include <spdlog/logger.h>

#include "stopwatch.hpp"

namespace fleetslam::slam {

void MappingChanges::record(const MappingReport& report) {
  changed.insert(report.ba.adjusted.begin(), report.ba.adjusted.end());
  for (KeyframeId id : report.culled_keyframes) {
    changed.erase(id);
    removed.push_back(id);
  }
}

MappingWorker::MappingWorker(LocalMapper& mapper, Map& map, std::mutex& map_mutex, MappingChanges& changes,
                             core::Logger logger, AfterMapping after)
    : mapper_(mapper), map_(map), map_mutex_(map_mutex), changes_(changes), logger_(std::move(logger)),
      after_(std::move(after)),
      thread_([this] { run(); }) {}

MappingWorker::~MappingWorker() {
  {
    const std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void MappingWorker::push(KeyframeId keyframe) {
  {
    const std::lock_guard<std::mutex> lock(queue_mutex_);
    if (failure_) std::rethrow_exception(failure_);
    queue_.push_back(keyframe);
  }
  wake_.notify_one();
}

int MappingWorker::pending() const {
  const std::lock_guard<std::mutex> lock(queue_mutex_);
  if (failure_) std::rethrow_exception(failure_);
  return static_cast<int>(queue_.size()) + (busy_ ? 1 : 0);
}

void MappingWorker::wait_idle() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  idle_.wait(lock, [this] { return queue_.empty() && !busy_; });
  if (failure_) std::rethrow_exception(failure_);
}

void MappingWorker::run() {
  for (;;) {
    KeyframeId keyframe = -1;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      keyframe = queue_.front();
      queue_.pop_front();
      busy_ = true;
    }
    std::exception_ptr failure;
    try {
      process(keyframe);
      if (after_) after_(keyframe);
    } catch (...) {
      // An exception must not escape the thread (std::terminate): it goes to the agent's thread instead,
      // and the keyframes queued behind it are dropped.
      failure = std::current_exception();
      logger_->error("local mapping of keyframe {} failed; the agent's next call rethrows the error", keyframe);
    }
    {
      const std::lock_guard<std::mutex> lock(queue_mutex_);
      busy_ = false;
      if (failure && !failure_) {
        failure_ = failure;
        queue_.clear();
      }
    }
    idle_.notify_all();
  }
}

void MappingWorker::process(KeyframeId keyframe) {
  const Stopwatch watch;
  MappingReport report;
  report.keyframe = keyframe;
  const LocalMappingConfig& config = mapper_.config();
  std::optional<LocalBaProblem> problem;
  {
    const std::lock_guard<std::mutex> lock(map_mutex_);
    report.culled_points = mapper_.cull_recent_points(keyframe, map_);
    if (config.triangulate) report.triangulated = mapper_.triangulate(keyframe, map_);
    mapper_.fuse_or_link(keyframe, map_, report);
    if (config.local_ba) problem = mapper_.prepare_local_ba(keyframe, map_);
  }
  std::optional<BaResult> solved;
  if (problem) solved = mapper_.solve_local_ba(*problem);  // without the lock: tracking goes on
  {
    const std::lock_guard<std::mutex> lock(map_mutex_);
    if (problem) report.ba = mapper_.apply_local_ba(*problem, *solved, map_);
    if (config.cull_keyframes) report.culled_keyframes = mapper_.cull_keyframes(keyframe, map_);
    changes_.record(report);
  }
  report.ms = watch.elapsed_ms();
  logger_->debug("worker: keyframe {}: {} culled points, {} triangulated, {} fused, BA rms {:.3f} -> {:.3f} px, "
                 "{} keyframes culled, {:.1f} ms",
                 keyframe, report.culled_points, report.triangulated, report.fused, report.ba.initial_rms_px,
                 report.ba.final_rms_px, report.culled_keyframes.size(), report.ms);
}

}  // namespace fleetslam::slam
