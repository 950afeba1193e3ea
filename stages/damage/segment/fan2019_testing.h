#pragma once
// For tests on fan2019 dataset3 (the authors' transformed disparity and pixel labels of five real
// frames): the frames, read once per call, or none when the shared data is absent.

#include "tests/support/test_data.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace rs::test {

struct Fan2019Frame {
  std::string name;  ///< "01.png" .. "05.png"
  cv::Mat disp;      ///< disp_tg: 16-bit transformed disparity
  cv::Mat label;     ///< grey label: non-zero = pothole
};

inline std::filesystem::path Fan2019Dataset3Dir() { return DataRoot() / "pothole_stereo_fan2019" / "dataset3"; }

/// The five frames; empty when the folder is absent. A listed frame that does not read is a test
/// failure (ADD_FAILURE), not a skip.
inline std::vector<Fan2019Frame> LoadFan2019Dataset3() {
  const std::filesystem::path dir = Fan2019Dataset3Dir();
  std::vector<Fan2019Frame> frames;
  if (!std::filesystem::exists(dir / "disp_tg")) return frames;
  for (int i = 1; i <= 5; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%02d.png", i);
    Fan2019Frame f{name, cv::imread((dir / "disp_tg" / name).string(), cv::IMREAD_UNCHANGED),
                   cv::imread((dir / "label" / name).string(), cv::IMREAD_GRAYSCALE)};
    if (f.disp.empty() || f.label.empty()) ADD_FAILURE() << "cannot read " << name << " of " << dir;
    frames.push_back(std::move(f));
  }
  return frames;
}

}  // namespace rs::test
