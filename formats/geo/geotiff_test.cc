#include "formats/geo/geotiff.h"

#include <gtest/gtest.h>
#include <tiffio.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include <opencv2/core.hpp>

#include "formats/checked_file.h"
#include "formats/input_error.h"

namespace rs {
namespace {

namespace fs = std::filesystem;

class GeoTiffTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("roadsurvey_geotiff_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

GeoTiffGeoreference Utm33() {
  GeoTiffGeoreference g;
  g.x_min = 500000;
  g.y_max = 5400000;
  g.cell = 0.05;
  g.epsg = 32633;
  g.vertical_epsg = 5773;
  g.citation = "WGS 84 / UTM zone 33N";
  return g;
}

// Pixel (x, y) of a test raster of `type`; distinct per pixel and channel.
cv::Scalar Pattern(int type, int x, int y) {
  switch (type) {
    case CV_32FC1: return cv::Scalar(100.0 + 0.25 * x - 0.5 * y);
    case CV_16UC1: return cv::Scalar((x * 7 + y * 13) % 60000);
    case CV_8UC1: return cv::Scalar((x + 3 * y) % 251);
    default: return cv::Scalar(x % 256, y % 256, (x + y) % 256);
  }
}

cv::Mat PatternBlock(int type, int x0, int y0, int w, int h) {
  cv::Mat block(h, w, type);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const cv::Scalar v = Pattern(type, x0 + x, y0 + y);
      switch (type) {
        case CV_32FC1: block.at<float>(y, x) = static_cast<float>(v[0]); break;
        case CV_16UC1: block.at<uint16_t>(y, x) = static_cast<uint16_t>(v[0]); break;
        case CV_8UC1: block.at<uint8_t>(y, x) = static_cast<uint8_t>(v[0]); break;
        default: block.at<cv::Vec3b>(y, x) = cv::Vec3b(uint8_t(v[0]), uint8_t(v[1]), uint8_t(v[2]));
      }
    }
  }
  return block;
}

// Writes the pattern into every tile but `skip` (left unwritten), last tile first; edge tiles
// get blocks just covering the raster.
void WritePattern(const fs::path& path, int width, int height, int type, const GeoTiffGeoreference& georef,
                  const GeoTiffOptions& options, cv::Point skip = {-1, -1}) {
  GeoTiffWriter writer(path, width, height, type, georef, options);
  const int t = writer.tile_size();
  for (int row = writer.tiles_down() - 1; row >= 0; --row) {
    for (int col = writer.tiles_across() - 1; col >= 0; --col) {
      if (cv::Point(col, row) == skip) continue;
      const int x0 = col * t, y0 = row * t;
      writer.WriteTile(col, row, PatternBlock(type, x0, y0, std::min(t, width - x0), std::min(t, height - y0)));
    }
  }
  writer.Finish();
}

// Every pixel is the pattern, except those in tile `skip`, which are `empty`.
void ExpectPattern(const cv::Mat& image, int type, int tile, cv::Point skip, double empty) {
  ASSERT_EQ(image.type(), type);
  int bad = 0;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const bool skipped = x / tile == skip.x && y / tile == skip.y;
      const cv::Scalar want = skipped ? cv::Scalar::all(empty) : Pattern(type, x, y);
      for (int c = 0; c < image.channels(); ++c) {
        double got = 0;
        switch (type) {
          case CV_32FC1: got = image.at<float>(y, x); break;
          case CV_16UC1: got = image.at<uint16_t>(y, x); break;
          case CV_8UC1: got = image.at<uint8_t>(y, x); break;
          default: got = image.at<cv::Vec3b>(y, x)[c];
        }
        if (std::abs(got - want[c]) > 1e-4 * std::max(1.0, std::abs(want[c])) && ++bad <= 5) {
          ADD_FAILURE() << "pixel " << x << "," << y << " channel " << c << ": " << got << " != " << want[c];
        }
      }
    }
  }
  EXPECT_EQ(bad, 0);
}

void ExpectSameGeoreference(const GeoTiffGeoreference& a, const GeoTiffGeoreference& b) {
  EXPECT_DOUBLE_EQ(a.x_min, b.x_min);
  EXPECT_DOUBLE_EQ(a.y_max, b.y_max);
  EXPECT_DOUBLE_EQ(a.cell, b.cell);
  EXPECT_EQ(a.epsg, b.epsg);
  EXPECT_EQ(a.vertical_epsg, b.vertical_epsg);
  EXPECT_EQ(a.citation, b.citation);
}

TEST_F(GeoTiffTest, Float32RoundTrip) {
  GeoTiffOptions options;
  options.tile_size = 128;
  options.nodata = -9999;
  options.description = "height above EGM96 geoid, m";
  const fs::path path = dir_ / "height.tif";
  WritePattern(path, 601, 397, CV_32FC1, Utm33(), options, {1, 1});

  const GeoTiffRaster raster = ReadGeoTiff(path);
  ASSERT_EQ(raster.image.size(), cv::Size(601, 397));
  ExpectPattern(raster.image, CV_32FC1, 128, {1, 1}, -9999);
  ExpectSameGeoreference(raster.georef, Utm33());
  EXPECT_EQ(raster.nodata, -9999);
  EXPECT_EQ(raster.description, options.description);
  EXPECT_EQ(raster.overview_count, 3);  // 301x199, 151x100, 76x50

  // A window over the bottom-left corner, partly outside the raster.
  const cv::Mat window = ReadGeoTiffWindow(path, -10, 390, 30, 20);
  ASSERT_EQ(window.size(), cv::Size(30, 20));
  EXPECT_EQ(window.at<float>(0, 0), -9999.f);
  EXPECT_EQ(window.at<float>(19, 15), -9999.f);
  EXPECT_FLOAT_EQ(window.at<float>(0, 10), static_cast<float>(Pattern(CV_32FC1, 0, 390)[0]));
  EXPECT_FLOAT_EQ(window.at<float>(6, 29), static_cast<float>(Pattern(CV_32FC1, 19, 396)[0]));
}

TEST_F(GeoTiffTest, UInt16RoundTrip) {
  GeoTiffOptions options;
  options.tile_size = 64;
  options.nodata = 65535;
  const fs::path path = dir_ / "counts.tif";
  WritePattern(path, 300, 200, CV_16UC1, Utm33(), options, {2, 1});
  const GeoTiffRaster raster = ReadGeoTiff(path);
  ExpectPattern(raster.image, CV_16UC1, 64, {2, 1}, 65535);
  EXPECT_EQ(raster.nodata, 65535);
  EXPECT_EQ(raster.overview_count, 3);  // 150x100, 75x50, 38x25
}

TEST_F(GeoTiffTest, UInt8GeographicRoundTrip) {
  GeoTiffGeoreference georef;
  georef.x_min = 16.3;
  georef.y_max = 48.2;
  georef.cell = 1e-6;
  georef.epsg = 4326;
  GeoTiffOptions options;
  options.tile_size = 32;
  const fs::path path = dir_ / "mask.tif";
  WritePattern(path, 100, 50, CV_8UC1, georef, options, {3, 1});
  const GeoTiffRaster raster = ReadGeoTiff(path);
  ExpectPattern(raster.image, CV_8UC1, 32, {3, 1}, 0);  // no nodata: unwritten tiles read 0
  ExpectSameGeoreference(raster.georef, georef);
  EXPECT_TRUE(std::isnan(raster.nodata));
  EXPECT_EQ(raster.overview_count, 2);  // 50x25, 25x13
}

TEST_F(GeoTiffTest, Bgr8LocalFrameRoundTrip) {
  GeoTiffGeoreference georef;
  georef.x_min = -12.5;
  georef.y_max = 40;
  georef.cell = 0.01;
  georef.citation = "local ENU at 48.2N 16.3E, m";
  GeoTiffOptions options;
  options.tile_size = 16;
  const fs::path path = dir_ / "ortho.tif";
  WritePattern(path, 70, 45, CV_8UC3, georef, options, {0, 2});
  const GeoTiffRaster raster = ReadGeoTiff(path);
  ExpectPattern(raster.image, CV_8UC3, 16, {0, 2}, 0);
  ExpectSameGeoreference(raster.georef, georef);

  // RGB in the file: pixel (5, 3) is BGR (5, 3, 8) in memory.
  TIFF* tif = TIFFOpen(path.c_str(), "r");
  ASSERT_NE(tif, nullptr);
  uint16_t photometric = 0;
  TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric);
  EXPECT_EQ(photometric, PHOTOMETRIC_RGB);
  std::vector<uint8_t> tile(TIFFTileSize(tif));
  ASSERT_GT(TIFFReadEncodedTile(tif, 0, tile.data(), static_cast<tmsize_t>(tile.size())), 0);
  const uint8_t* rgb = &tile[(3 * 16 + 5) * 3];
  EXPECT_EQ(rgb[0], 8);
  EXPECT_EQ(rgb[1], 3);
  EXPECT_EQ(rgb[2], 5);
  TIFFClose(tif);
}

TEST_F(GeoTiffTest, OverviewsAverageIgnoringNodata) {
  GeoTiffOptions options;
  options.tile_size = 128;
  options.nodata = -9999;
  const fs::path path = dir_ / "dem.tif";
  {
    GeoTiffWriter writer(path, 512, 512, CV_32FC1, Utm33(), options);
    for (int row = 0; row < 4; ++row) {
      for (int col = 0; col < 4; ++col) {
        cv::Mat block(128, 128, CV_32FC1);
        for (int y = 0; y < 128; ++y) {
          for (int x = 0; x < 128; ++x) block.at<float>(y, x) = float((col * 128 + x) + 1000 * (row * 128 + y));
        }
        if (row == 0 && col == 0) block.at<float>(0, 0) = -9999;
        writer.WriteTile(col, row, block);
      }
    }
    writer.Finish();
  }

  TIFF* tif = TIFFOpen(path.c_str(), "r");
  ASSERT_NE(tif, nullptr);
  EXPECT_EQ(TIFFNumberOfDirectories(tif), 3);  // 512 -> 256 -> 128 fits one tile
  ASSERT_TRUE(TIFFSetDirectory(tif, 1));
  uint32_t subfile = 0, width = 0, height = 0, tile_w = 0;
  uint16_t compression = 0;
  TIFFGetField(tif, TIFFTAG_SUBFILETYPE, &subfile);
  TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &height);
  TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tile_w);
  TIFFGetField(tif, TIFFTAG_COMPRESSION, &compression);
  EXPECT_EQ(subfile, uint32_t(FILETYPE_REDUCEDIMAGE));
  EXPECT_EQ(width, 256u);
  EXPECT_EQ(height, 256u);
  EXPECT_EQ(tile_w, 128u);
  EXPECT_EQ(compression, COMPRESSION_ADOBE_DEFLATE);
  std::vector<float> tile(128 * 128);
  ASSERT_GT(TIFFReadEncodedTile(tif, 0, tile.data(), tmsize_t(tile.size() * sizeof(float))), 0);
  EXPECT_FLOAT_EQ(tile[0], (1 + 1000 + 1001) / 3.f);  // the nodata pixel does not count
  EXPECT_FLOAT_EQ(tile[1], (2 + 3 + 1002 + 1003) / 4.f);
  TIFFClose(tif);

  GeoTiffReader reader(path);
  ASSERT_EQ(reader.overview_count(), 2);
  EXPECT_EQ(reader.level_size(2), cv::Size(128, 128));
  const cv::Mat level2 = reader.Window(10, 20, 1, 1, 2);  // mean of the 4x4 full-resolution block
  EXPECT_NEAR(level2.at<float>(0, 0), 41.5f + 1000 * 81.5f, 1e-2);
}

TEST_F(GeoTiffTest, NoOverviewsWhenOff) {
  GeoTiffOptions options;
  options.tile_size = 64;
  options.overviews = false;
  const fs::path path = dir_ / "flat.tif";
  WritePattern(path, 300, 100, CV_8UC1, Utm33(), options);
  EXPECT_EQ(ReadGeoTiff(path).overview_count, 0);
}

// gdalinfo's output, or "" when gdalinfo is not on PATH.
std::string Gdalinfo(const fs::path& file) {
  const char* path_env = std::getenv("PATH");
  bool found = false;
  std::stringstream dirs(path_env ? path_env : "");
  for (std::string d; std::getline(dirs, d, ':');)
    found = found || (!d.empty() && fs::exists(fs::path(d) / "gdalinfo"));
  if (!found) return "";
  std::string out;
  FILE* pipe = ::popen(("gdalinfo '" + file.string() + "' 2>&1").c_str(), "r");
  if (!pipe) return "";
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  ::pclose(pipe);
  return out;
}

TEST_F(GeoTiffTest, GdalinfoReadsFloatRaster) {
  GeoTiffOptions options;
  options.nodata = -9999;
  const fs::path path = dir_ / "height.tif";
  WritePattern(path, 600, 400, CV_32FC1, Utm33(), options, {1, 0});
  const std::string info = Gdalinfo(path);
  if (info.empty()) GTEST_SKIP() << "gdalinfo (package gdal-bin) is not on PATH";
  EXPECT_NE(info.find("Driver: GTiff/GeoTIFF"), std::string::npos) << info;
  EXPECT_NE(info.find("Size is 600, 400"), std::string::npos) << info;
  EXPECT_NE(info.find("ID[\"EPSG\",32633]"), std::string::npos) << info;
  EXPECT_NE(info.find("Origin = (500000.000000000000000,5400000.000000000000000)"), std::string::npos) << info;
  EXPECT_NE(info.find("Pixel Size = (0.050000000000000,-0.050000000000000)"), std::string::npos) << info;
  EXPECT_NE(info.find("Block=256x256 Type=Float32"), std::string::npos) << info;
  EXPECT_NE(info.find("NoData Value=-9999"), std::string::npos) << info;
  EXPECT_NE(info.find("Overviews: 300x200, 150x100"), std::string::npos) << info;
  EXPECT_EQ(info.find("ERROR"), std::string::npos) << info;
  EXPECT_EQ(info.find("Warning"), std::string::npos) << info;
}

TEST_F(GeoTiffTest, GdalinfoReadsRgbRaster) {
  const fs::path path = dir_ / "ortho.tif";
  WritePattern(path, 1030, 520, CV_8UC3, Utm33(), {});
  const std::string info = Gdalinfo(path);
  if (info.empty()) GTEST_SKIP() << "gdalinfo (package gdal-bin) is not on PATH";
  EXPECT_NE(info.find("ID[\"EPSG\",32633]"), std::string::npos) << info;
  EXPECT_NE(info.find("Origin = (500000.000000000000000,5400000.000000000000000)"), std::string::npos) << info;
  EXPECT_NE(info.find("Pixel Size = (0.050000000000000,-0.050000000000000)"), std::string::npos) << info;
  EXPECT_NE(info.find("Band 1 Block=256x256 Type=Byte, ColorInterp=Red"), std::string::npos) << info;
  EXPECT_NE(info.find("Band 3 Block=256x256 Type=Byte, ColorInterp=Blue"), std::string::npos) << info;
  EXPECT_NE(info.find("Overviews: 515x260, 258x130, 129x65"), std::string::npos) << info;
  EXPECT_EQ(info.find("NoData"), std::string::npos) << info;
  EXPECT_EQ(info.find("ERROR"), std::string::npos) << info;
}

TEST_F(GeoTiffTest, MissingFolderThrowsWriteError) {
  const fs::path path = dir_ / "no_such_folder" / "height.tif";
  try {
    GeoTiffWriter writer(path, 10, 10, CV_32FC1, Utm33());
    FAIL() << "no WriteError";
  } catch (const WriteError& e) {
    EXPECT_EQ(e.path(), path);
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(path));
}

TEST_F(GeoTiffTest, CorruptFileThrowsInputError) {
  GeoTiffOptions options;
  options.tile_size = 64;
  const fs::path good = dir_ / "good.tif";
  WritePattern(good, 200, 150, CV_32FC1, Utm33(), options);
  std::ifstream in(good, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 1000u);

  // The last IFD ends the file, so every cut loses part of a directory.
  for (size_t keep : {size_t(0), size_t(7), size_t(200), bytes.size() / 2, bytes.size() - 100}) {
    const fs::path bad = dir_ / ("truncated_" + std::to_string(keep) + ".tif");
    std::ofstream(bad, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
    try {
      ReadGeoTiff(bad);
      ADD_FAILURE() << "no InputError for " << keep << " of " << bytes.size() << " bytes";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().path, bad.string());
    }
  }

  // Garbage in the first tile's deflate stream (tiles start after the 8-byte header).
  std::string scrambled = bytes;
  std::fill(scrambled.begin() + 8, scrambled.begin() + 108, '\xff');
  const fs::path garbled = dir_ / "garbled.tif";
  std::ofstream(garbled, std::ios::binary).write(scrambled.data(), static_cast<std::streamsize>(scrambled.size()));
  EXPECT_THROW(ReadGeoTiff(garbled), InputError);

  const fs::path text = dir_ / "notes.tif";
  std::ofstream(text) << "not a TIFF at all\n";
  EXPECT_THROW(ReadGeoTiff(text), InputError);
  EXPECT_THROW(ReadGeoTiff(dir_ / "missing.tif"), InputError);
}

TEST_F(GeoTiffTest, PlainTiffIsNotAGeoTiff) {
  const fs::path path = dir_ / "plain.tif";
  TIFF* tif = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(tif, nullptr);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, 4u);
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, 1u);
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 8);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  uint8_t row[4] = {1, 2, 3, 4};
  TIFFWriteScanline(tif, row, 0, 0);
  TIFFClose(tif);
  try {
    ReadGeoTiff(path);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("not a GeoTIFF"), std::string::npos) << e.what();
  }
}

TEST_F(GeoTiffTest, UnfinishedFileIsRemoved) {
  const fs::path path = dir_ / "partial.tif";
  {
    GeoTiffWriter writer(path, 300, 300, CV_32FC1, Utm33());
    writer.WriteTile(0, 0, cv::Mat(256, 256, CV_32FC1, cv::Scalar(1)));
    EXPECT_TRUE(fs::exists(path));
  }
  EXPECT_FALSE(fs::exists(path));
}

TEST_F(GeoTiffTest, FailedFinishThrowsWriteErrorAndLeavesNoFile) {
  const fs::path path = dir_ / "vanishing.tif";
  GeoTiffWriter writer(path, 300, 300, CV_32FC1, Utm33());
  writer.WriteTile(0, 0, cv::Mat(256, 256, CV_32FC1, cv::Scalar(1)));
  fs::remove(path);  // the overviews cannot read the tiles back
  try {
    writer.Finish();
    FAIL() << "no WriteError";
  } catch (const WriteError& e) {
    EXPECT_EQ(e.path(), path);
  }
  EXPECT_FALSE(fs::exists(path));
}

TEST_F(GeoTiffTest, BadArgumentsThrow) {
  const fs::path path = dir_ / "bad.tif";
  GeoTiffOptions odd_tiles;
  odd_tiles.tile_size = 100;
  EXPECT_THROW(GeoTiffWriter(path, 10, 10, CV_32FC1, Utm33(), odd_tiles), std::invalid_argument);
  EXPECT_THROW(GeoTiffWriter(path, 10, 10, CV_64FC1, Utm33()), std::invalid_argument);
  EXPECT_THROW(GeoTiffWriter(path, 10, 10, CV_32FC1, GeoTiffGeoreference{}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));

  GeoTiffWriter writer(path, 300, 300, CV_32FC1, Utm33());
  EXPECT_THROW(writer.WriteTile(0, 0, cv::Mat(256, 256, CV_16UC1)), std::invalid_argument);
  EXPECT_THROW(writer.WriteTile(2, 0, cv::Mat(256, 256, CV_32FC1)), std::invalid_argument);
  EXPECT_THROW(writer.WriteTile(1, 0, cv::Mat(256, 40, CV_32FC1)), std::invalid_argument);  // edge needs 44 cols
  writer.WriteTile(1, 1, cv::Mat(44, 44, CV_32FC1, cv::Scalar(2)));
}

}  // namespace
}  // namespace rs
