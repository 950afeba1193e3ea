#include "stages/report/ortho_pieces.h"

#include <fmt/format.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>

#include "formats/checked_file.h"
#include "formats/geo/geotiff.h"

namespace rs {
namespace fs = std::filesystem;
namespace {

// Share of the raster's pixels that hold data, from its coarsest level (a few thousand pixels).
double DataShare(GeoTiffReader& ortho) {
  const int level = ortho.overview_count();
  const cv::Size s = ortho.level_size(level);
  const cv::Mat coarse = ortho.Window(0, 0, s.width, s.height, level);
  std::vector<cv::Mat> channels;
  cv::split(coarse, channels);
  cv::Mat any = channels[0] | channels[1] | channels[2];
  return s.area() > 0 ? static_cast<double>(cv::countNonZero(any)) / s.area() : 0.0;
}

// The finest level whose data pixels fit the budget (the coarsest when none does).
int ChooseLevel(GeoTiffReader& ortho, long long max_pixels) {
  const double share = DataShare(ortho);
  for (int level = 0; level <= ortho.overview_count(); ++level)
    if (static_cast<double>(ortho.level_size(level).area()) * share <= static_cast<double>(max_pixels)) return level;
  return ortho.overview_count();
}

// BGR with nodata 0 -> BGRA, transparent where no channel has data; the count of data pixels.
cv::Mat WithAlpha(const cv::Mat& bgr, int* data_pixels) {
  std::vector<cv::Mat> channels;
  cv::split(bgr, channels);
  cv::Mat alpha = (channels[0] | channels[1] | channels[2]) > 0;
  *data_pixels = cv::countNonZero(alpha);
  channels.push_back(alpha);
  cv::Mat bgra;
  cv::merge(channels, bgra);
  return bgra;
}

}  // namespace

OrthoPieces WriteOrthoPieces(const fs::path& ortho_tif, const fs::path& report_dir, const OrthoPieceOptions& o) {
  GeoTiffReader ortho(ortho_tif);
  OrthoPieces out;
  out.level = ChooseLevel(ortho, o.max_pixels);
  const cv::Size full = ortho.level_size(0), size = ortho.level_size(out.level);
  const GeoTiffGeoreference& g = ortho.georef();
  // An overview pixel covers the full raster's extent divided by the overview's size.
  out.cell_x = g.cell * full.width / size.width;
  out.cell_y = g.cell * full.height / size.height;
  const bool webp = cv::haveImageWriter(".webp");
  const std::string ext = webp ? "webp" : "png";
  const std::vector<int> params =
      webp ? std::vector<int>{cv::IMWRITE_WEBP_QUALITY, o.quality} : std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 6};
  fs::create_directories(report_dir / "ortho");
  for (int y = 0, row = 0; y < size.height; y += o.piece_px, ++row)
    for (int x = 0, col = 0; x < size.width; x += o.piece_px, ++col) {
      const int w = std::min(o.piece_px, size.width - x), h = std::min(o.piece_px, size.height - y);
      int data = 0;
      const cv::Mat bgra = WithAlpha(ortho.Window(x, y, w, h, out.level), &data);
      if (data == 0) continue;
      OrthoPiece p;
      p.file = fmt::format("ortho/{}_{}.{}", row, col, ext);
      std::vector<uchar> bytes;
      if (!cv::imencode("." + ext, bgra, bytes, params))
        throw WriteError(report_dir / p.file, "the image encoder failed");
      WriteFileChecked(report_dir / p.file, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
      p.x_min = g.x_min + x * out.cell_x;
      p.x_max = g.x_min + (x + w) * out.cell_x;
      p.y_max = g.y_max - y * out.cell_y;
      p.y_min = g.y_max - (y + h) * out.cell_y;
      out.pixels += data;
      out.pieces.push_back(std::move(p));
    }
  return out;
}

}  // namespace rs
