// disparity_bench: our GPT-SGM and SGM vs OpenCV StereoSGBM (SGBM, SGBM_3WAY) on the same
// pairs in one process. Usage: disparity_bench [--data DIR] [--reps N] [--no-middlebury]
// [--paths 4|8] [--gpt-range N] [--threads N] [--only gpt-sgm|sgm|sgbm|sgbm-3way]
// or: disparity_bench --fan2021 MODEL3_DIR [--out DIR] [--scale S] (real road pairs -> PNG previews)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include <memory>

#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "stages/disparity/disparity_benchmark.h"
#include "stages/disparity/disparity_io.h"

namespace {

// Real road pairs (pothole_recon_fan2021/model3): GPT-SGM per pair, road model and density
// printed, colour-mapped disparity and transformed disparity written under out_dir.
int RunFan2021(const std::string& dir, const std::string& out_dir, double scale, rs::DisparityParams params) {
  params.num_disparities = 256;  // fallback range at the working scale
  // A rig ~1 m above the road: potholes reach ~15 px below the road at half size.
  params.gpt_delta_px = 20, params.gpt_num_disparities = 48;
  std::printf("| pair | size | road model a0, a1, roll | matches / inliers | RMS px | reliable | disparities | valid density (all) | valid density (road visible in right view) | ms |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
  for (int i = 1; i <= 5; ++i) {
    const std::string lp = dir + "/left images/L" + std::to_string(i) + ".png";
    const std::string rp = dir + "/right images/R" + std::to_string(i) + ".png";
    cv::Mat l = cv::imread(lp, cv::IMREAD_GRAYSCALE), r = cv::imread(rp, cv::IMREAD_GRAYSCALE);
    if (l.empty() || r.empty()) {
      std::fprintf(stderr, "cannot read %s or %s\n", lp.c_str(), rp.c_str());
      return 1;
    }
    cv::resize(l, l, cv::Size(), scale, scale, cv::INTER_AREA);
    cv::resize(r, r, cv::Size(), scale, scale, cv::INTER_AREA);
    const rs::DisparityResult res = rs::ComputeDisparity(l, r, params);
    const rs::RoadModel& m = res.road;
    int64_t visible = 0, visible_valid = 0;  // pixels whose road point lies inside the right image
    for (int v = 0; v < l.rows; ++v)
      for (int u = 0; u < l.cols; ++u)
        if (u - m.At(u, v) >= 0) ++visible, visible_valid += res.valid.at<uint8_t>(v, u) != 0;
    std::printf("| L%d/R%d | %dx%d | %.2f, %.4f, %.2f deg | %d / %d | %.2f | %s | %d%s | %.1f %% | %.1f %% | %.0f |\n", i, i, l.cols,
                l.rows, m.a0, m.a1, m.roll_rad * 180 / M_PI, m.num_matches, m.num_inliers, m.residual_rms_px,
                m.reliable ? "yes" : "no", res.num_disparities, res.fell_back ? " (fell back)" : "",
                100 * res.valid_fraction, 100.0 * visible_valid / std::max<int64_t>(1, visible), res.timings.total_ms);
    if (out_dir.empty()) continue;
    std::vector<float> vals;  // colour range: 0.5th to 99.5th percentile of valid disparities
    for (int v = 0; v < l.rows; ++v)
      for (int u = 0; u < l.cols; ++u)
        if (res.valid.at<uint8_t>(v, u)) vals.push_back(res.disparity.at<float>(v, u));
    if (vals.empty()) continue;
    std::sort(vals.begin(), vals.end());
    const double lo = vals[vals.size() / 200], hi = vals[vals.size() - 1 - vals.size() / 200];
    cv::Mat small_d, small_t, small_v;
    const cv::Size preview(l.cols / 2, l.rows / 2);  // keeps each PNG well under 300 KB
    cv::resize(res.disparity, small_d, preview, 0, 0, cv::INTER_NEAREST);
    cv::resize(res.transformed, small_t, preview, 0, 0, cv::INTER_NEAREST);
    cv::resize(res.valid, small_v, preview, 0, 0, cv::INTER_NEAREST);
    const std::string base = out_dir + "/disparity_fan2021_model3_" + std::to_string(i);
    cv::imwrite(base + "_disparity.png", rs::ColorizeDisparity(small_d, small_v, std::floor(lo), std::ceil(hi)),
                {cv::IMWRITE_PNG_COMPRESSION, 9});
    cv::imwrite(base + "_transformed.png",
                rs::ColorizeDisparity(small_t, small_v, params.gpt_delta_px - 12, params.gpt_delta_px + 3),
                {cv::IMWRITE_PNG_COMPRESSION, 9});
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = std::getenv("ROADSURVEY_DATA") ? std::getenv("ROADSURVEY_DATA") : "";
  int reps = 5;
  bool middlebury = true;
  rs::DisparityParams params;
  int threads = 0;
  std::string fan_dir, out_dir, only;
  double fan_scale = 0.5;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--data") && i + 1 < argc) data = argv[++i];
    else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) reps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--no-middlebury")) middlebury = false;
    else if (!std::strcmp(argv[i], "--fan2021") && i + 1 < argc) fan_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--out") && i + 1 < argc) out_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--scale") && i + 1 < argc) fan_scale = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
    else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--paths") && i + 1 < argc) params.num_paths = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--gpt-range") && i + 1 < argc) params.gpt_num_disparities = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: disparity_bench [--data DIR] [--reps N] [--no-middlebury] [--paths 4|8] [--gpt-range N] [--threads N] [--only METHOD]\n"
                         "       disparity_bench --fan2021 MODEL3_DIR [--out DIR] [--scale S]\n");
      return 2;
    }
  }
  std::unique_ptr<tbb::global_control> limit;
  if (threads > 0) {  // same thread budget for ours (oneTBB) and OpenCV
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
    cv::setNumThreads(threads);
  }
  try {
    if (!fan_dir.empty()) return RunFan2021(fan_dir, out_dir, fan_scale, params);
    std::vector<rs::StereoPairWithTruth> pairs;
    pairs.push_back(rs::MakeSyntheticRoadPair(rs::SyntheticRoadOptions{}));
    if (middlebury && !data.empty()) {
      auto mb = rs::LoadMiddlebury(data + "/middlebury");
      pairs.insert(pairs.end(), mb.begin(), mb.end());
    }
    const auto results = rs::RunDisparityBenchmark(pairs, params, reps, only);
    std::printf("%s\n%s\n", rs::FormatBenchmarkTable(results).c_str(), rs::FormatStepTimes(results).c_str());
    for (const auto& r : results)
      std::printf("%s: gpt-sgm/sgbm-3way time %.2f, sgm/sgbm-3way %.2f (medians of %d runs)\n", r.pair.c_str(),
                  r.Ratio("gpt-sgm", "sgbm-3way"), r.Ratio("sgm", "sgbm-3way"), reps);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "disparity_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
