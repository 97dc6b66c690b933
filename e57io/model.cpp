#include "e57io/model.hpp"

#include <cmath>

#include "e57io/error.hpp"

namespace coloc::e57 {
namespace {

const Element* child_of(const Element& e, const char* name, ElementType type) {
  const Element* c = e.find(name);
  if (c != nullptr && c->type != type) {
    throw Error(
        std::string("'") + name + "' is a " + to_string(c->type) + ", expected " + to_string(type),
        {.element = c->path});
  }
  return c;
}

std::string get_string(const Element& e, const char* name) {
  const Element* c = child_of(e, name, ElementType::kString);
  return c != nullptr ? c->string_value : std::string{};
}

double get_number(const Element& e, const char* name, double fallback = 0.0) {
  const Element* c = e.find(name);
  return c != nullptr ? c->number() : fallback;
}

std::optional<double> get_optional_number(const Element& e, const char* name) {
  const Element* c = e.find(name);
  if (c == nullptr) return std::nullopt;
  return c->number();
}

std::int64_t get_integer(const Element& e, const char* name) {
  const Element* c = e.find(name);
  if (c == nullptr) return 0;
  if (c->type == ElementType::kInteger) return c->int_value;
  const double v = c->number();
  if (!(std::abs(v) < 9.2e18)) {
    throw Error("value does not fit a 64-bit integer", {.element = c->path});
  }
  return static_cast<std::int64_t>(v);
}

std::optional<Pose> get_pose(const Element& e, const char* name) {
  const Element* p = child_of(e, name, ElementType::kStructure);
  if (p == nullptr) return std::nullopt;
  Pose pose;
  if (const Element* r = child_of(*p, "rotation", ElementType::kStructure)) {
    pose.rotation = {get_number(*r, "w", 1.0), get_number(*r, "x"), get_number(*r, "y"),
                     get_number(*r, "z")};
  }
  if (const Element* t = child_of(*p, "translation", ElementType::kStructure)) {
    pose.translation = {get_number(*t, "x"), get_number(*t, "y"), get_number(*t, "z")};
  }
  return pose;
}

std::optional<DateTime> get_datetime(const Element& e, const char* name) {
  const Element* d = child_of(e, name, ElementType::kStructure);
  if (d == nullptr) return std::nullopt;
  return DateTime{get_number(*d, "dateTimeValue"), get_integer(*d, "isAtomicClockReferenced") != 0};
}

Element structure(const std::string& name) {
  return Element::make_structure(name);
}

void add_string(Element& e, const char* name, const std::string& v, bool always = false) {
  if (always || !v.empty()) e.children.push_back(Element::make_string(name, v));
}

void add_float(Element& e, const char* name, double v) {
  e.children.push_back(Element::make_float(name, v));
}

void read_bounds(const Element& scan, Data3D& d) {
  if (const Element* b = child_of(scan, "cartesianBounds", ElementType::kStructure)) {
    d.cartesian_bounds = CartesianBounds{get_number(*b, "xMinimum"), get_number(*b, "xMaximum"),
                                         get_number(*b, "yMinimum"), get_number(*b, "yMaximum"),
                                         get_number(*b, "zMinimum"), get_number(*b, "zMaximum")};
  }
  if (const Element* b = child_of(scan, "sphericalBounds", ElementType::kStructure)) {
    d.spherical_bounds =
        SphericalBounds{get_number(*b, "rangeMinimum"),     get_number(*b, "rangeMaximum"),
                        get_number(*b, "elevationMinimum"), get_number(*b, "elevationMaximum"),
                        get_number(*b, "azimuthStart"),     get_number(*b, "azimuthEnd")};
  }
  if (const Element* b = child_of(scan, "indexBounds", ElementType::kStructure)) {
    d.index_bounds =
        IndexBounds{get_integer(*b, "rowMinimum"),    get_integer(*b, "rowMaximum"),
                    get_integer(*b, "columnMinimum"), get_integer(*b, "columnMaximum"),
                    get_integer(*b, "returnMinimum"), get_integer(*b, "returnMaximum")};
  }
  if (const Element* b = child_of(scan, "intensityLimits", ElementType::kStructure)) {
    d.intensity_limits =
        IntensityLimits{get_number(*b, "intensityMinimum"), get_number(*b, "intensityMaximum")};
  }
  if (const Element* b = child_of(scan, "colorLimits", ElementType::kStructure)) {
    d.color_limits =
        ColorLimits{get_number(*b, "colorRedMinimum"),   get_number(*b, "colorRedMaximum"),
                    get_number(*b, "colorGreenMinimum"), get_number(*b, "colorGreenMaximum"),
                    get_number(*b, "colorBlueMinimum"),  get_number(*b, "colorBlueMaximum")};
  }
}

}  // namespace

const char* to_string(ImageRepresentation r) {
  switch (r) {
    case ImageRepresentation::kVisualReference:
      return "visualReference";
    case ImageRepresentation::kPinhole:
      return "pinhole";
    case ImageRepresentation::kSpherical:
      return "spherical";
    case ImageRepresentation::kCylindrical:
      return "cylindrical";
  }
  return "?";
}

FileInfo file_info_from_element(const Element& root) {
  FileInfo info;
  info.version_major = static_cast<std::uint32_t>(get_integer(root, "versionMajor"));
  info.version_minor = static_cast<std::uint32_t>(get_integer(root, "versionMinor"));
  info.guid = get_string(root, "guid");
  info.library_version = get_string(root, "e57LibraryVersion");
  info.coordinate_metadata = get_string(root, "coordinateMetadata");
  info.creation_time = get_datetime(root, "creationDateTime");
  return info;
}

Data3D data3d_from_element(const Element& scan) {
  if (scan.type != ElementType::kStructure) {
    throw Error("data3D entry is not a Structure", {.element = scan.path});
  }
  Data3D d;
  d.element_path = scan.path;
  d.guid = get_string(scan, "guid");
  d.name = get_string(scan, "name");
  d.description = get_string(scan, "description");
  d.sensor_vendor = get_string(scan, "sensorVendor");
  d.sensor_model = get_string(scan, "sensorModel");
  d.sensor_serial_number = get_string(scan, "sensorSerialNumber");
  d.sensor_hardware_version = get_string(scan, "sensorHardwareVersion");
  d.sensor_software_version = get_string(scan, "sensorSoftwareVersion");
  d.sensor_firmware_version = get_string(scan, "sensorFirmwareVersion");
  d.temperature = get_optional_number(scan, "temperature");
  d.relative_humidity = get_optional_number(scan, "relativeHumidity");
  d.atmospheric_pressure = get_optional_number(scan, "atmosphericPressure");
  d.acquisition_start = get_datetime(scan, "acquisitionStart");
  d.acquisition_end = get_datetime(scan, "acquisitionEnd");
  d.pose = get_pose(scan, "pose");
  read_bounds(scan, d);
  if (const Element* g = child_of(scan, "originalGuids", ElementType::kVector)) {
    for (const Element& c : g->children) {
      if (c.type == ElementType::kString) d.original_guids.push_back(c.string_value);
    }
  }
  if (const Element* s = scan.find_path("pointGroupingSchemes/groupingByLine")) {
    GroupingByLine g;
    g.id_element_name = get_string(*s, "idElementName");
    if (const Element* groups = child_of(*s, "groups", ElementType::kCompressedVector)) {
      g.group_count = groups->record_count;
    }
    d.grouping_by_line = g;
  }
  const Element* points = child_of(scan, "points", ElementType::kCompressedVector);
  if (points == nullptr) throw Error("data3D entry has no 'points'", {.element = scan.path});
  d.point_count = points->record_count;
  const Element* proto = points->find("prototype");
  for (const Element& f : proto->children) {
    PrototypeField pf;
    pf.name = f.name;
    pf.field = field_from_name(f.name);
    pf.spec.kind = f.type == ElementType::kInteger         ? FieldKind::kInteger
                   : f.type == ElementType::kScaledInteger ? FieldKind::kScaledInteger
                                                           : FieldKind::kFloat;
    pf.spec.minimum = f.int_minimum;
    pf.spec.maximum = f.int_maximum;
    pf.spec.scale = f.scale;
    pf.spec.offset = f.offset;
    pf.spec.single_precision = f.single_precision;
    if (pf.field) {
      pf.spec.field = *pf.field;
      d.field_mask |= field_bit(*pf.field);
    }
    d.prototype.push_back(std::move(pf));
  }
  return d;
}

namespace {

// What a camera can have: an image of at least one pixel (and not more than a million on a
// side), pixel sizes and focal length that are not negative or non-finite.
void check_image_geometry(const Image2D& im, const Element& rep) {
  const auto fail = [&rep](const char* field, const std::string& what) {
    throw Error(what, {.element = rep.path + "/" + field});
  };
  constexpr std::int64_t kMaxSide = 1000000;
  if (im.width < 1 || im.width > kMaxSide)
    fail("imageWidth", "image width " + std::to_string(im.width) + " is not in 1..1000000");
  if (im.height < 1 || im.height > kMaxSide)
    fail("imageHeight", "image height " + std::to_string(im.height) + " is not in 1..1000000");
  // 0 = absent (files in the wild leave pixel sizes out); negative or non-finite is damage.
  if (!(std::isfinite(im.pixel_width) && im.pixel_width >= 0.0))
    fail("pixelWidth", "pixel width must be a positive number");
  if (!(std::isfinite(im.pixel_height) && im.pixel_height >= 0.0))
    fail("pixelHeight", "pixel height must be a positive number");
  if (!(std::isfinite(im.focal_length) && im.focal_length >= 0.0))
    fail("focalLength", "focal length must be a positive number");
}

}  // namespace

Image2D image2d_from_element(const Element& image) {
  if (image.type != ElementType::kStructure) {
    throw Error("images2D entry is not a Structure", {.element = image.path});
  }
  Image2D im;
  im.element_path = image.path;
  im.guid = get_string(image, "guid");
  im.name = get_string(image, "name");
  im.description = get_string(image, "description");
  im.sensor_vendor = get_string(image, "sensorVendor");
  im.sensor_model = get_string(image, "sensorModel");
  im.sensor_serial_number = get_string(image, "sensorSerialNumber");
  im.associated_data3d_guid = get_string(image, "associatedData3DGuid");
  im.acquisition_time = get_datetime(image, "acquisitionDateTime");
  im.pose = get_pose(image, "pose");
  static constexpr std::pair<const char*, ImageRepresentation> kReps[] = {
      {"pinholeRepresentation", ImageRepresentation::kPinhole},
      {"sphericalRepresentation", ImageRepresentation::kSpherical},
      {"cylindricalRepresentation", ImageRepresentation::kCylindrical},
      {"visualReferenceRepresentation", ImageRepresentation::kVisualReference}};
  const Element* rep = nullptr;
  for (const auto& [name, kind] : kReps) {
    rep = child_of(image, name, ElementType::kStructure);
    if (rep != nullptr) {
      im.representation = kind;
      break;
    }
  }
  if (rep == nullptr) {
    throw Error(
        "images2D entry has no pinhole, spherical, cylindrical or visual reference "
        "representation",
        {.element = image.path});
  }
  const Element* blob = child_of(*rep, "jpegImage", ElementType::kBlob);
  im.format = ImageFormat::kJpeg;
  if (blob == nullptr) {
    blob = child_of(*rep, "pngImage", ElementType::kBlob);
    im.format = ImageFormat::kPng;
  }
  if (blob == nullptr) {
    throw Error("image representation has neither jpegImage nor pngImage", {.element = rep->path});
  }
  im.image = {blob->file_offset, blob->length};
  if (const Element* m = child_of(*rep, "imageMask", ElementType::kBlob)) {
    im.mask = BlobRef{m->file_offset, m->length};
  }
  im.width = get_integer(*rep, "imageWidth");
  im.height = get_integer(*rep, "imageHeight");
  im.pixel_width = get_number(*rep, "pixelWidth");
  im.pixel_height = get_number(*rep, "pixelHeight");
  im.focal_length = get_number(*rep, "focalLength");
  im.principal_point_x = get_number(*rep, "principalPointX");
  im.principal_point_y = get_number(*rep, "principalPointY");
  im.radius = get_number(*rep, "radius");
  check_image_geometry(im, *rep);
  return im;
}

Element pose_to_element(const std::string& name, const Pose& pose) {
  Element p = structure(name);
  Element r = structure("rotation");
  add_float(r, "w", pose.rotation.w);
  add_float(r, "x", pose.rotation.x);
  add_float(r, "y", pose.rotation.y);
  add_float(r, "z", pose.rotation.z);
  Element t = structure("translation");
  add_float(t, "x", pose.translation.x);
  add_float(t, "y", pose.translation.y);
  add_float(t, "z", pose.translation.z);
  p.children.push_back(std::move(r));
  p.children.push_back(std::move(t));
  return p;
}

Element datetime_to_element(const std::string& name, const DateTime& t) {
  Element d = structure(name);
  add_float(d, "dateTimeValue", t.gps_seconds);
  d.children.push_back(
      Element::make_integer("isAtomicClockReferenced", t.atomic_clock_referenced ? 1 : 0));
  return d;
}

Element data3d_to_element(const Data3D& s) {
  Element e = structure("vectorChild");
  add_string(e, "guid", s.guid, true);
  add_string(e, "name", s.name);
  add_string(e, "description", s.description);
  add_string(e, "sensorVendor", s.sensor_vendor);
  add_string(e, "sensorModel", s.sensor_model);
  add_string(e, "sensorSerialNumber", s.sensor_serial_number);
  add_string(e, "sensorHardwareVersion", s.sensor_hardware_version);
  add_string(e, "sensorSoftwareVersion", s.sensor_software_version);
  add_string(e, "sensorFirmwareVersion", s.sensor_firmware_version);
  if (s.temperature) add_float(e, "temperature", *s.temperature);
  if (s.relative_humidity) add_float(e, "relativeHumidity", *s.relative_humidity);
  if (s.atmospheric_pressure) add_float(e, "atmosphericPressure", *s.atmospheric_pressure);
  if (s.acquisition_start)
    e.children.push_back(datetime_to_element("acquisitionStart", *s.acquisition_start));
  if (s.acquisition_end)
    e.children.push_back(datetime_to_element("acquisitionEnd", *s.acquisition_end));
  if (s.pose) e.children.push_back(pose_to_element("pose", *s.pose));
  if (const auto& b = s.cartesian_bounds) {
    Element c = structure("cartesianBounds");
    add_float(c, "xMinimum", b->x_min);
    add_float(c, "xMaximum", b->x_max);
    add_float(c, "yMinimum", b->y_min);
    add_float(c, "yMaximum", b->y_max);
    add_float(c, "zMinimum", b->z_min);
    add_float(c, "zMaximum", b->z_max);
    e.children.push_back(std::move(c));
  }
  if (const auto& b = s.spherical_bounds) {
    Element c = structure("sphericalBounds");
    add_float(c, "rangeMinimum", b->range_min);
    add_float(c, "rangeMaximum", b->range_max);
    add_float(c, "elevationMinimum", b->elevation_min);
    add_float(c, "elevationMaximum", b->elevation_max);
    add_float(c, "azimuthStart", b->azimuth_start);
    add_float(c, "azimuthEnd", b->azimuth_end);
    e.children.push_back(std::move(c));
  }
  if (const auto& b = s.index_bounds) {
    Element c = structure("indexBounds");
    c.children.push_back(Element::make_integer("rowMinimum", b->row_min));
    c.children.push_back(Element::make_integer("rowMaximum", b->row_max));
    c.children.push_back(Element::make_integer("columnMinimum", b->column_min));
    c.children.push_back(Element::make_integer("columnMaximum", b->column_max));
    c.children.push_back(Element::make_integer("returnMinimum", b->return_min));
    c.children.push_back(Element::make_integer("returnMaximum", b->return_max));
    e.children.push_back(std::move(c));
  }
  if (const auto& b = s.intensity_limits) {
    Element c = structure("intensityLimits");
    add_float(c, "intensityMinimum", b->minimum);
    add_float(c, "intensityMaximum", b->maximum);
    e.children.push_back(std::move(c));
  }
  if (const auto& b = s.color_limits) {
    Element c = structure("colorLimits");
    add_float(c, "colorRedMinimum", b->red_min);
    add_float(c, "colorRedMaximum", b->red_max);
    add_float(c, "colorGreenMinimum", b->green_min);
    add_float(c, "colorGreenMaximum", b->green_max);
    add_float(c, "colorBlueMinimum", b->blue_min);
    add_float(c, "colorBlueMaximum", b->blue_max);
    e.children.push_back(std::move(c));
  }
  if (!s.original_guids.empty()) {
    Element v;
    v.name = "originalGuids";
    v.type = ElementType::kVector;
    for (const std::string& g : s.original_guids)
      v.children.push_back(Element::make_string("vectorChild", g));
    e.children.push_back(std::move(v));
  }
  return e;
}

Element image2d_to_element(const Image2D& im) {
  Element e = structure("vectorChild");
  add_string(e, "guid", im.guid, true);
  add_string(e, "name", im.name);
  add_string(e, "description", im.description);
  add_string(e, "sensorVendor", im.sensor_vendor);
  add_string(e, "sensorModel", im.sensor_model);
  add_string(e, "sensorSerialNumber", im.sensor_serial_number);
  add_string(e, "associatedData3DGuid", im.associated_data3d_guid);
  if (im.acquisition_time)
    e.children.push_back(datetime_to_element("acquisitionDateTime", *im.acquisition_time));
  if (im.pose) e.children.push_back(pose_to_element("pose", *im.pose));
  return e;
}

}  // namespace coloc::e57
