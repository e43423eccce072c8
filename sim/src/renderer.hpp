#pragma once
// Internal: one OSMesa GL context and MuJoCo render context shared by every camera of a world.

#include <cstdint>
#include <memory>

#include <opencv2/core/mat.hpp>

#include "mujoco_util.hpp"

namespace fleetslam::sim::detail {

struct RenderOptions {
  bool shadows = false;
  bool want_depth = true;
};

class Renderer {
 public:
  // Creates the GL context and uploads the model's meshes and textures. Throws fleetslam::Error when
  // OSMesa cannot create a context, InputError-free otherwise. `max_width/height` must fit the model's
  // offscreen buffer (the World sets it from the largest camera).
  Renderer(const mjModel* model, int max_width, int max_height);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders fixed camera `camera_id` at the data's current state. bgr: CV_8UC3 top-down; depth_m:
  // CV_32FC1 metric depth along the optical axis (0 where nothing was hit), or empty without want_depth.
  void render(const mjModel* model, mjData* data, int camera_id, int width, int height,
              const RenderOptions& options, cv::Mat* bgr, cv::Mat* depth_m);

 private:
  // bgra: width x height x 4 bytes; depth_stencil: width x height words, or null for no depth.
  // Throws fleetslam::Error when GL reports an error.
  void read_offscreen(const mjrRect& viewport, unsigned char* bgra, std::uint32_t* depth_stencil);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fleetslam::sim::detail
