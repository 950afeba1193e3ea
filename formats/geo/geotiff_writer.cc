// Writing tiled GeoTIFFs through libtiff + libgeotiff, with GDAL-style internal overviews.

#include <geotiff/geotiff.h>
#include <geotiff/geovalues.h>
#include <geotiff/xtiffio.h>
#include <tiffio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "formats/checked_file.h"
#include "formats/geo/geotiff.h"
#include "formats/input_error.h"

namespace rs {
namespace {

// How one cv type is stored.
struct SampleLayout {
  uint16_t bits = 0;
  uint16_t samples = 1;
  uint16_t format = SAMPLEFORMAT_UINT;
  uint16_t photometric = PHOTOMETRIC_MINISBLACK;
  uint16_t predictor = PREDICTOR_HORIZONTAL;
};

SampleLayout LayoutOf(int cv_type) {
  switch (cv_type) {
    case CV_32FC1: return {32, 1, SAMPLEFORMAT_IEEEFP, PHOTOMETRIC_MINISBLACK, PREDICTOR_FLOATINGPOINT};
    case CV_16UC1: return {16, 1, SAMPLEFORMAT_UINT, PHOTOMETRIC_MINISBLACK, PREDICTOR_HORIZONTAL};
    case CV_8UC1: return {8, 1, SAMPLEFORMAT_UINT, PHOTOMETRIC_MINISBLACK, PREDICTOR_HORIZONTAL};
    case CV_8UC3: return {8, 3, SAMPLEFORMAT_UINT, PHOTOMETRIC_RGB, PREDICTOR_HORIZONTAL};
    default:
      throw std::invalid_argument("GeoTiffWriter: cv type " + std::to_string(cv_type) +
                                  " is not one of CV_32FC1, CV_16UC1, CV_8UC1, CV_8UC3");
  }
}

bool IsGeographic(int epsg) { return epsg >= 4000 && epsg <= 4999; }

void CheckArguments(int width, int height, const GeoTiffGeoreference& georef, const GeoTiffOptions& options) {
  const auto fail = [](const std::string& rule) { throw std::invalid_argument("GeoTiffWriter: " + rule); };
  if (width <= 0 || height <= 0) fail(fmt::format("size {}x{} violates width > 0 and height > 0", width, height));
  if (options.tile_size <= 0 || options.tile_size % 16 != 0) {
    fail(fmt::format("tile_size = {} violates tile_size > 0 and a multiple of 16", options.tile_size));
  }
  if (!(georef.cell > 0) || !std::isfinite(georef.cell)) fail(fmt::format("cell = {} violates cell > 0", georef.cell));
  if (!std::isfinite(georef.x_min) || !std::isfinite(georef.y_max)) fail("x_min and y_max must be finite");
  if (georef.epsg < 0 || georef.epsg >= KvUserDefined || georef.vertical_epsg < 0 ||
      georef.vertical_epsg >= KvUserDefined) {
    fail(fmt::format("EPSG codes {} / {} violate 0 <= code < 32767", georef.epsg, georef.vertical_epsg));
  }
}

// 2x2 box average, rounding the size up. Skipped samples (NaN, and nodata where averaging ignores
// it) do not count; a destination sample with none left is `none`.
struct Averaging {
  bool skip_nodata = false;
  double nodata = 0;
  double none = 0;
  bool Skips(double v) const { return std::isnan(v) || (skip_nodata && v == nodata); }
};

template <typename T>
cv::Mat Halve(const cv::Mat& src, const Averaging& averaging) {
  const int channels = src.channels();
  cv::Mat dst((src.rows + 1) / 2, (src.cols + 1) / 2, src.type());
  for (int y = 0; y < dst.rows; ++y) {
    const int row_count = 2 * y + 1 < src.rows ? 2 : 1;
    const T* rows[2] = {src.ptr<T>(2 * y), src.ptr<T>(2 * y + row_count - 1)};
    T* out = dst.ptr<T>(y);
    for (int x = 0; x < dst.cols; ++x) {
      const int col_count = 2 * x + 1 < src.cols ? 2 : 1;
      for (int c = 0; c < channels; ++c) {
        double sum = 0;
        int n = 0;
        for (int r = 0; r < row_count; ++r) {
          for (int k = 0; k < col_count; ++k) {
            const double v = rows[r][(2 * x + k) * channels + c];
            if (averaging.Skips(v)) continue;
            sum += v;
            ++n;
          }
        }
        out[x * channels + c] = cv::saturate_cast<T>(n == 0 ? averaging.none : sum / n);
      }
    }
  }
  return dst;
}

cv::Mat Halve(const cv::Mat& src, const Averaging& averaging) {
  switch (src.depth()) {
    case CV_32F: return Halve<float>(src, averaging);
    case CV_16U: return Halve<uint16_t>(src, averaging);
    default: return Halve<uint8_t>(src, averaging);
  }
}

}  // namespace

struct GeoTiffWriter::Impl {
  std::filesystem::path path;
  int width = 0;
  int height = 0;
  int cv_type = 0;
  GeoTiffGeoreference georef;
  GeoTiffOptions options;
  SampleLayout layout;
  geotiff_detail::TiffMessages messages;
  TIFF* tif = nullptr;
  bool created = false;  // the file exists because of this writer
  bool finished = false;

  ~Impl() {
    if (!finished) Abandon();
  }

  // What pixels of unwritten tiles read as (GDAL's convention).
  double EmptyValue() const { return std::isfinite(options.nodata) ? options.nodata : 0.0; }

  [[noreturn]] void Fail(const std::string& fallback) { throw WriteError(path, messages.Take(fallback)); }

  void Abandon();
  void Close();
  void SetLayoutTags(cv::Size size, bool reduced);
  void SetGeoTags();
  void WriteBlock(int col, int row, const cv::Mat& block);
  void WriteOverview(int level, cv::Size from, cv::Size to);
};

void GeoTiffWriter::Impl::Abandon() {
  if (tif) {
    const int fd = TIFFFileno(tif);
    TIFFCleanup(tif);
    ::close(fd);
    tif = nullptr;
  }
  std::error_code ignored;
  if (created) std::filesystem::remove(path, ignored);
  created = false;
}

// TIFFClose reports nothing; flush and close(2) are checked here instead.
void GeoTiffWriter::Impl::Close() {
  if (!TIFFFlush(tif)) Fail("cannot flush the file");
  const int fd = TIFFFileno(tif);
  TIFFCleanup(tif);
  tif = nullptr;
  if (::close(fd) != 0) throw WriteError(path, std::strerror(errno));
}

void GeoTiffWriter::Impl::SetLayoutTags(cv::Size size, bool reduced) {
  const auto tile = static_cast<uint32_t>(options.tile_size);
  bool ok = TIFFSetField(tif, TIFFTAG_SUBFILETYPE, reduced ? FILETYPE_REDUCEDIMAGE : 0) &&
            TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(size.width)) &&
            TIFFSetField(tif, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(size.height)) &&
            TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, layout.bits) &&
            TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, layout.samples) &&
            TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, layout.format) &&
            TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, layout.photometric) &&
            TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG) &&
            TIFFSetField(tif, TIFFTAG_TILEWIDTH, tile) && TIFFSetField(tif, TIFFTAG_TILELENGTH, tile) &&
            TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE) &&
            TIFFSetField(tif, TIFFTAG_PREDICTOR, layout.predictor);
  if (ok && std::isfinite(options.nodata)) {
    ok = TIFFSetField(tif, geotiff_detail::kGdalNodataTag, fmt::format("{}", options.nodata).c_str());
  }
  if (!ok) Fail("cannot set the TIFF tags");
}

void GeoTiffWriter::Impl::SetGeoTags() {
  double scale[3] = {georef.cell, georef.cell, 0};
  double tiepoint[6] = {0, 0, 0, georef.x_min, georef.y_max, 0};
  if (!TIFFSetField(tif, TIFFTAG_GEOPIXELSCALE, 3, scale) || !TIFFSetField(tif, TIFFTAG_GEOTIEPOINTS, 6, tiepoint)) {
    Fail("cannot set the georeference tags");
  }
  if (!options.description.empty() && !TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, options.description.c_str())) {
    Fail("cannot set the description");
  }
  GTIF* keys = geotiff_detail::OpenGeoKeys(tif, &messages);
  if (!keys) Fail("cannot create the GeoTIFF keys");
  const bool geographic = IsGeographic(georef.epsg);
  GTIFKeySet(keys, GTModelTypeGeoKey, TYPE_SHORT, 1, geographic ? ModelTypeGeographic : ModelTypeProjected);
  GTIFKeySet(keys, GTRasterTypeGeoKey, TYPE_SHORT, 1, RasterPixelIsArea);
  if (!georef.citation.empty()) GTIFKeySet(keys, GTCitationGeoKey, TYPE_ASCII, 0, georef.citation.c_str());
  if (geographic) {
    GTIFKeySet(keys, GeographicTypeGeoKey, TYPE_SHORT, 1, georef.epsg);
  } else {
    GTIFKeySet(keys, ProjectedCSTypeGeoKey, TYPE_SHORT, 1, georef.epsg == 0 ? KvUserDefined : georef.epsg);
    // A local frame has no EPSG definition to take its unit from.
    if (georef.epsg == 0) GTIFKeySet(keys, ProjLinearUnitsGeoKey, TYPE_SHORT, 1, Linear_Meter);
  }
  if (georef.vertical_epsg != 0) {
    GTIFKeySet(keys, VerticalCSTypeGeoKey, TYPE_SHORT, 1, georef.vertical_epsg);
    GTIFKeySet(keys, VerticalUnitsGeoKey, TYPE_SHORT, 1, Linear_Meter);
  }
  const bool written = GTIFWriteKeys(keys);
  GTIFFree(keys);
  if (!written || !messages.errors.empty()) Fail("cannot write the GeoTIFF keys");
}

// `block` (the writer's type, BGR for colour) covers the raster part of tile (col, row) of the
// current directory; the rest of the tile is padded with the empty value.
void GeoTiffWriter::Impl::WriteBlock(int col, int row, const cv::Mat& block) {
  const int t = options.tile_size;
  cv::Mat tile(t, t, cv_type, cv::Scalar::all(EmptyValue()));
  block.copyTo(tile(cv::Rect(0, 0, block.cols, block.rows)));
  if (cv_type == CV_8UC3) {  // BGR in memory, RGB in the file
    for (auto it = tile.begin<cv::Vec3b>(); it != tile.end<cv::Vec3b>(); ++it) std::swap((*it)[0], (*it)[2]);
  }
  const uint32_t index = TIFFComputeTile(tif, static_cast<uint32_t>(col * t), static_cast<uint32_t>(row * t), 0, 0);
  const auto bytes = static_cast<tmsize_t>(tile.total() * tile.elemSize());
  if (TIFFWriteEncodedTile(tif, index, tile.data, bytes) < 0) Fail(fmt::format("cannot write tile {},{}", col, row));
}

// One overview IFD, `to` = `from` halved, built from level - 1 a row of tiles at a time. Tiles
// that would hold only the empty value stay unwritten, as at full resolution.
void GeoTiffWriter::Impl::WriteOverview(int level, cv::Size from, cv::Size to) {
  GeoTiffReader source(path);  // sees the directories written so far
  SetLayoutTags(to, true);
  Averaging averaging;
  if (cv_type == CV_32FC1 || cv_type == CV_16UC1) {
    averaging.skip_nodata = std::isfinite(options.nodata);
    averaging.nodata = options.nodata;
    averaging.none = averaging.skip_nodata ? options.nodata : std::numeric_limits<double>::quiet_NaN();
  }
  const int t = options.tile_size;
  const double empty = EmptyValue();
  for (int row = 0; row * t < to.height; ++row) {
    const int y = 2 * row * t;
    const cv::Mat band = Halve(source.Window(0, y, from.width, std::min(2 * t, from.height - y), level - 1), averaging);
    for (int col = 0; col * t < to.width; ++col) {
      const cv::Mat block = band(cv::Rect(col * t, 0, std::min(t, to.width - col * t), band.rows));
      if (cv::countNonZero(block.reshape(1) != empty) == 0) continue;
      WriteBlock(col, row, block);
    }
  }
  if (!TIFFWriteDirectory(tif)) Fail(fmt::format("cannot write overview {}", level));
}

GeoTiffWriter::GeoTiffWriter(std::filesystem::path path, int width, int height, int cv_type, GeoTiffGeoreference georef,
                             GeoTiffOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& w = *impl_;
  w.layout = LayoutOf(cv_type);
  CheckArguments(width, height, georef, options);
  w.path = std::move(path);
  w.width = width;
  w.height = height;
  w.cv_type = cv_type;
  w.georef = std::move(georef);
  w.options = std::move(options);
  // Classic TIFF offsets are 32-bit; deflate rarely grows data, so the raw size with overviews
  // (x 4/3) decides.
  const double raw_bytes = double(width) * height * CV_ELEM_SIZE(cv_type) * 4.0 / 3.0;
  w.tif = geotiff_detail::OpenTiff(w.path, raw_bytes > 2.0 * (1ull << 30) ? "w8" : "w", &w.messages);
  if (!w.tif) w.Fail("cannot create the file");
  w.created = true;
  w.SetLayoutTags(cv::Size(width, height), false);
  w.SetGeoTags();
}

GeoTiffWriter::~GeoTiffWriter() = default;
GeoTiffWriter::GeoTiffWriter(GeoTiffWriter&&) noexcept = default;
GeoTiffWriter& GeoTiffWriter::operator=(GeoTiffWriter&&) noexcept = default;

int GeoTiffWriter::tile_size() const { return impl_->options.tile_size; }
int GeoTiffWriter::tiles_across() const { return (impl_->width + tile_size() - 1) / tile_size(); }
int GeoTiffWriter::tiles_down() const { return (impl_->height + tile_size() - 1) / tile_size(); }

void GeoTiffWriter::WriteTile(int tile_col, int tile_row, const cv::Mat& block) {
  Impl& w = *impl_;
  if (!w.tif) throw std::logic_error("GeoTiffWriter::WriteTile after Finish or a failure: " + w.path.string());
  if (tile_col < 0 || tile_col >= tiles_across() || tile_row < 0 || tile_row >= tiles_down()) {
    throw std::invalid_argument(fmt::format("GeoTiffWriter::WriteTile: tile {},{} outside {}x{} tiles", tile_col,
                                            tile_row, tiles_across(), tiles_down()));
  }
  const int t = w.options.tile_size;
  const int need_w = std::min(t, w.width - tile_col * t), need_h = std::min(t, w.height - tile_row * t);
  if (block.type() != w.cv_type || block.cols < need_w || block.cols > t || block.rows < need_h || block.rows > t) {
    throw std::invalid_argument(
        fmt::format("GeoTiffWriter::WriteTile: block {}x{} type {} for tile {},{}, expected {}x{} to {}x{} of type {}",
                    block.cols, block.rows, block.type(), tile_col, tile_row, need_w, need_h, t, t, w.cv_type));
  }
  w.WriteBlock(tile_col, tile_row, block(cv::Rect(0, 0, need_w, need_h)));
}

void GeoTiffWriter::Finish() {
  Impl& w = *impl_;
  if (!w.tif) throw std::logic_error("GeoTiffWriter::Finish called twice or after a failure: " + w.path.string());
  try {
    if (!TIFFWriteDirectory(w.tif)) w.Fail("cannot write the image directory");
    cv::Size from(w.width, w.height);
    const int t = w.options.tile_size;
    for (int level = 1; w.options.overviews && (from.width > t || from.height > t); ++level) {
      const cv::Size to((from.width + 1) / 2, (from.height + 1) / 2);
      w.WriteOverview(level, from, to);
      from = to;
    }
    w.Close();
  } catch (const InputError& e) {
    w.Abandon();
    throw WriteError(w.path, "reading back the written tiles: " + e.message());
  } catch (...) {
    w.Abandon();
    throw;
  }
  w.finished = true;
}

}  // namespace rs
