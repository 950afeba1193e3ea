#include "eval/disparity/disparity_benchmark.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <map>

#include <opencv2/calib3d.hpp>

namespace rs {
namespace {

double ProcessCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double Median(std::vector<double> t) {
  std::nth_element(t.begin(), t.begin() + t.size() / 2, t.end());
  return t[t.size() / 2];
}

}  // namespace

void RunStereoSgbm(const cv::Mat& left, const cv::Mat& right, int min_d, int num_d, bool three_way, cv::Mat* disparity,
                   cv::Mat* valid) {
  const int bs = 5, cn = 1;
  const int nd = (num_d + 15) / 16 * 16;
  auto sgbm = cv::StereoSGBM::create(min_d, nd, bs, 8 * cn * bs * bs, 32 * cn * bs * bs, 1, 63, 10, 100, 2,
                                     three_way ? cv::StereoSGBM::MODE_SGBM_3WAY : cv::StereoSGBM::MODE_SGBM);
  cv::Mat raw;
  sgbm->compute(left, right, raw);  // CV_16S, 1/16 px, invalid = (min_d - 1) * 16
  *valid = raw > (min_d - 1) * 16;
  raw.convertTo(*disparity, CV_32F, 1.0 / 16.0);
  disparity->setTo(0, *valid == 0);
}

const BenchMethodResult* BenchPairResult::Find(const std::string& m) const {
  for (const auto& r : methods)
    if (r.method == m) return &r;
  return nullptr;
}

double BenchPairResult::Ratio(const std::string& m, const std::string& b) const {
  const auto *x = Find(m), *y = Find(b);
  return x && y && y->median_ms > 0 ? x->median_ms / y->median_ms : 0.0;
}

std::vector<BenchPairResult> RunDisparityBenchmark(const std::vector<StereoPairWithTruth>& pairs,
                                                   const DisparityParams& ours, int repetitions,
                                                   const std::string& only) {
  const char* names[] = {"gpt-sgm", "sgm", "sgbm", "sgbm-3way"};
  std::vector<BenchPairResult> out;
  for (const auto& p : pairs) {
    BenchPairResult pr;
    pr.pair = p.name, pr.width = p.left.cols, pr.height = p.left.rows;
    for (const char* n : names) {
      BenchMethodResult r;
      r.method = n;
      pr.methods.push_back(r);
    }
    for (int rep = 0; rep < std::max(1, repetitions); ++rep) {
      for (int m = 0; m < 4; ++m) {
        if (!only.empty() && only != names[m]) continue;
        cv::Mat d, valid;
        const auto t0 = std::chrono::steady_clock::now();
        const double c0 = ProcessCpuMs();
        BenchMethodResult& r = pr.methods[m];
        if (m < 2) {
          DisparityParams q = ours;
          q.method = m == 0 ? DisparityMethod::kGptSgm : DisparityMethod::kSgm;
          q.min_disparity = p.min_disparity, q.num_disparities = p.num_disparities;
          q.camera_focal_px = p.focal_px;
          const DisparityResult res = ComputeDisparity(p.left, p.right, q);
          d = res.disparity, valid = res.valid;
          r.num_disparities = res.num_disparities, r.fell_back = res.fell_back, r.timings = res.timings;
        } else {
          RunStereoSgbm(p.left, p.right, p.min_disparity, p.num_disparities, m == 3, &d, &valid);
          r.num_disparities = (p.num_disparities + 15) / 16 * 16;
        }
        r.cpu_ms.push_back(ProcessCpuMs() - c0);
        r.times_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        if (rep == 0) {
          r.eval.all = EvaluateDisparity(d, valid, p.gt);
          r.eval.nonocc = EvaluateDisparity(d, valid, p.gt, p.nonocc);
          if (!p.road.empty()) r.eval.masked = EvaluateDisparity(d, valid, p.gt, p.road);
          if (!p.pothole.empty()) r.eval.pothole = EvaluateDisparity(d, valid, p.gt, p.pothole);
        }
      }
    }
    std::erase_if(pr.methods, [](const BenchMethodResult& r) { return r.times_ms.empty(); });
    for (auto& r : pr.methods) r.median_ms = Median(r.times_ms), r.median_cpu_ms = Median(r.cpu_ms);
    out.push_back(std::move(pr));
  }
  return out;
}

std::string FormatStepTimes(const std::vector<BenchPairResult>& results) {
  std::string s =
      "| pair | method | road model | warp + smooth | census | cost+aggregation | WTA+LR | post | transform | total |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[512];
  for (const auto& p : results)
    for (const auto& r : p.methods) {
      if (r.method != "gpt-sgm" && r.method != "sgm") continue;
      const DisparityTimings& t = r.timings;
      std::snprintf(buf, sizeof(buf), "| %s | %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n",
                    p.pair.c_str(), r.method.c_str(), t.road_model_ms, t.warp_ms, t.census_ms, t.aggregation_ms,
                    t.wta_ms, t.postprocess_ms, t.transform_ms, t.total_ms);
      s += buf;
    }
  return s;
}

std::string FormatBenchmarkTable(const std::vector<BenchPairResult>& results) {
  std::string s =
      "| pair | method | range | wall ms/pair | pairs/s | wall / sgbm-3way | CPU ms/pair | CPU / sgbm-3way | density | "
      "bad-2 nonocc | D1 nonocc | EPE nonocc px |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[512];
  for (const auto& p : results)
    for (const auto& r : p.methods) {
      const BenchMethodResult* base = p.Find("sgbm-3way");
      std::snprintf(
          buf, sizeof(buf),
          "| %s %dx%d | %s%s | %d | %.1f | %.1f | %.2f | %.1f | %.2f | %.1f %% | %.2f %% | %.2f %% | %.3f |\n",
          p.pair.c_str(), p.width, p.height, r.method.c_str(), r.fell_back ? " (fell back)" : "", r.num_disparities,
          r.median_ms, 1000.0 / r.median_ms, p.Ratio(r.method, "sgbm-3way"), r.median_cpu_ms,
          base && base->median_cpu_ms > 0 ? r.median_cpu_ms / base->median_cpu_ms : 0.0, 100 * r.eval.nonocc.density,
          100 * r.eval.nonocc.bad2, 100 * r.eval.nonocc.d1, r.eval.nonocc.epe);
      s += buf;
    }
  return s;
}

std::string FormatRoadAccuracyTable(const std::vector<BenchPairResult>& results) {
  struct Acc {
    std::vector<DisparityMetrics> road, pothole;
    std::vector<double> wall, cpu;
    int fell_back = 0, range_min = 1 << 30, range_max = 0;
  };
  std::map<std::string, std::map<std::string, Acc>> groups;  // survey -> method -> pooled
  std::vector<std::string> order;
  std::map<std::string, int> frames;
  for (const auto& p : results) {
    const std::string survey = p.pair.substr(0, p.pair.find('/'));
    bool any = false;
    for (const auto& r : p.methods) {
      if (r.eval.masked.evaluated == 0 && r.eval.pothole.evaluated == 0) continue;
      Acc& a = groups[survey][r.method];
      a.road.push_back(r.eval.masked), a.pothole.push_back(r.eval.pothole);
      a.wall.push_back(r.median_ms), a.cpu.push_back(r.median_cpu_ms);
      a.fell_back += r.fell_back;
      a.range_min = std::min(a.range_min, r.num_disparities), a.range_max = std::max(a.range_max, r.num_disparities);
      any = true;
    }
    if (!any) continue;
    if (!frames[survey]++) order.push_back(survey);
  }
  std::string s =
      "| survey | pairs | method | range | road density | road D1 | D1 / best SGBM's | road bad-1 | road EPE px | "
      "pothole pixels | pothole density | pothole MAE px | wall ms/pair | CPU ms/pair | CPU / sgbm-3way |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  char buf[768];
  const char* methods[] = {"gpt-sgm", "sgm", "sgbm", "sgbm-3way"};
  for (const auto& survey : order) {
    auto& g = groups[survey];
    double best_sgbm_d1 = -1;
    for (const char* m : {"sgbm", "sgbm-3way"})
      if (g.count(m)) {
        const double d1 = PoolMetrics(g[m].road).d1;
        best_sgbm_d1 = best_sgbm_d1 < 0 ? d1 : std::min(best_sgbm_d1, d1);
      }
    const double cpu_3way = g.count("sgbm-3way") ? Median(g["sgbm-3way"].cpu) : 0.0;
    for (const char* m : methods) {
      if (!g.count(m)) continue;
      Acc& a = g[m];
      const DisparityMetrics road = PoolMetrics(a.road), ph = PoolMetrics(a.pothole);
      const std::string range = a.range_min == a.range_max
                                    ? std::to_string(a.range_min)
                                    : std::to_string(a.range_min) + "–" + std::to_string(a.range_max);
      const std::string fb = a.fell_back ? " (" + std::to_string(a.fell_back) + " fell back)" : "";
      const double cpu = Median(a.cpu);
      std::snprintf(buf, sizeof(buf),
                    "| %s | %d | %s%s | %s | %.2f %% | %.3f %% | %s | %.2f %% | %.3f | %lld | %.1f %% | %.3f | %.1f | "
                    "%.1f | %.2f |\n",
                    survey.c_str(), frames[survey], m, fb.c_str(), range.c_str(), 100 * road.density, 100 * road.d1,
                    best_sgbm_d1 > 0 ? std::to_string(road.d1 / best_sgbm_d1).substr(0, 4).c_str() : "–",
                    100 * road.bad1, road.epe, static_cast<long long>(ph.evaluated), 100 * ph.density, ph.epe,
                    Median(a.wall), cpu, cpu_3way > 0 ? cpu / cpu_3way : 0.0);
      s += buf;
    }
  }
  return s;
}

}  // namespace rs
