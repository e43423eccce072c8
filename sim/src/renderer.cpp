#include "renderer.hpp"

#include <GL/osmesa.h>

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "fleetslam/core/error.hpp"

namespace fleetslam::sim::detail {

struct Renderer::Impl {
  OSMesaContext gl = nullptr;
  std::vector<unsigned char> gl_buffer;  // OSMesa's window buffer (unused: MuJoCo renders offscreen)
  mjvScene scene{};
  mjrContext context{};
  mjvOption option{};
  std::vector<unsigned char> rgb;  // bottom-up rows from mjr_readPixels
  std::vector<float> zbuffer;
  double near_m = 0.0;
  double far_m = 0.0;
};

Renderer::Renderer(const mjModel* model, int max_width, int max_height) : impl_(std::make_unique<Impl>()) {
  // The context must be current before mjr_makeContext, which then finds OSMesaGetProcAddress.
  impl_->gl = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (impl_->gl == nullptr) throw Error("OSMesa: cannot create an off-screen GL context");
  impl_->gl_buffer.resize(static_cast<std::size_t>(max_width) * static_cast<std::size_t>(max_height) * 4);
  if (!OSMesaMakeCurrent(impl_->gl, impl_->gl_buffer.data(), GL_UNSIGNED_BYTE, max_width, max_height)) {
    OSMesaDestroyContext(impl_->gl);
    throw Error("OSMesa: cannot make the off-screen GL context current");
  }
  mjv_defaultScene(&impl_->scene);
  mjv_makeScene(model, &impl_->scene, 4000);
  mjr_defaultContext(&impl_->context);
  mjr_makeContext(model, &impl_->context, mjFONTSCALE_100);
  mjr_setBuffer(mjFB_OFFSCREEN, &impl_->context);
  if (impl_->context.offWidth < max_width || impl_->context.offHeight < max_height) {
    const std::string have = std::to_string(impl_->context.offWidth) + "x" + std::to_string(impl_->context.offHeight);
    mjr_freeContext(&impl_->context);
    mjv_freeScene(&impl_->scene);
    OSMesaDestroyContext(impl_->gl);
    throw Error("the off-screen buffer is " + have + ", smaller than the largest camera " +
                std::to_string(max_width) + "x" + std::to_string(max_height));
  }
  mjv_defaultOption(&impl_->option);
  impl_->near_m = static_cast<double>(model->vis.map.znear) * model->stat.extent;
  impl_->far_m = static_cast<double>(model->vis.map.zfar) * model->stat.extent;
}

Renderer::~Renderer() {
  mjr_freeContext(&impl_->context);
  mjv_freeScene(&impl_->scene);
  OSMesaDestroyContext(impl_->gl);
}

void Renderer::render(const mjModel* model, mjData* data, int camera_id, int width, int height,
                      const RenderOptions& options, cv::Mat* bgr, cv::Mat* depth_m) {
  mjvCamera camera;
  mjv_defaultCamera(&camera);
  camera.type = mjCAMERA_FIXED;
  camera.fixedcamid = camera_id;
  mjv_updateScene(model, data, &impl_->option, nullptr, &camera, mjCAT_ALL, &impl_->scene);
  impl_->scene.flags[mjRND_SHADOW] = options.shadows ? 1 : 0;
  const mjrRect viewport{0, 0, width, height};
  mjr_render(viewport, &impl_->scene, &impl_->context);

  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  impl_->rgb.resize(pixels * 3);
  impl_->zbuffer.resize(options.want_depth ? pixels : 0);
  mjr_readPixels(impl_->rgb.data(), options.want_depth ? impl_->zbuffer.data() : nullptr, viewport,
                 &impl_->context);

  // Rows come bottom-up; flip to top-down and RGB -> BGR.
  *bgr = cv::Mat(height, width, CV_8UC3);
  for (int row = 0; row < height; ++row) {
    const unsigned char* src = impl_->rgb.data() + static_cast<std::size_t>(height - 1 - row) * width * 3;
    auto* dst = bgr->ptr<unsigned char>(row);
    for (int col = 0; col < width; ++col) {
      dst[3 * col + 0] = src[3 * col + 2];
      dst[3 * col + 1] = src[3 * col + 1];
      dst[3 * col + 2] = src[3 * col + 0];
    }
  }
  if (!options.want_depth || depth_m == nullptr) {
    if (depth_m != nullptr) *depth_m = cv::Mat();
    return;
  }
  // Linearise the z-buffer: depth = near * far / (far - d * (far - near)) (checked against ray casts
  // to micrometres, DESIGN.md). d == 1 is the far plane: nothing was hit.
  const double near_m = impl_->near_m;
  const double far_m = impl_->far_m;
  *depth_m = cv::Mat(height, width, CV_32FC1);
  for (int row = 0; row < height; ++row) {
    const float* src = impl_->zbuffer.data() + static_cast<std::size_t>(height - 1 - row) * width;
    auto* dst = depth_m->ptr<float>(row);
    for (int col = 0; col < width; ++col) {
      const double d = static_cast<double>(src[col]);
      dst[col] = d >= 1.0 ? 0.0f : static_cast<float>(near_m * far_m / (far_m - d * (far_m - near_m)));
    }
  }
}

}  // namespace fleetslam::sim::detail
