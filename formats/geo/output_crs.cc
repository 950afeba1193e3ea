#include "formats/geo/output_crs.h"

#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <fmt/format.h>
#include <proj.h>

#include <cmath>
#include <mutex>
#include <optional>
#include <stdexcept>

namespace rs {
namespace {

constexpr const char* kWgs84Geographic3d = "EPSG:4979";  // lat, lon, ellipsoidal height
constexpr const char* kEgm96Height = "EPSG:5773";

// One PROJ context and transformation (WGS84 3D -> target), lon/lat axis order on input.
struct ProjTransform {
  PJ_CONTEXT* ctx = nullptr;
  PJ* op = nullptr;
  ProjTransform(const std::string& source, const std::string& target) {
    ctx = proj_context_create();
    proj_log_level(ctx, PJ_LOG_NONE);
    PJ* raw = proj_create_crs_to_crs(ctx, source.c_str(), target.c_str(), nullptr);
    if (raw) {
      op = proj_normalize_for_visualization(ctx, raw);
      proj_destroy(raw);
    }
    if (!op) {
      const std::string why = proj_context_errno_string(ctx, proj_context_errno(ctx));
      proj_context_destroy(ctx);
      throw std::invalid_argument(fmt::format("crs \"{}\": PROJ cannot transform {} to it ({})", target, source, why));
    }
  }
  ~ProjTransform() {
    proj_destroy(op);
    proj_context_destroy(ctx);
  }
  ProjTransform(const ProjTransform&) = delete;
  ProjTransform& operator=(const ProjTransform&) = delete;

  Eigen::Vector3d Apply(double lon, double lat, double h) const {
    const PJ_COORD out = proj_trans(op, PJ_FWD, proj_coord(lon, lat, h, HUGE_VAL));
    return {out.xyz.x, out.xyz.y, out.xyz.z};
  }
};

std::string WktOf(const std::string& crs) {
  PJ_CONTEXT* ctx = proj_context_create();
  proj_log_level(ctx, PJ_LOG_NONE);
  PJ* obj = proj_create(ctx, crs.c_str());
  std::string wkt;
  if (obj) {
    if (const char* w = proj_as_wkt(ctx, obj, PJ_WKT2_2019, nullptr)) wkt = w;
    proj_destroy(obj);
  }
  proj_context_destroy(ctx);
  if (wkt.empty()) throw std::invalid_argument(fmt::format("crs \"{}\": PROJ does not know this CRS", crs));
  return wkt;
}

// True when `crs` is a 2D or 3D projected or geographic CRS (a vertical datum can be added).
bool IsHorizontalCrs(const std::string& crs) {
  PJ_CONTEXT* ctx = proj_context_create();
  proj_log_level(ctx, PJ_LOG_NONE);
  PJ* obj = proj_create(ctx, crs.c_str());
  bool ok = false;
  if (obj) {
    const PJ_TYPE t = proj_get_type(obj);
    ok = t == PJ_TYPE_PROJECTED_CRS || t == PJ_TYPE_GEOGRAPHIC_2D_CRS || t == PJ_TYPE_GEOGRAPHIC_3D_CRS;
    proj_destroy(obj);
  }
  proj_context_destroy(ctx);
  return ok;
}

}  // namespace

const char* ToString(HeightReference h) {
  return h == HeightReference::kEllipsoid ? "WGS84 ellipsoidal height" : "height above the EGM96 geoid (EPSG:5773)";
}

int UtmZone(double lat_deg, double lon_deg) { return GeographicLib::UTMUPS::StandardZone(lat_deg, lon_deg); }

struct OutputCrs::Impl {
  std::string spec, epsg, wkt;
  HeightReference heights = HeightReference::kEllipsoid;
  Geodetic origin;
  std::optional<GeographicLib::LocalCartesian> enu;
  std::unique_ptr<ProjTransform> proj;
};

OutputCrs::OutputCrs(const std::string& spec, const Geodetic& centre, HeightReference heights)
    : impl_(std::make_unique<Impl>()) {
  impl_->spec = spec;
  impl_->heights = heights;
  impl_->origin = centre;
  if (spec == "enu") {
    if (heights != HeightReference::kEllipsoid)
      throw std::invalid_argument("crs \"enu\": heights are the tangent plane's up axis; geoid heights need a CRS");
    impl_->enu.emplace(centre.lat_deg, centre.lon_deg, centre.h_ellipsoid_m);
    impl_->wkt = fmt::format(
        "local ENU tangent plane (x east, y north, z up, metres) at WGS84 lat {:.9f} deg, lon {:.9f} deg, "
        "ellipsoidal height {:.4f} m",
        centre.lat_deg, centre.lon_deg, centre.h_ellipsoid_m);
    return;
  }
  std::string horizontal;
  if (spec == "utm") {
    const int zone = UtmZone(centre.lat_deg, centre.lon_deg);
    if (zone < 1) throw std::invalid_argument("crs \"utm\": the survey's centre lies in a polar (UPS) region");
    horizontal = fmt::format("EPSG:{}", (centre.lat_deg >= 0 ? 32600 : 32700) + zone);
  } else if (spec.rfind("EPSG:", 0) == 0 && spec.size() > 5 &&
             spec.find_first_not_of("0123456789", 5) == std::string::npos) {
    horizontal = spec;
  } else {
    throw std::invalid_argument(fmt::format("crs \"{}\": expected \"utm\", \"enu\" or \"EPSG:<code>\"", spec));
  }
  if (!IsHorizontalCrs(horizontal))
    throw std::invalid_argument(fmt::format("crs \"{}\": not a projected or geographic CRS PROJ knows", spec));
  impl_->epsg = heights == HeightReference::kGeoidEgm96 ? horizontal + "+5773" : horizontal;
  impl_->wkt = WktOf(impl_->epsg);
  impl_->proj = std::make_unique<ProjTransform>(kWgs84Geographic3d, impl_->epsg);
  if (heights == HeightReference::kGeoidEgm96) {
    // PROJ falls back to a ballpark (no geoid) when the grid is missing: refuse instead.
    (void)Egm96UndulationM(centre.lat_deg, centre.lon_deg);
  }
}

OutputCrs::~OutputCrs() = default;
OutputCrs::OutputCrs(OutputCrs&&) noexcept = default;
OutputCrs& OutputCrs::operator=(OutputCrs&&) noexcept = default;

Eigen::Vector3d OutputCrs::Forward(const Geodetic& p) const {
  if (impl_->enu) {
    Eigen::Vector3d x;
    impl_->enu->Forward(p.lat_deg, p.lon_deg, p.h_ellipsoid_m, x.x(), x.y(), x.z());
    return x;
  }
  return impl_->proj->Apply(p.lon_deg, p.lat_deg, p.h_ellipsoid_m);
}

const std::string& OutputCrs::spec() const { return impl_->spec; }
const std::string& OutputCrs::epsg() const { return impl_->epsg; }
const std::string& OutputCrs::wkt() const { return impl_->wkt; }
HeightReference OutputCrs::heights() const { return impl_->heights; }
const Geodetic& OutputCrs::origin() const { return impl_->origin; }
bool OutputCrs::is_local_enu() const { return impl_->enu.has_value(); }

double Egm96UndulationM(double lat_deg, double lon_deg) {
  // One transformation shared by all callers; proj_trans on one PJ is not thread-safe.
  static std::mutex mutex;
  static std::unique_ptr<ProjTransform> to_geoid;
  std::lock_guard<std::mutex> lock(mutex);
  if (!to_geoid) {
    to_geoid = std::make_unique<ProjTransform>(kWgs84Geographic3d, std::string("EPSG:4326+") + kEgm96Height);
    // Without the grid PROJ picks a ballpark transformation that leaves heights unchanged.
    const Eigen::Vector3d probe = to_geoid->Apply(0.0, 0.0, 0.0);
    if (!std::isfinite(probe.z()) || std::abs(probe.z()) < 1.0) {
      to_geoid.reset();
      throw std::runtime_error("EGM96 geoid grid not found by PROJ (install proj-data: egm96_15.gtx)");
    }
  }
  const Eigen::Vector3d geoid = to_geoid->Apply(lon_deg, lat_deg, 0.0);
  return -geoid.z();  // H = h - N with h = 0
}

}  // namespace rs
