#pragma once
// How agents' updates reach the central unit. The server only ever sees value messages through this
// interface, so a transport between processes (a socket, a bag file) can implement it without the
// server changing; the in-process queue is the default.

#include <cstddef>
#include <deque>
#include <mutex>
#include <vector>

#include "fleetslam/slam/agent.hpp"

namespace fleetslam::central {

class Link {
 public:
  virtual ~Link() = default;
  // Agent side: hands one update over (never blocks for long; thread-safe).
  virtual void send(slam::AgentUpdate update) = 0;
  // Server side: every update sent since the last call, in the order they were sent.
  virtual std::vector<slam::AgentUpdate> receive() = 0;
};

// A mutex-guarded FIFO: agents may send from their own threads.
class InProcessLink final : public Link {
 public:
  void send(slam::AgentUpdate update) override;
  std::vector<slam::AgentUpdate> receive() override;
  std::size_t pending() const;

 private:
  mutable std::mutex mutex_;
  std::deque<slam::AgentUpdate> queue_;
};

}  // namespace fleetslam::central
