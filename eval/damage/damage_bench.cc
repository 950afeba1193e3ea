#include "eval/damage/damage_bench.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "sim/synthetic_damage_scene.h"
#include "stages/damage/output/damage_output.h"
#include "stages/damage/damage_pipeline.h"
#include "survey/elapsed.h"

namespace rs {
DamageBench BenchDetectDamage(int width, int height, int repeats) {
  const SyntheticRoadScene scene = BenchmarkRoadScene(width, height);
  const cv::Mat disparity = scene.Render(), image = scene.RenderImage();
  const DamageOptions options;
  options.Check();
  const std::vector<std::string> names = DamagePassNames();
  std::vector<double> wall, cpu, outputs, encode;
  std::vector<std::vector<double>> passes(names.size());
  DamageBench b;
  for (int i = 0; i < std::max(1, repeats); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    const FrameDamage f = DetectDamage(disparity, image, scene.geometry, options);
    const auto t1 = std::chrono::steady_clock::now();
    const cv::Mat overlay = RenderOverlay(image, f.labels, f.instances);
    const std::string json = DetectionsToJson(f.instances).dump(2);
    cpu.push_back(1000.0 * double(std::clock() - c0) / CLOCKS_PER_SEC);
    wall.push_back(MsSince(t0));
    for (size_t k = 0; k < names.size(); ++k) passes[k].push_back(f.PassMs(names[k]));
    outputs.push_back(MsSince(t1));
    const auto t2 = std::chrono::steady_clock::now();
    std::vector<uchar> png;
    cv::imencode(".png", f.labels, png);
    cv::imencode(".png", overlay, png);
    encode.push_back(MsSince(t2));
    b.potholes = b.cracks = b.others = 0;
    for (const DamageInstance& d : f.instances)
      (d.type == DamageType::kPothole ? b.potholes : d.type == DamageType::kCrack ? b.cracks : b.others)++;
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  b.wall_ms = median(wall), b.cpu_ms = median(cpu);
  for (size_t k = 0; k < names.size(); ++k) b.pass_ms.push_back({names[k], median(passes[k])});
  b.outputs_ms = median(outputs), b.encode_ms = median(encode);
  return b;
}

}  // namespace rs
