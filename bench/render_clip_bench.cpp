// Drawing far beyond the image costs only the visible part (src/render/clip.hpp): the time of dashed lines billions
// of pixels long, against one as long as the image, as JSON lines. Speed is measured here, never asserted in a test
// (tests/render/test_render_image.cpp checks what such lines draw).
//
//   build/release/bench/tsdf_mcl_render_clip_bench [REPETITIONS]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "tsdf_mcl/render/image.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double median_ms(int repetitions, float length) {
  std::vector<double> ms;
  for (int k = 0; k < repetitions; ++k) {
    tsdf_mcl::Image image(100, 20);
    const auto t0 = Clock::now();
    image.draw_dashed_line({0.0f, 10.5f}, {length, 10.5f}, tsdf_mcl::colors::kBlack, 1.0f, 10.0f);
    image.draw_dashed_polyline({{-length, 5.5f}, {length, 5.5f}}, tsdf_mcl::colors::kBlack, 1.0f, 10.0f);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  std::nth_element(ms.begin(), ms.begin() + static_cast<std::ptrdiff_t>(ms.size() / 2), ms.end());
  return ms[ms.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int repetitions = argc > 1 ? std::max(1, std::atoi(argv[1])) : 20;
  for (const float length : {100.0f, 1e6f, 4e9f}) {
    std::printf(
        "{\"bench\": \"render_dashed_lines\", \"length_px\": %.0f, \"image_px\": 100, \"repetitions\": %d, "
        "\"median_ms\": %.4f}\n",
        static_cast<double>(length), repetitions, median_ms(repetitions, length));
  }
  return 0;
}
