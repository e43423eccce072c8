#include "renderer.hpp"

#include <GL/osmesa.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc/hal/hal.hpp>

#include "fleetslam/core/error.hpp"

namespace fleetslam::sim::detail {
namespace {

// a where c, else b, as a bitwise select: unlike ?:, it keeps linearize_row free of branches for the
// vectoriser (GCC will not evaluate a division that only one branch needs on both).
float select(bool c, float a, float b) {
  std::uint32_t a_bits, b_bits;
  std::memcpy(&a_bits, &a, sizeof a);
  std::memcpy(&b_bits, &b, sizeof b);
  const std::uint32_t mask = 0u - static_cast<std::uint32_t>(c);
  const std::uint32_t bits = (a_bits & mask) | (b_bits & ~mask);
  float r;
  std::memcpy(&r, &bits, sizeof r);
  return r;
}

// Depth from z-buffer values d: near far / (far - d (far - near)) = 1 / (1/far + (1 - d)(1/near - 1/far)).
// The second form in float is well conditioned (1 - d is exact for d >= 0.5, every other step adds a
// relative error of at most half an ulp): within 3 ulp (2.5e-7 relative, 3 um below 20 m) of the first
// in double for every 24-bit z-buffer value; sim_test_world checks depth against analytic planes.
// d == 1 is the far plane: nothing was hit, depth 0. The loop vectorises, with an AVX2 clone where GCC
// dispatches at load time (the same values: no fused multiply-add).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
__attribute__((target_clones("avx2", "default")))
#endif
void linearize_row(const float* d, std::size_t n, float inv_far, float inv_near_minus_inv_far, float* depth_m) {
  for (std::size_t i = 0; i < n; ++i) {
    depth_m[i] = select(d[i] < 1.0f, 1.0f / (inv_far + inv_near_minus_inv_far * (1.0f - d[i])), 0.0f);
  }
}

}  // namespace

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

  // Rows come bottom-up: output row r is input row height - 1 - r, RGB -> BGR by one SIMD call per
  // row (hal::cvtBGRtoBGR dispatches to the CPU's widest instructions, and a single row stays on this
  // thread).
  *bgr = cv::Mat(height, width, CV_8UC3);
  const std::size_t rgb_step = static_cast<std::size_t>(width) * 3;
  for (int row = 0; row < height; ++row) {
    const unsigned char* src = impl_->rgb.data() + static_cast<std::size_t>(height - 1 - row) * rgb_step;
    cv::hal::cvtBGRtoBGR(src, rgb_step, bgr->ptr<unsigned char>(row), bgr->step[0], width, 1, CV_8U, 3, 3, true);
  }
  if (!options.want_depth || depth_m == nullptr) {
    if (depth_m != nullptr) *depth_m = cv::Mat();
    return;
  }
  // Linearise the z-buffer (see linearize_row).
  const auto inv_far = static_cast<float>(1.0 / impl_->far_m);
  const auto inv_near_minus_inv_far = static_cast<float>(1.0 / impl_->near_m - 1.0 / impl_->far_m);
  *depth_m = cv::Mat(height, width, CV_32FC1);
  for (int row = 0; row < height; ++row) {
    const float* src =
        impl_->zbuffer.data() + static_cast<std::size_t>(height - 1 - row) * static_cast<std::size_t>(width);
    linearize_row(src, static_cast<std::size_t>(width), inv_far, inv_near_minus_inv_far, depth_m->ptr<float>(row));
  }
}

}  // namespace fleetslam::sim::detail
