#include "cli/tool_util.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <regex>

#include <opencv2/imgcodecs.hpp>

#include "formats/input_error.h"

namespace rs {
namespace fs = std::filesystem;

cv::Size ParseImageSize(const std::string& text, const std::string& flag) {
  static const std::regex re(R"((\d{1,5})[xX](\d{1,5}))");
  std::smatch m;
  if (std::regex_match(text, m, re)) {
    const int w = std::stoi(m[1].str()), h = std::stoi(m[2].str());
    if (w >= 16 && h >= 16 && w <= 16384 && h <= 16384) return {w, h};
  }
  throw OptionError(fmt::format("{} = '{}' violates WIDTHxHEIGHT with 16 <= each <= 16384", flag, text));
}

namespace {

fs::path Existing(const fs::path& p) {
  if (!fs::exists(p)) throw InputError(InputLocation::File(p.string()), "no such file or folder");
  return p;
}

}  // namespace

std::vector<FilePair> PairFiles(const fs::path& est, const fs::path& truth, const std::string& ext,
                                const fs::path& extra) {
  Existing(est), Existing(truth);
  if (!extra.empty()) Existing(extra);
  const bool dirs = fs::is_directory(truth);
  if (fs::is_directory(est) != dirs || (!extra.empty() && fs::is_directory(extra) != dirs))
    throw OptionError(
        fmt::format("give files or folders on both sides, not a mix ({} vs {})", est.string(), truth.string()));
  if (!dirs) return {{truth.filename().string(), est, truth, extra}};
  std::vector<FilePair> pairs;
  for (const auto& entry : fs::directory_iterator(truth)) {
    if (!entry.is_regular_file() || entry.path().extension() != ext) continue;
    const std::string name = entry.path().filename().string();
    FilePair p{name, Existing(est / name), entry.path(), {}};
    if (!extra.empty()) p.extra = Existing(extra / name);
    pairs.push_back(std::move(p));
  }
  if (pairs.empty())
    throw InputError(InputLocation::File(truth.string()), fmt::format("no *{} files in the truth folder", ext));
  std::sort(pairs.begin(), pairs.end(), [](const FilePair& a, const FilePair& b) { return a.name < b.name; });
  return pairs;
}

cv::Mat ReadImageAnyDepth(const fs::path& path, bool single_channel) {
  if (!fs::is_regular_file(path)) throw InputError(InputLocation::File(path.string()), "no such file");
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (image.empty()) throw InputError(InputLocation::File(path.string()), "cannot decode image");
  if (single_channel && image.channels() != 1)
    throw InputError(InputLocation::File(path.string()),
                     fmt::format("expected a single-channel image, got {} channels", image.channels()));
  return image;
}

void WriteTextOutput(const std::string& path, const std::string& text) {
  if (path == "-") {
    std::fwrite(text.data(), 1, text.size(), stdout);
    return;
  }
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error(fmt::format("cannot write {}", path));
}

std::pair<double, double> ValidRange(const cv::Mat& values, const cv::Mat& valid, double lower_q, double upper_q) {
  std::vector<float> v;
  for (int r = 0; r < values.rows; ++r)
    for (int c = 0; c < values.cols; ++c)
      if (valid.at<uint8_t>(r, c)) v.push_back(values.at<float>(r, c));
  if (v.empty()) return {0.0, 1.0};
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) { return double(v[std::min(v.size() - 1, size_t(q * double(v.size() - 1)))]); };
  double lo = at(lower_q), hi = at(upper_q);
  if (hi <= lo) hi = lo + 1;
  return {lo, hi};
}

}  // namespace rs
