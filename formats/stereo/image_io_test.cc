#include "formats/stereo/image_io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "formats/image_file.h"
#include "formats/input_error.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

fs::path TempDir() {
  const fs::path d = fs::temp_directory_path() / "rs_stereo_image_io_test";
  fs::create_directories(d);
  return d;
}

TEST(ImageIo, Nominal) {
  const fs::path d = TempDir();
  // 16-bit grey: v8 = round(v16 * 255 / 65535) = round(v16 / 257).
  cv::Mat g16(3, 5, CV_16U, cv::Scalar(257 * 100));
  g16.at<uint16_t>(0, 0) = 65535;
  g16.at<uint16_t>(0, 1) = 128;  // 0.498 -> 0
  g16.at<uint16_t>(0, 2) = 129;  // 0.502 -> 1
  ASSERT_TRUE(cv::imwrite((d / "g16.png").string(), g16));
  const cv::Mat a = LoadGray8(d / "g16.png");
  ASSERT_EQ(a.type(), CV_8UC1);
  EXPECT_EQ(a.at<uchar>(0, 0), 255);
  EXPECT_EQ(a.at<uchar>(0, 1), 0);
  EXPECT_EQ(a.at<uchar>(0, 2), 1);
  EXPECT_EQ(a.at<uchar>(2, 4), 100);
  // 12-bit data in 16-bit words: 4095 -> 255, 2048 -> round(127.53) = 128.
  cv::Mat g12(2, 2, CV_16U, cv::Scalar(4095));
  g12.at<uint16_t>(1, 1) = 2048;
  const cv::Mat b = ToGray8(g12, 12);
  EXPECT_EQ(b.at<uchar>(0, 0), 255);
  EXPECT_EQ(b.at<uchar>(1, 1), 128);
  // Colour -> grey, BT.601: Y = 0.299 R + 0.587 G + 0.114 B (BGR order in OpenCV).
  cv::Mat bgr(2, 2, CV_8UC3, cv::Scalar(200, 100, 50));
  ASSERT_TRUE(cv::imwrite((d / "c8.png").string(), bgr));
  EXPECT_NEAR(LoadGray8(d / "c8.png").at<uchar>(1, 1), 0.299 * 50 + 0.587 * 100 + 0.114 * 200, 0.51);
  const cv::Mat c = LoadColor8(d / "c8.png");
  EXPECT_EQ(c.type(), CV_8UC3);
  EXPECT_EQ(c.at<cv::Vec3b>(0, 0), cv::Vec3b(200, 100, 50));
  // 16-bit colour TIFF and an 8-bit grey JPEG.
  cv::Mat c16(4, 4, CV_16UC3, cv::Scalar(65535, 0, 257 * 10));
  ASSERT_TRUE(cv::imwrite((d / "c16.tif").string(), c16));
  EXPECT_EQ(LoadColor8(d / "c16.tif").at<cv::Vec3b>(3, 3), cv::Vec3b(255, 0, 10));
  cv::Mat g8(16, 16, CV_8U, cv::Scalar(90));
  ASSERT_TRUE(cv::imwrite((d / "g8.jpg").string(), g8));
  EXPECT_NEAR(LoadGray8(d / "g8.jpg").at<uchar>(8, 8), 90, 1);
}

// Writes the first `keep` bytes of an encoded image.
fs::path WriteTruncated(const std::string& name, const std::string& ext, double keep_fraction) {
  cv::Mat img(64, 64, CV_8U);
  cv::randu(img, 0, 255);
  std::vector<uchar> buf;
  cv::imencode(ext, img, buf);
  const fs::path p = TempDir() / name;
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size() * keep_fraction));
  return p;
}

TEST(ImageIo, TruncatedPng) {
  for (double keep : {0.05, 0.5, 0.98}) {
    const fs::path p = WriteTruncated("cut.png", ".png", keep);
    try {
      LoadGray8(p);
      FAIL() << "truncated PNG accepted, keep " << keep;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().path, p.string());
      EXPECT_NE(std::string(e.what()).find("cut.png"), std::string::npos);
    }
  }
}

TEST(ImageIo, TruncatedJpeg) {
  const fs::path p = WriteTruncated("cut.jpg", ".jpg", 0.7);
  try {
    LoadGray8(p);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().path, p.string());
    EXPECT_NE(e.message().find("truncated JPEG"), std::string::npos);
  }
}

TEST(ImageIo, GarbageAndMissing) {
  const fs::path p = TempDir() / "garbage.png";
  std::ofstream(p) << "this is not an image";
  EXPECT_THROW(LoadGray8(p), InputError);
  const fs::path e = TempDir() / "empty.png";
  std::ofstream{e};
  EXPECT_THROW(LoadGray8(e), InputError);
  EXPECT_THROW(LoadGray8(TempDir() / "nope.png"), InputError);
}

// The checked image writer (encode to memory, then a checked write) stores every format the
// pipeline writes exactly: 32-bit float TIFF (NaN kept), 16-bit and 8-bit PNG.
TEST(ImageFile, RoundTripsExactly) {
  const fs::path d = TempDir();
  cv::Mat f32(7, 11, CV_32F);
  for (int i = 0; i < f32.rows * f32.cols; ++i) f32.at<float>(i) = -3.25f + 0.731f * i;
  f32.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
  cv::Mat u16(7, 11, CV_16U), u8c3(7, 11, CV_8UC3);
  cv::randu(u16, 0, 65535);
  cv::randu(u8c3, 0, 255);
  WriteImageFile(d / "f.tiff", f32);
  WriteImageFile(d / "u16.png", u16);
  WriteImageFile(d / "c.png", u8c3);
  const cv::Mat f = cv::imread((d / "f.tiff").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(f.type(), CV_32F);
  EXPECT_EQ(std::memcmp(f.data, f32.data, f32.total() * sizeof(float)), 0);  // bit for bit, NaN included
  EXPECT_EQ(cv::norm(cv::imread((d / "u16.png").string(), cv::IMREAD_UNCHANGED), u16, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(cv::imread((d / "c.png").string(), cv::IMREAD_UNCHANGED), u8c3, cv::NORM_INF), 0);
}

TEST(ImageFile, UnencodableImageNamesTheFile) {
  const fs::path p = TempDir() / "x.unknown_extension";
  try {
    WriteImageFile(p, cv::Mat(2, 2, CV_8U, cv::Scalar(1)));
    FAIL() << "expected WriteError";
  } catch (const WriteError& e) {
    EXPECT_EQ(e.path(), p);
  }
  EXPECT_FALSE(fs::exists(p));
}

}  // namespace
}  // namespace rs
