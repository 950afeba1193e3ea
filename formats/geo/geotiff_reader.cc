// Reading GeoTIFFs through libtiff + libgeotiff, and the handle setup the writer shares.

#include <geotiff/geotiff.h>
#include <geotiff/geovalues.h>
#include <geotiff/xtiffio.h>
#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "formats/geo/geotiff.h"
#include "formats/input_error.h"

namespace rs {
namespace geotiff_detail {
namespace {

TIFFExtendProc g_parent_extender = nullptr;

void ExtendTags(TIFF* tif) {
  static const TIFFFieldInfo kNodata[] = {{static_cast<ttag_t>(kGdalNodataTag), -1, -1, TIFF_ASCII, FIELD_CUSTOM, 1, 0,
                                           const_cast<char*>("GDALNoDataValue")}};
  TIFFMergeFieldInfo(tif, kNodata, 1);
  if (g_parent_extender) g_parent_extender(tif);
}

void RegisterTags() {
  static std::once_flag once;
  std::call_once(once, [] {
    XTIFFInitialize();  // GeoTIFF tags, chained into libtiff's tag extender
    g_parent_extender = TIFFSetTagExtender(ExtendTags);
  });
}

void Append(TiffMessages* messages, const char* module, const char* fmt, va_list ap) {
  char buffer[1024];
  std::vsnprintf(buffer, sizeof buffer, fmt, ap);
  std::string_view text = buffer;
  const std::string prefix = messages->file + ": ";
  if (!messages->file.empty() && text.starts_with(prefix)) text.remove_prefix(prefix.size());
  std::string& out = messages->errors;
  if (!out.empty()) out += "; ";
  if (module && *module && module != messages->file) out += std::string(module) + ": ";
  out += text;
}

int CollectError(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
  Append(static_cast<TiffMessages*>(user), module, fmt, ap);
  return 1;  // handled: libtiff's global handler would print to stderr
}

// Unknown tags and the like in foreign files; nothing a caller can act on.
int DropWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

void CollectGeoTiffError(GTIF* gtif, int, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  Append(static_cast<TiffMessages*>(GTIFGetUserData(gtif)), "libgeotiff", fmt, ap);
  va_end(ap);
}

}  // namespace

std::string TiffMessages::Take(const std::string& fallback) {
  std::string text = errors.empty() ? fallback : errors;
  errors.clear();
  return text;
}

TIFF* OpenTiff(const std::filesystem::path& path, const char* mode, TiffMessages* messages) {
  RegisterTags();
  messages->file = path.string();
  TIFFOpenOptions* options = TIFFOpenOptionsAlloc();
  TIFFOpenOptionsSetErrorHandlerExtR(options, CollectError, messages);
  TIFFOpenOptionsSetWarningHandlerExtR(options, DropWarning, nullptr);
  TIFF* tif = TIFFOpenExt(path.c_str(), mode, options);
  TIFFOpenOptionsFree(options);
  return tif;
}

GTIF* OpenGeoKeys(TIFF* tif, TiffMessages* messages) { return GTIFNewEx(tif, CollectGeoTiffError, messages); }

}  // namespace geotiff_detail

namespace {

using geotiff_detail::TiffMessages;

// The cv type of the current directory's sample layout, or -1.
int CvTypeOf(TIFF* tif) {
  uint16_t bits = 0, samples = 1, format = SAMPLEFORMAT_UINT, planar = PLANARCONFIG_CONTIG, photometric = 0;
  TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &samples);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFGetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &planar);
  TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &photometric);
  if (planar != PLANARCONFIG_CONTIG && samples > 1) return -1;
  if (samples == 1 && bits == 32 && format == SAMPLEFORMAT_IEEEFP) return CV_32FC1;
  if (samples == 1 && bits == 16 && format == SAMPLEFORMAT_UINT) return CV_16UC1;
  if (samples == 1 && bits == 8 && format == SAMPLEFORMAT_UINT) return CV_8UC1;
  if (samples == 3 && bits == 8 && format == SAMPLEFORMAT_UINT && photometric == PHOTOMETRIC_RGB) return CV_8UC3;
  return -1;
}

int KeyShort(GTIF* gtif, geokey_t key) {
  unsigned short value = 0;
  return GTIFKeyGetSHORT(gtif, key, &value, 0, 1) == 1 ? value : 0;
}

}  // namespace

struct GeoTiffReader::Impl {
  std::filesystem::path path;
  TiffMessages messages;
  TIFF* tif = nullptr;
  int cv_type = -1;
  GeoTiffGeoreference georef;
  double nodata = std::numeric_limits<double>::quiet_NaN();
  std::string description;
  std::vector<cv::Size> level_sizes;      // [0] = full resolution
  std::vector<tdir_t> level_directories;  // IFD index of each level
  tdir_t current_directory = 0;

  ~Impl() {
    if (tif) TIFFClose(tif);
  }

  [[noreturn]] void Fail(const std::string& fallback) {
    throw InputError(InputLocation::File(path.string()), messages.Take(fallback));
  }

  void Open();
  void ReadGeoreference();
  void FindOverviews();
  void SelectLevel(int level);
  void ReadBlocks(int x, int y, cv::Mat* out);
};

void GeoTiffReader::Impl::Open() {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) Fail("no such file");
  tif = geotiff_detail::OpenTiff(path, "rm", &messages);  // no mmap: files far larger than memory
  if (!tif) Fail("not a readable TIFF file");
  cv_type = CvTypeOf(tif);
  if (cv_type < 0) Fail("unsupported sample layout (readable: 32-bit float, 16/8-bit unsigned grey, 8-bit RGB)");
  uint32_t width = 0, height = 0;
  TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &height);
  if (width == 0 || height == 0 || width > INT32_MAX || height > INT32_MAX) Fail("bad image size");
  level_sizes.push_back(cv::Size(static_cast<int>(width), static_cast<int>(height)));
  level_directories.push_back(0);
  ReadGeoreference();
  char* text = nullptr;
  if (TIFFGetField(tif, geotiff_detail::kGdalNodataTag, &text) && text) nodata = std::strtod(text, nullptr);
  if (TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &text) && text) description = text;
  FindOverviews();
}

void GeoTiffReader::Impl::ReadGeoreference() {
  uint16_t count = 0;
  double* scale = nullptr;
  double* tie = nullptr;
  if (!TIFFGetField(tif, TIFFTAG_GEOPIXELSCALE, &count, &scale) || count < 2) {
    Fail("not a GeoTIFF: no ModelPixelScale tag (a rotated ModelTransformation is not supported)");
  }
  const double sx = scale[0], sy = scale[1];
  if (!TIFFGetField(tif, TIFFTAG_GEOTIEPOINTS, &count, &tie) || count < 6) Fail("not a GeoTIFF: no ModelTiepoint tag");
  if (!(sx > 0) || std::abs(sx - sy) > 1e-9 * sx) Fail("pixels are not square (only north-up square pixels are read)");

  GTIF* gtif = geotiff_detail::OpenGeoKeys(tif, &messages);
  if (!gtif) Fail("unreadable GeoTIFF keys");
  const bool point = KeyShort(gtif, GTRasterTypeGeoKey) == RasterPixelIsPoint;
  georef.cell = sx;
  georef.x_min = tie[3] - tie[0] * sx - (point ? sx / 2 : 0);
  georef.y_max = tie[4] + tie[1] * sx + (point ? sx / 2 : 0);
  const int model = KeyShort(gtif, GTModelTypeGeoKey);
  const int code = KeyShort(gtif, model == ModelTypeGeographic ? GeographicTypeGeoKey : ProjectedCSTypeGeoKey);
  georef.epsg = code == KvUserDefined ? 0 : code;
  const int vertical = KeyShort(gtif, VerticalCSTypeGeoKey);
  georef.vertical_epsg = vertical == KvUserDefined ? 0 : vertical;
  int size = 0;
  tagtype_t type;
  const int chars = GTIFKeyInfo(gtif, GTCitationGeoKey, &size, &type);
  if (chars > 0 && type == TYPE_ASCII) {
    std::vector<char> citation(static_cast<size_t>(chars) + 1, '\0');
    GTIFKeyGetASCII(gtif, GTCitationGeoKey, citation.data(), chars + 1);
    georef.citation = citation.data();
  }
  GTIFFree(gtif);
  if (!messages.errors.empty()) Fail("");
}

// Reduced-resolution IFDs after the first (GDAL's internal overviews); masks are skipped.
void GeoTiffReader::Impl::FindOverviews() {
  for (tdir_t dir = 1; TIFFReadDirectory(tif); ++dir) {
    uint32_t subfile = 0, width = 0, height = 0;
    TIFFGetFieldDefaulted(tif, TIFFTAG_SUBFILETYPE, &subfile);
    TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &width);
    TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &height);
    if (!(subfile & FILETYPE_REDUCEDIMAGE) || (subfile & FILETYPE_MASK) || CvTypeOf(tif) != cv_type) continue;
    if (width == 0 || height == 0 || width > INT32_MAX || height > INT32_MAX) Fail("bad overview size");
    level_sizes.push_back(cv::Size(static_cast<int>(width), static_cast<int>(height)));
    level_directories.push_back(dir);
  }
  if (!messages.errors.empty()) Fail("");
  if (!TIFFSetDirectory(tif, 0)) Fail("cannot reread the first directory");
}

void GeoTiffReader::Impl::SelectLevel(int level) {
  if (level < 0 || level >= static_cast<int>(level_sizes.size())) {
    throw std::invalid_argument("GeoTiffReader: level " + std::to_string(level) + " out of range [0, " +
                                std::to_string(level_sizes.size()) + ")");
  }
  const tdir_t dir = level_directories[static_cast<size_t>(level)];
  if (dir != current_directory) {
    if (!TIFFSetDirectory(tif, dir)) Fail("cannot read directory " + std::to_string(dir));
    current_directory = dir;
  }
}

// Copies every stored block (tile or strip) of the current level that overlaps `out`, whose
// top-left pixel is (x, y); unwritten blocks (byte count 0) keep out's fill.
void GeoTiffReader::Impl::ReadBlocks(int x, int y, cv::Mat* out) {
  uint32_t image_w = 0, image_h = 0;
  TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &image_w);
  TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &image_h);
  const bool tiled = TIFFIsTiled(tif);
  uint32_t block_w = image_w, block_h = image_h;
  if (tiled) {
    TIFFGetField(tif, TIFFTAG_TILEWIDTH, &block_w);
    TIFFGetField(tif, TIFFTAG_TILELENGTH, &block_h);
  } else {
    TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &block_h);
    block_h = std::min(block_h, image_h);
  }
  if (block_w == 0 || block_h == 0) Fail("bad tile or strip size");
  const cv::Rect image(0, 0, static_cast<int>(image_w), static_cast<int>(image_h));
  const cv::Rect wanted = cv::Rect(x, y, out->cols, out->rows) & image;
  if (wanted.empty()) return;
  const size_t pixel_bytes = CV_ELEM_SIZE(cv_type);
  const tmsize_t block_bytes = static_cast<tmsize_t>(block_w) * block_h * static_cast<tmsize_t>(pixel_bytes);
  std::vector<uint8_t> buffer(static_cast<size_t>(block_bytes));
  const int bw = static_cast<int>(block_w), bh = static_cast<int>(block_h);
  for (int by = wanted.y / bh; by * bh < wanted.br().y; ++by) {
    for (int bx = wanted.x / bw; bx * bw < wanted.br().x; ++bx) {
      const uint32_t index = tiled ? TIFFComputeTile(tif, bx * bw, by * bh, 0, 0) : TIFFComputeStrip(tif, by * bh, 0);
      if (TIFFGetStrileByteCount(tif, index) == 0) continue;  // never written: sparse
      const tmsize_t got = tiled ? TIFFReadEncodedTile(tif, index, buffer.data(), block_bytes)
                                 : TIFFReadEncodedStrip(tif, index, buffer.data(), block_bytes);
      const cv::Rect block = cv::Rect(bx * bw, by * bh, bw, bh) & image;
      const tmsize_t needed = static_cast<tmsize_t>(block.height - 1) * bw * static_cast<tmsize_t>(pixel_bytes) +
                              static_cast<tmsize_t>(block.width) * static_cast<tmsize_t>(pixel_bytes);
      if (got < needed) Fail("cannot read block " + std::to_string(index));
      const cv::Rect overlap = block & wanted;
      const cv::Mat source(bh, bw, cv_type, buffer.data());
      source(overlap - block.tl()).copyTo((*out)(overlap - cv::Point(x, y)));
    }
  }
}

GeoTiffReader::GeoTiffReader(const std::filesystem::path& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->Open();
}

GeoTiffReader::~GeoTiffReader() = default;
GeoTiffReader::GeoTiffReader(GeoTiffReader&&) noexcept = default;
GeoTiffReader& GeoTiffReader::operator=(GeoTiffReader&&) noexcept = default;

int GeoTiffReader::width() const { return impl_->level_sizes[0].width; }
int GeoTiffReader::height() const { return impl_->level_sizes[0].height; }
int GeoTiffReader::cv_type() const { return impl_->cv_type; }
const GeoTiffGeoreference& GeoTiffReader::georef() const { return impl_->georef; }
double GeoTiffReader::nodata() const { return impl_->nodata; }
int GeoTiffReader::overview_count() const { return static_cast<int>(impl_->level_sizes.size()) - 1; }
const std::string& GeoTiffReader::description() const { return impl_->description; }

cv::Size GeoTiffReader::level_size(int level) const {
  if (level < 0 || level > overview_count())
    throw std::invalid_argument("GeoTiffReader: no level " + std::to_string(level));
  return impl_->level_sizes[static_cast<size_t>(level)];
}

cv::Mat GeoTiffReader::Window(int x, int y, int w, int h, int level) {
  if (w < 0 || h < 0) throw std::invalid_argument("GeoTiffReader::Window: negative size");
  impl_->SelectLevel(level);
  const double fill = std::isfinite(impl_->nodata) ? impl_->nodata : 0.0;
  cv::Mat out(h, w, impl_->cv_type, cv::Scalar::all(fill));
  impl_->ReadBlocks(x, y, &out);
  if (impl_->cv_type == CV_8UC3) {  // RGB in the file, BGR in memory
    for (int r = 0; r < out.rows; ++r) {
      for (auto *p = out.ptr<cv::Vec3b>(r), *end = p + out.cols; p != end; ++p) std::swap((*p)[0], (*p)[2]);
    }
  }
  return out;
}

GeoTiffRaster ReadGeoTiff(const std::filesystem::path& path) {
  GeoTiffReader reader(path);
  GeoTiffRaster raster;
  raster.image = reader.Window(0, 0, reader.width(), reader.height());
  raster.georef = reader.georef();
  raster.nodata = reader.nodata();
  raster.overview_count = reader.overview_count();
  raster.description = reader.description();
  return raster;
}

cv::Mat ReadGeoTiffWindow(const std::filesystem::path& path, int x, int y, int w, int h) {
  return GeoTiffReader(path).Window(x, y, w, h);
}

}  // namespace rs
