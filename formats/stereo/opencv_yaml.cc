#include "formats/stereo/opencv_yaml.h"

#include <cmath>
#include <opencv2/core.hpp>
#include <fstream>
#include <istream>
#include <regex>
#include <sstream>

#include "formats/input_error.h"

namespace rs::stereo_internal {

std::string SlurpStream(std::istream& in, const std::string& path) {
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw InputError(InputLocation::File(path), "read error");
  return s.str();
}

std::string SlurpFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputLocation::File(path), "cannot open file");
  return SlurpStream(in, path);
}

cv::FileStorage OpenYamlText(const std::string& text, const std::string& path) {
  std::string body = text;
  // OpenCV accepts only "%YAML:1.0" / "%YAML 1.0" as the first line; plain YAML gets one.
  if (body.rfind("%YAML", 0) != 0) body = "%YAML:1.0\n" + body;
  try {
    cv::FileStorage fs(body, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) throw InputError(InputLocation::File(path), "not a readable YAML file");
    return fs;
  } catch (const cv::Exception& e) {
    // OpenCV puts the input line into the "function" field as "(54): message".
    std::smatch m;
    const std::string what = e.func;  // e.g. "(54): Incorrect indentation"
    static const std::regex kLine(R"(\((\d+)\):\s*(.*))");
    if (std::regex_search(what, m, kLine)) {
      int64_t line = std::stoll(m[1].str());
      if (text.rfind("%YAML", 0) != 0) line -= 1;  // the directive we prepended
      throw InputError(InputLocation::Line(path, std::max<int64_t>(line, 1)), "YAML parse error: " + m[2].str());
    }
    throw InputError(InputLocation::File(path), "YAML parse error: " + e.err);
  }
}

namespace {
std::string Name(const std::string& key, const std::string& key_path) { return key_path.empty() ? key : key_path; }
}  // namespace

double RequireReal(const cv::FileNode& parent, const std::string& key, const std::string& path,
                   const std::string& key_path) {
  cv::FileNode n = parent[key];
  if (n.empty() || n.isNone()) throw InputError(InputLocation::File(path), "missing key '" + Name(key, key_path) + "'");
  if (!n.isReal() && !n.isInt())
    throw InputError(InputLocation::File(path), "key '" + Name(key, key_path) + "' is not a number");
  return n.real();
}

int RequireInt(const cv::FileNode& parent, const std::string& key, const std::string& path,
               const std::string& key_path) {
  cv::FileNode n = parent[key];
  if (n.empty() || n.isNone()) throw InputError(InputLocation::File(path), "missing key '" + Name(key, key_path) + "'");
  if (n.isInt()) return static_cast<int>(n);
  if (n.isReal()) {
    const double v = n.real();
    if (v == std::floor(v) && std::abs(v) < 1e9) return static_cast<int>(v);
  }
  throw InputError(InputLocation::File(path), "key '" + Name(key, key_path) + "' is not an integer");
}

std::vector<double> RequireNumbers(const cv::FileNode& parent, const std::string& key, const std::string& path,
                                   size_t expected, const std::string& key_path) {
  const std::string name = Name(key, key_path);
  cv::FileNode n = parent[key];
  if (n.empty() || n.isNone()) throw InputError(InputLocation::File(path), "missing key '" + name + "'");
  std::vector<double> out;
  auto take = [&](const cv::FileNode& v) {
    if (!v.isReal() && !v.isInt())
      throw InputError(InputLocation::File(path), "key '" + name + "' holds a non-numeric element");
    out.push_back(v.real());
  };
  size_t rows = 0, cols = 0;
  if (n.isMap()) {
    // "!!opencv-matrix" is decoded by OpenCV into a Mat; an untagged {rows, cols, data} map is not.
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception&) {
      m.release();
    }
    if (!m.empty()) {
      m.convertTo(m, CV_64F);
      rows = m.rows;
      cols = m.cols;
      for (int r = 0; r < m.rows; ++r)
        for (int c = 0; c < m.cols; ++c) out.push_back(m.at<double>(r, c));
    } else {
      rows = RequireInt(n, "rows", path, name + ".rows");
      cols = RequireInt(n, "cols", path, name + ".cols");
      cv::FileNode d = n["data"];
      if (!d.isSeq()) throw InputError(InputLocation::File(path), "key '" + name + ".data' is not a sequence");
      for (const auto& v : d) take(v);
      if (out.size() != rows * cols)
        throw InputError(InputLocation::File(path), "key '" + name + "' declares " + std::to_string(rows) + "x" +
                                                        std::to_string(cols) + " but holds " +
                                                        std::to_string(out.size()) + " values");
    }
  } else if (n.isSeq()) {
    for (const auto& v : n) {
      if (v.isSeq()) {
        for (const auto& w : v) take(w);
      } else {
        take(v);
      }
    }
  } else {
    throw InputError(InputLocation::File(path), "key '" + name + "' is not a matrix or sequence");
  }
  if (expected > 0 && out.size() != expected)
    throw InputError(InputLocation::File(path), "key '" + name + "' holds " + std::to_string(out.size()) +
                                                    " values, expected " + std::to_string(expected));
  return out;
}

}  // namespace rs::stereo_internal
