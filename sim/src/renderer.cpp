#include "renderer.hpp"

// GL 3.0 framebuffer entry points, exported by libOSMesa (declared only with this, before any GL header).
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES
#endif
#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
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

// Depth from the 24-bit z-buffer value z (d = z / Z, Z = 2^24 - 1, read with the stencil byte below it):
// near far / (far - d (far - near)) = 1 / (1/far + (Z - z) (1/near - 1/far) / Z). Z - z is an integer
// below 2^24, exact in float, so the float form has four roundings: within 3 ulp (under 4e-7 relative,
// 4 um at 10 m) of the exact value for every z with near 5 cm and far 10-100 m (checked exhaustively);
// sim_test_world checks depth against analytic planes. z == Z is the far plane: nothing was hit,
// depth 0. The loop vectorises, with an AVX2 clone where GCC dispatches at load time (the same
// values: no fused multiply-add).
constexpr std::uint32_t kDepthMax = (1u << 24) - 1;

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
__attribute__((target_clones("avx2", "default")))
#endif
void linearize_row(const std::uint32_t* depth_stencil, std::size_t n, float inv_far, float step_per_unit,
                   float* depth_m) {
  for (std::size_t i = 0; i < n; ++i) {
    const auto units_to_far = static_cast<std::int32_t>(kDepthMax - (depth_stencil[i] >> 8));
    depth_m[i] = select(units_to_far > 0, 1.0f / (inv_far + step_per_unit * static_cast<float>(units_to_far)), 0.0f);
  }
}

std::string gl_error_text(GLenum error) {
  std::ostringstream text;
  text << "0x" << std::hex << error;
  return text.str();
}

}  // namespace

struct Renderer::Impl {
  OSMesaContext gl = nullptr;
  std::vector<unsigned char> gl_buffer;  // OSMesa's window buffer (unused: MuJoCo renders offscreen)
  int buffer_width = 0;
  int buffer_height = 0;

  // The GL context is per thread and per renderer: another renderer (a second World) or another thread
  // may have made its own current since, and MuJoCo's buffers and textures live in this one.
  bool make_current() {
    return OSMesaGetCurrentContext() == gl ||
           OSMesaMakeCurrent(gl, gl_buffer.data(), GL_UNSIGNED_BYTE, buffer_width, buffer_height) != 0;
  }
  mjvScene scene{};
  mjrContext context{};
  mjvOption option{};
  std::vector<unsigned char> bgra;          // bottom-up rows read from the offscreen buffer
  std::vector<std::uint32_t> depth_stencil;  // bottom-up rows: 24-bit depth, 8-bit stencil
  std::vector<unsigned char> sky_scratch;   // the colour of the depth pass without the skybox (unused)
  double near_m = 0.0;
  double far_m = 0.0;
};

Renderer::Renderer(const mjModel* model, int max_width, int max_height) : impl_(std::make_unique<Impl>()) {
  // The context must be current before mjr_makeContext, which then finds OSMesaGetProcAddress.
  impl_->gl = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (impl_->gl == nullptr) throw Error("OSMesa: cannot create an off-screen GL context");
  impl_->gl_buffer.resize(static_cast<std::size_t>(max_width) * static_cast<std::size_t>(max_height) * 4);
  impl_->buffer_width = max_width;
  impl_->buffer_height = max_height;
  if (!OSMesaMakeCurrent(impl_->gl, impl_->gl_buffer.data(), GL_UNSIGNED_BYTE, max_width, max_height)) {
    OSMesaDestroyContext(impl_->gl);
    throw Error("OSMesa: cannot make the off-screen GL context current");
  }
  mjv_defaultScene(&impl_->scene);
  // Room for every geom of the model and MuJoCo's decorations: a full scene would drop geoms from the
  // images while surface_points() still samples them.
  mjv_makeScene(model, &impl_->scene, std::max(4000, 2 * model->ngeom + 1000));
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
  // MuJoCo frees its GL objects in the current context: this renderer's.
  impl_->make_current();
  mjr_freeContext(&impl_->context);
  mjv_freeScene(&impl_->scene);
  OSMesaDestroyContext(impl_->gl);
}

void Renderer::render(const mjModel* model, mjData* data, int camera_id, int width, int height,
                      const RenderOptions& options, cv::Mat* bgr, cv::Mat* depth_m) {
  if (!impl_->make_current()) throw Error("OSMesa: cannot make the off-screen GL context current");
  mjvCamera camera;
  mjv_defaultCamera(&camera);
  camera.type = mjCAMERA_FIXED;
  camera.fixedcamid = camera_id;
  mjv_updateScene(model, data, &impl_->option, nullptr, &camera, mjCAT_ALL, &impl_->scene);
  impl_->scene.flags[mjRND_SHADOW] = options.shadows ? 1 : 0;
  impl_->scene.flags[mjRND_SKYBOX] = 1;
  const mjrRect viewport{0, 0, width, height};
  mjr_render(viewport, &impl_->scene, &impl_->context);

  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  const bool depth = options.want_depth && depth_m != nullptr;
  impl_->bgra.resize(pixels * 4);
  impl_->depth_stencil.resize(depth ? pixels : 0);
  // A skybox is drawn as a shell 0.7 zfar around the camera, with depth: the depth buffer would hold it
  // as a surface hundreds of metres away where nothing was hit. With one, the colour comes from this pass
  // and the depth from a second without it (sky pixels then stay at the far plane: depth 0).
  bool skybox = false;
  for (int t = 0; t < model->ntex && !skybox; ++t) skybox = model->tex_type[t] == mjTEXTURE_SKYBOX;
  if (depth && skybox) {
    read_offscreen(viewport, impl_->bgra.data(), nullptr);
    impl_->scene.flags[mjRND_SKYBOX] = 0;
    mjr_render(viewport, &impl_->scene, &impl_->context);
    impl_->sky_scratch.resize(pixels * 4);
    read_offscreen(viewport, impl_->sky_scratch.data(), impl_->depth_stencil.data());
  } else {
    read_offscreen(viewport, impl_->bgra.data(), depth ? impl_->depth_stencil.data() : nullptr);
  }

  // Rows come bottom-up: output row r is input row height - 1 - r, BGRA -> BGR by one SIMD call per
  // row (hal::cvtBGRtoBGR dispatches to the CPU's widest instructions, and a single row stays on the
  // calling thread), and the z-buffer linearised (see linearize_row), rows in parallel on OpenCV's
  // thread pool.
  *bgr = cv::Mat(height, width, CV_8UC3);
  if (depth) {
    *depth_m = cv::Mat(height, width, CV_32FC1);
  } else if (depth_m != nullptr) {
    *depth_m = cv::Mat();
  }
  const std::size_t bgra_step = static_cast<std::size_t>(width) * 4;
  const auto inv_far = static_cast<float>(1.0 / impl_->far_m);
  const auto step_per_unit = static_cast<float>((1.0 / impl_->near_m - 1.0 / impl_->far_m) / kDepthMax);
  const unsigned char* bgra = impl_->bgra.data();
  const std::uint32_t* depth_stencil = impl_->depth_stencil.data();
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
    for (int row = rows.start; row < rows.end; ++row) {
      const auto source_row = static_cast<std::size_t>(height - 1 - row);
      cv::hal::cvtBGRtoBGR(bgra + source_row * bgra_step, bgra_step, bgr->ptr<unsigned char>(row), bgr->step[0], width,
                           1, CV_8U, 4, 3, false);
      if (depth) {
        linearize_row(depth_stencil + source_row * static_cast<std::size_t>(width), static_cast<std::size_t>(width),
                      inv_far, step_per_unit, depth_m->ptr<float>(row));
      }
    }
  }, 8);
}

// Reads the offscreen buffer as mjr_readPixels does (resolving multisamples into MuJoCo's resolve
// buffer first), but in the formats llvmpipe stores: BGRA bytes and packed 24-bit depth with 8-bit
// stencil, which it copies without converting each pixel (about half the time of mjr_readPixels'
// RGB bytes and float depth at 640x480).
void Renderer::read_offscreen(const mjrRect& viewport, unsigned char* bgra, std::uint32_t* depth_stencil) {
  const mjrContext& con = impl_->context;
  glBindFramebuffer(GL_READ_FRAMEBUFFER, con.offFBO);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  if (con.offSamples > 0) {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, con.offFBO_r);
    glDrawBuffer(GL_COLOR_ATTACHMENT0);
    const int right = viewport.left + viewport.width;
    const int top = viewport.bottom + viewport.height;
    glBlitFramebuffer(viewport.left, viewport.bottom, right, top, viewport.left, viewport.bottom, right, top,
                      GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT, GL_NEAREST);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, con.offFBO_r);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
  }
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(viewport.left, viewport.bottom, viewport.width, viewport.height, GL_BGRA, GL_UNSIGNED_BYTE, bgra);
  if (depth_stencil != nullptr) {
    glReadPixels(viewport.left, viewport.bottom, viewport.width, viewport.height, GL_DEPTH_STENCIL,
                 GL_UNSIGNED_INT_24_8, depth_stencil);
  }
  const GLenum error = glGetError();
  mjr_restoreBuffer(&impl_->context);
  if (error != GL_NO_ERROR) {
    throw Error("OpenGL: reading the offscreen buffer failed (error " + gl_error_text(error) +
                "; it must hold 8-bit colour and 24-bit depth with 8-bit stencil)");
  }
}

}  // namespace fleetslam::sim::detail
