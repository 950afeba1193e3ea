#pragma once
// Tiled, deflate-compressed GeoTIFFs (libtiff + libgeotiff) for north-up rasters: orthomosaics,
// height and damage grids. The writer streams tile by tile so a raster far larger than memory can
// be written, then adds internal overviews the way GDAL lays them out (reduced-resolution IFDs
// after the full-resolution one), so GDAL/QGIS read the files directly.

#include <filesystem>
#include <limits>
#include <memory>
#include <string>

#include <opencv2/core/mat.hpp>

struct tiff;   // libtiff's TIFF
struct gtiff;  // libgeotiff's GTIF

namespace rs {

/// Where a north-up raster lies in its CRS.
struct GeoTiffGeoreference {
  double x_min = 0;  ///< CRS x (easting) of the raster's left edge (outer edge of pixel column 0)
  double y_max = 0;  ///< CRS y (northing) of the raster's top edge (outer edge of row 0)
  double cell = 0;   ///< square pixel size, CRS units
  /// Horizontal CRS EPSG code: projected (e.g. 32633) or, for codes 4000-4999, geographic;
  /// 0 = user-defined local frame described by `citation`.
  int epsg = 0;
  int vertical_epsg = 0;  ///< e.g. 5773 (EGM96 height); 0 = no vertical code (heights described in `description`)
  std::string citation;   ///< GTCitationGeoKey text (e.g. the CRS's name or the local frame's description)
};

/// How GeoTiffWriter lays out the file.
struct GeoTiffOptions {
  int tile_size = 256;  ///< square tiles, multiple of 16
  /// Written as GDAL_NODATA (tag 42113) when finite; for float rasters use e.g. -9999. Pixels of
  /// tiles never written read as this value (0 when it is not finite).
  double nodata = std::numeric_limits<double>::quiet_NaN();
  /// Internal overviews: reduced-resolution IFDs, factors 2, 4, 8, ... until the level fits one tile.
  bool overviews = true;
  std::string description;  ///< TIFFTAG_IMAGEDESCRIPTION (e.g. "height above WGS84 ellipsoid, m")
};

/// Writes a tiled, deflate-compressed GeoTIFF block by block, so a raster far larger than memory
/// can be written: blocks may come in any order; blocks never written are left empty (sparse;
/// readers, GDAL included, see nodata). The file is written at the path given and removed again
/// unless Finish() completes. Files whose pixels exceed 2 GiB uncompressed are BigTIFF.
class GeoTiffWriter {
 public:
  /// cv_type: CV_32FC1, CV_16UC1, CV_8UC1 or CV_8UC3 (BGR in memory, RGB photometric in the file).
  /// Throws std::invalid_argument on a bad size, type, tile size or georeference, and WriteError
  /// naming the file when it cannot be created.
  GeoTiffWriter(std::filesystem::path path, int width, int height, int cv_type, GeoTiffGeoreference georef,
                GeoTiffOptions options = {});
  /// Closes and removes an unfinished file.
  ~GeoTiffWriter();
  GeoTiffWriter(GeoTiffWriter&&) noexcept;
  GeoTiffWriter& operator=(GeoTiffWriter&&) noexcept;

  int tile_size() const;
  int tiles_across() const;
  int tiles_down() const;

  /// One tile: `block` of the writer's type, tile_size x tile_size; at the right/bottom edge a
  /// block that covers just the rest of the raster is accepted and padded with nodata (or 0).
  /// Writing a tile again replaces it. Throws std::invalid_argument on a bad tile index, type or
  /// size, WriteError naming the file when the write fails.
  void WriteTile(int tile_col, int tile_row, const cv::Mat& block);

  /// Builds the overviews from the full-resolution tiles (reading them back a row of tiles at a
  /// time, so memory stays O(width x tile)), with averaging that ignores nodata and NaN (float,
  /// 16U) or plain averaging (8-bit), and closes the file. Throws WriteError naming the file when
  /// anything fails; the file is then removed.
  void Finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// A GeoTIFF read whole (tests, evaluation).
struct GeoTiffRaster {
  cv::Mat image;  ///< full resolution; CV_32FC1, CV_16UC1, CV_8UC1 or CV_8UC3 (BGR)
  GeoTiffGeoreference georef;
  double nodata = std::numeric_limits<double>::quiet_NaN();  ///< GDAL_NODATA, NaN when absent
  int overview_count = 0;
  std::string description;
};

/// An open GeoTIFF for streaming consumers: reads windows of the full-resolution image or of an
/// overview. Reads tiled and stripped files (contiguous planes; the sample layouts of
/// GeoTiffWriter). Every method throws InputError naming the file on a missing, foreign or corrupt
/// file.
class GeoTiffReader {
 public:
  explicit GeoTiffReader(const std::filesystem::path& path);
  ~GeoTiffReader();
  GeoTiffReader(GeoTiffReader&&) noexcept;
  GeoTiffReader& operator=(GeoTiffReader&&) noexcept;

  int width() const;
  int height() const;
  int cv_type() const;
  const GeoTiffGeoreference& georef() const;
  double nodata() const;  ///< NaN when the file has no GDAL_NODATA
  int overview_count() const;
  const std::string& description() const;
  /// Size of level 0 (full resolution) or overview `level` (1 = first, half size).
  cv::Size level_size(int level) const;

  /// Rows [y, y+h), cols [x, x+w) of `level`; pixels outside the raster or in unwritten tiles are
  /// nodata (0 when nodata is not finite).
  cv::Mat Window(int x, int y, int w, int h, int level = 0);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reads the whole full-resolution raster. Throws InputError naming the file on a
/// missing/foreign/corrupt file.
GeoTiffRaster ReadGeoTiff(const std::filesystem::path& path);

/// Reads one window of the full-resolution image, rows [y, y+h) cols [x, x+w); pixels outside
/// the raster or in unwritten tiles are nodata (or 0). Opens the file per call; keep a
/// GeoTiffReader for many windows.
cv::Mat ReadGeoTiffWindow(const std::filesystem::path& path, int x, int y, int w, int h);

/// Shared by the writer and the reader.
namespace geotiff_detail {

/// libtiff's and libgeotiff's error messages for one handle, "; "-separated.
struct TiffMessages {
  std::string errors;
  std::string file;  ///< the handle's path, dropped from messages (callers name the file themselves)
  /// The messages collected since the last call, or `fallback` when there are none.
  std::string Take(const std::string& fallback);
};

/// TIFFOpen with the GeoTIFF tags and GDAL_NODATA registered and the handle's errors collected in
/// `messages` (which must outlive the handle) instead of printed; warnings are dropped.
/// nullptr when it fails.
::tiff* OpenTiff(const std::filesystem::path& path, const char* mode, TiffMessages* messages);

/// GTIFNewEx on an open handle, its errors collected in `messages`; nullptr when it fails.
::gtiff* OpenGeoKeys(::tiff* tif, TiffMessages* messages);

/// TIFF tag GDAL writes its nodata value in (ASCII).
inline constexpr unsigned kGdalNodataTag = 42113;

}  // namespace geotiff_detail
}  // namespace rs
