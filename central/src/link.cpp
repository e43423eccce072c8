#include "fleetslam/central/link.hpp"

#include <iterator>
#include <utility>

namespace fleetslam::central {

void InProcessLink::send(slam::AgentUpdate update) {
  const std::lock_guard<std::mutex> lock(mutex_);
  queue_.push_back(std::move(update));
}

std::vector<slam::AgentUpdate> InProcessLink::receive() {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<slam::AgentUpdate> out(std::make_move_iterator(queue_.begin()), std::make_move_iterator(queue_.end()));
  queue_.clear();
  return out;
}

std::size_t InProcessLink::pending() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

}  // namespace fleetslam::central
