// fieldline-bench-camera: milliseconds per rendered omni frame (simulated camera) at 320x240 and
// 640x480, with an empty field and with a ball and five other robots; and the cost of colour
// classification per pixel. Results and the command line are recorded in docs/camera.md.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "common/camera/colour.hpp"
#include "common/field/field_model.hpp"
#include "common/geometry/geometry.hpp"
#include "services/camera/camera_config.hpp"
#include "services/camera/sim_renderer.hpp"

namespace camera = fieldline::camera;
namespace geometry = fieldline::geometry;

namespace {

std::unique_ptr<camera::SimRenderer> makeRenderer(const std::string& preset, int blur_samples,
                                                  const std::string& raster_cache = {}) {
  camera::CameraConfig config = camera::loadCameraConfigPreset(preset);
  config.render->motion_blur_samples = blur_samples;
  const fieldline::field::FieldModel field = fieldline::field::loadFieldPreset("msl");
  return std::make_unique<camera::SimRenderer>(config.model.mirror, field, *config.render,
                                               raster_cache);
}

// A robot driving a circle through the penalty area; frames differ in pose and noise.
camera::SimScene sceneAt(std::int64_t frame, bool objects) {
  camera::SimScene scene;
  const double t = frame / 30.0;
  scene.robot = {6.0 + 2.0 * std::cos(0.5 * t), 1.0 + 2.0 * std::sin(0.5 * t), 0.5 * t + 1.6};
  scene.velocity = {-std::sin(0.5 * t), std::cos(0.5 * t)};
  scene.omega = 0.5;
  scene.frame_number = static_cast<std::uint64_t>(frame);
  if (objects) {
    scene.ball = camera::SimBall{{7.0, 0.0}, 0.11};
    for (int k = 0; k < 5; ++k) {
      scene.robots.push_back({{4.0 + 1.5 * k, -2.0 + 1.0 * k}, 0.25, k % 2 == 0});
    }
  }
  return scene;
}

void renderBenchmark(benchmark::State& state, const std::string& preset, bool objects,
                     int blur_samples) {
  const std::unique_ptr<camera::SimRenderer> renderer = makeRenderer(preset, blur_samples);
  std::vector<std::uint8_t> frame;
  std::int64_t n = 0;
  for (auto _ : state) {
    renderer->render(sceneAt(n++, objects), frame);
    benchmark::DoNotOptimize(frame.data());
    benchmark::ClobberMemory();
  }
  state.SetLabel(std::to_string(renderer->width()) + "x" + std::to_string(renderer->height()));
}

// Six cameras rendering in turn, each with its own renderer (its own raster, as six camera
// processes have) at another place on the field: the live team's caches, where one camera's
// raster cells are gone by its next frame. Time per frame.
void sixCameras(benchmark::State& state, const std::string& raster_cache) {
  std::vector<std::unique_ptr<camera::SimRenderer>> renderers;
  for (int k = 0; k < 6; ++k)
    renderers.push_back(makeRenderer("omni_sim", 1, raster_cache));
  std::vector<std::uint8_t> frame;
  std::int64_t n = 0;
  for (auto _ : state) {
    const auto camera = static_cast<std::size_t>(n % 6);
    camera::SimScene scene = sceneAt(n / 6, true);
    scene.robot.x -= 2.5 * static_cast<double>(camera);
    scene.robot.y *= camera % 2 == 0 ? 1.0 : -1.0;
    renderers[camera]->render(scene, frame);
    benchmark::DoNotOptimize(frame.data());
    benchmark::ClobberMemory();
    ++n;
  }
}

void BM_Render320SixCameras(benchmark::State& state) {
  sixCameras(state, "");
}
// The same six sharing one raster: the cache file mapped by each (as the team's cameras do).
void BM_Render320SixCamerasShared(benchmark::State& state) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("fieldline_bench_raster_" + std::to_string(::getpid()));
  sixCameras(state, dir.string());
  std::error_code ignored;
  std::filesystem::remove_all(dir, ignored);
}

void BM_Render320Empty(benchmark::State& s) {
  renderBenchmark(s, "omni_sim", false, 1);
}
void BM_Render320Objects(benchmark::State& s) {
  renderBenchmark(s, "omni_sim", true, 1);
}
void BM_Render320ObjectsBlur3(benchmark::State& s) {
  renderBenchmark(s, "omni_sim", true, 3);
}
void BM_Render640Empty(benchmark::State& s) {
  renderBenchmark(s, "omni_sim_640", false, 1);
}
void BM_Render640Objects(benchmark::State& s) {
  renderBenchmark(s, "omni_sim_640", true, 1);
}

void BM_RendererSetup320(benchmark::State& state) {
  for (auto _ : state)
    benchmark::DoNotOptimize(makeRenderer("omni_sim", 1));
}

// Classifying every pixel of a rendered 320x240 YUYV frame through the lookup table.
void BM_ClassifyFrame320(benchmark::State& state) {
  const std::unique_ptr<camera::SimRenderer> renderer = makeRenderer("omni_sim", 1);
  const camera::ColourTable table = camera::loadColourTablePreset("colours_sim");
  std::vector<std::uint8_t> frame;
  renderer->render(sceneAt(0, true), frame);
  const camera::FrameView view = renderer->view(frame);
  for (auto _ : state) {
    int green = 0;
    for (int v = 0; v < view.height; ++v) {
      for (int u = 0; u < view.width; ++u) {
        green += table.classifyPixel(view, u, v) == camera::ColourClass::kGreen;
      }
    }
    benchmark::DoNotOptimize(green);
  }
  state.SetItemsProcessed(state.iterations() * view.width * view.height);
}

}  // namespace

BENCHMARK(BM_Render320Empty)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Render320Objects)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Render320SixCameras)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Render320SixCamerasShared)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Render320ObjectsBlur3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Render640Empty)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Render640Objects)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RendererSetup320)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_ClassifyFrame320)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
