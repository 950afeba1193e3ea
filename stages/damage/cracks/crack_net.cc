#include "stages/damage/cracks/crack_net.h"

#include "survey/hash.h"

#include <nlohmann/json.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>

#ifndef ROADSURVEY_CRACK_MODEL_SOURCE
#error "ROADSURVEY_CRACK_MODEL_SOURCE must name the source tree's crack_net.onnx"
#endif
#ifndef ROADSURVEY_CRACK_MODEL_INSTALLED
#error "ROADSURVEY_CRACK_MODEL_INSTALLED must name the installed crack_net.onnx"
#endif

namespace rs {

namespace fs = std::filesystem;

namespace {

// The whole image in one pass up to this side; beyond it, tiles of kTile with kMargin of context
// on each side (the net sees about 40 px around a pixel; the margin is dropped).
constexpr int kWhole = 384, kTile = 320, kMargin = 32;

struct LoadedModel {
  CrackModelInfo info;
  std::vector<uchar> onnx;  // the file's bytes: each thread builds its own network from them
};

std::string Key(const fs::path& path) { return fs::absolute(path).lexically_normal().string(); }

cv::dnn::Net NetFrom(const LoadedModel& m) {
  try {
    cv::dnn::Net net = cv::dnn::readNetFromONNX(m.onnx);
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
    return net;
  } catch (const cv::Exception& e) {
    throw CrackModelError(m.info.path.string() + ": not an ONNX network OpenCV's dnn module can import (" +
                          std::string(e.what()) + ")");
  }
}

// One normalised, padded tile through the net: probabilities of the tile's own size. A tile
// flatter than min_std grey levels is stretched no more than that: no training photograph was
// flatter, and stretching sensor noise to unit variance makes it look like texture with cracks.
cv::Mat RunTile(cv::dnn::Net& net, const cv::Mat& grey, const CrackModelInfo& info) {
  const int stride = info.stride_px;
  const fs::path& path = info.path;
  cv::Mat f;
  grey.convertTo(f, CV_32F);
  cv::Scalar mean, sd;
  cv::meanStdDev(f, mean, sd);
  f = (f - mean[0]) / std::max(sd[0], info.min_std_grey);
  const int pad_b = (stride - f.rows % stride) % stride, pad_r = (stride - f.cols % stride) % stride;
  // numpy's "reflect" in training: the edge pixel not repeated.
  const int border = f.rows > pad_b && f.cols > pad_r ? cv::BORDER_REFLECT_101 : cv::BORDER_REPLICATE;
  cv::copyMakeBorder(f, f, 0, pad_b, 0, pad_r, border);
  const int shape[] = {1, 1, f.rows, f.cols};
  const cv::Mat blob(4, shape, CV_32F, f.ptr<float>());
  net.setInput(blob);
  cv::Mat out;
  try {
    out = net.forward();
  } catch (const cv::Exception& e) {
    throw CrackModelError(path.string() + ": the network failed to run (" + std::string(e.what()) + ")");
  }
  if (out.dims != 4 || out.size[0] != 1 || out.size[1] != 1 || out.size[2] != f.rows || out.size[3] != f.cols)
    throw CrackModelError(path.string() + ": the network's output is not one probability per input pixel");
  return cv::Mat(f.rows, f.cols, CV_32F, out.ptr<float>())(cv::Rect(0, 0, grey.cols, grey.rows)).clone();
}

std::mutex g_mutex;
std::map<std::string, std::unique_ptr<LoadedModel>> g_models;  // by absolute path; never erased

const LoadedModel& Loaded(const fs::path& path) {
  const std::string key = Key(path);
  std::lock_guard<std::mutex> lock(g_mutex);
  if (auto it = g_models.find(key); it != g_models.end()) return *it->second;
  if (!fs::is_regular_file(path)) throw CrackModelError(path.string() + ": crack model not found");
  auto m = std::make_unique<LoadedModel>();
  m->info.path = path;
  {
    std::ifstream in(path, std::ios::binary);
    m->onnx.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (!in.good() && !in.eof()) throw CrackModelError(path.string() + ": cannot read the crack model");
  }
  if (m->onnx.empty()) throw CrackModelError(path.string() + ": the crack model file is empty");
  m->info.sha256 = Sha256Hex(std::string_view(reinterpret_cast<const char*>(m->onnx.data()), m->onnx.size()));
  fs::path meta = path;
  meta.replace_extension(".json");
  std::ifstream in(meta);
  if (!in)
    throw CrackModelError(meta.string() + ": missing (beside the crack model " + path.string() +
                          "; holds its detection threshold)");
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    m->info.threshold = j.at("threshold").get<double>();
    m->info.stride_px = j.value("stride_px", 8);
    m->info.min_std_grey = j.value("min_std_grey", 1.0);
    if (j.contains("components")) {
      m->info.min_length_px = j.at("components").at("min_length_px").get<int>();
      m->info.min_elongation = j.at("components").at("min_elongation").get<double>();
      if (m->info.min_length_px < 2 || !(m->info.min_elongation >= 1))
        throw CrackModelError(meta.string() + ": components need min_length_px >= 2 and min_elongation >= 1");
    }
  } catch (const nlohmann::json::exception& e) {
    throw CrackModelError(meta.string() + ": " + e.what());
  }
  if (!(m->info.threshold > 0 && m->info.threshold < 1))
    throw CrackModelError(meta.string() + ": threshold must lie in (0, 1)");
  if (!(m->info.min_std_grey >= 1 && m->info.min_std_grey <= 64))
    throw CrackModelError(meta.string() + ": min_std_grey must lie in [1, 64]");
  if (m->info.stride_px < 1 || m->info.stride_px > 64)
    throw CrackModelError(meta.string() + ": stride_px must lie in [1, 64]");
  // Imported and run once here, so that a file OpenCV cannot use fails on first use with its name.
  cv::dnn::Net net = NetFrom(*m);
  RunTile(net, cv::Mat(2 * m->info.stride_px, 2 * m->info.stride_px, CV_8U, cv::Scalar(128)), m->info);
  return *g_models.emplace(key, std::move(m)).first->second;
}

}  // namespace

fs::path DefaultCrackModelPath() {
  const fs::path source = ROADSURVEY_CRACK_MODEL_SOURCE, installed = ROADSURVEY_CRACK_MODEL_INSTALLED;
  if (fs::exists(source)) return source;
  if (fs::exists(installed)) return installed;
  return source;
}

fs::path ResolveCrackModelPath(const std::string& path) {
  return path.empty() ? DefaultCrackModelPath() : fs::path(path);
}

const CrackModelInfo& LoadCrackModel(const fs::path& path) { return Loaded(path).info; }

cv::Mat CrackProbability(const cv::Mat& grey, const fs::path& path) {
  if (grey.empty() || grey.type() != CV_8UC1) throw std::invalid_argument("CrackProbability: image must be 8-bit grey");
  const LoadedModel& m = Loaded(path);
  // cv::dnn::Net may not run forward passes concurrently: one instance per thread and model.
  thread_local std::map<std::string, cv::dnn::Net> nets;
  const std::string key = Key(path);
  auto it = nets.find(key);
  if (it == nets.end()) it = nets.emplace(key, NetFrom(m)).first;
  cv::dnn::Net& net = it->second;
  if (grey.rows <= kWhole && grey.cols <= kWhole) return RunTile(net, grey, m.info);
  cv::Mat prob(grey.size(), CV_32F);
  const int core = kTile - 2 * kMargin;
  for (int y = 0; y < grey.rows; y += core)
    for (int x = 0; x < grey.cols; x += core) {
      const cv::Rect inner(x, y, std::min(core, grey.cols - x), std::min(core, grey.rows - y));
      const cv::Rect outer = cv::Rect(x - kMargin, y - kMargin, inner.width + 2 * kMargin, inner.height + 2 * kMargin) &
                             cv::Rect(0, 0, grey.cols, grey.rows);
      const cv::Mat p = RunTile(net, grey(outer), m.info);
      p(inner - outer.tl()).copyTo(prob(inner));
    }
  return prob;
}

}  // namespace rs
