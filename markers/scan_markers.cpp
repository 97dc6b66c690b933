#include "markers/scan_markers.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "e57io/error.hpp"
#include "e57io/reader.hpp"
#include "markers/panorama.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"

namespace coloc::markers {
namespace {

SE3 to_se3(const e57::Pose& pose) {
  Eigen::Quaterniond q(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z);
  q.normalize();
  return SE3(q, Eigen::Vector3d(pose.translation.x, pose.translation.y, pose.translation.z));
}

std::array<Eigen::Vector3d, 4> global_corners(const SE3& global_from_marker, double size) {
  std::array<Eigen::Vector3d, 4> out;
  const auto local = marker_corners(size);
  for (int c = 0; c < 4; ++c)
    out[c] = global_from_marker * local[c];
  return out;
}

std::string file_safe(std::string s) {
  for (char& c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '+' && c != '_') c = '_';
  }
  return s;
}

void write_debug(const ScanMarkerOptions& options, const cv::Mat& image,
                 const ImageSightings& found, const std::string& name, int index) {
  if (options.debug_dir.empty()) return;
  std::vector<MarkerObservation> accepted, rejected;
  for (const MarkerObservation& o : found.observations) {
    const bool ok = std::any_of(found.sightings.begin(), found.sightings.end(),
                                [&](const Sighting& s) { return s.id == o.id; });
    (ok ? accepted : rejected).push_back(o);
  }
  cv::Mat out = draw_observations(image, accepted);
  const cv::Mat red =
      draw_observations(cv::Mat(image.size(), CV_8UC3, cv::Scalar::all(0)), rejected);
  // Rejected detections: recolour the drawn outlines red.
  std::vector<cv::Mat> channels;
  cv::split(red, channels);
  const cv::Mat mask = channels[1] > 0;
  out.setTo(cv::Scalar(0, 0, 255), mask);
  char prefix[16];
  std::snprintf(prefix, sizeof(prefix), "%03d_", index);
  const auto path = options.debug_dir / (prefix + file_safe(name) + ".jpg");
  std::vector<std::uint8_t> jpeg;
  if (!cv::imencode(".jpg", out, jpeg))
    throw Error("cannot encode debug image", {.file = path.string()});
  write_file_atomically(
      path, std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()), false);
}

struct ImageJob {
  std::size_t index = 0;
  std::string name;
  SE3 global_from_image;
  std::optional<Camera> pinhole;
  std::optional<PanoramaModel> panorama;
};

// Decides what to do with each image; images without pose or geometry are reported as skipped.
std::vector<ImageJob> plan_images(const e57::Reader& reader, ScanMarkersResult& result) {
  std::vector<ImageJob> jobs;
  for (std::size_t i = 0; i < reader.images().size(); ++i) {
    const e57::Image2D& im = reader.images()[i];
    ImageJob job;
    job.index = i;
    job.name = im.name.empty() ? "images2D/" + std::to_string(i) : im.name;
    const auto skip = [&](const std::string& why) {
      result.skipped.push_back(job.name + ": " + why);
    };
    if (!im.pose) {
      skip("no pose");
      continue;
    }
    job.global_from_image = to_se3(*im.pose);
    if (im.width <= 0 || im.height <= 0) {
      skip("no image size");
      continue;
    }
    if (im.representation == e57::ImageRepresentation::kPinhole) {
      if (!(im.focal_length > 0.0 && im.pixel_width > 0.0 && im.pixel_height > 0.0)) {
        skip("pinhole without focal length or pixel size");
        continue;
      }
      PinholeCamera c;
      c.width = static_cast<int>(im.width);
      c.height = static_cast<int>(im.height);
      c.fx = im.focal_length / im.pixel_width;
      c.fy = im.focal_length / im.pixel_height;
      c.cx = im.principal_point_x;
      c.cy = im.principal_point_y;
      job.pinhole = c;
    } else if (im.representation == e57::ImageRepresentation::kSpherical ||
               im.representation == e57::ImageRepresentation::kCylindrical) {
      PanoramaModel m;
      m.kind = im.representation == e57::ImageRepresentation::kSpherical
                   ? PanoramaKind::kSpherical
                   : PanoramaKind::kCylindrical;
      m.width = static_cast<int>(im.width);
      m.height = static_cast<int>(im.height);
      m.pixel_width = im.pixel_width;
      m.pixel_height = im.pixel_height;
      m.radius = im.radius;
      m.principal_point_y = im.principal_point_y;
      try {
        m.check();
      } catch (const Error& e) {
        skip(std::string("panorama: ") + e.what());
        continue;
      }
      job.panorama = m;
    } else {
      skip("visual reference image (no projection model)");
      continue;
    }
    jobs.push_back(job);
  }
  return jobs;
}

}  // namespace

const char* to_string(Rejection r) {
  switch (r) {
    case Rejection::kNoPose:
      return "no pose";
    case Rejection::kReprojection:
      return "reprojection error";
    case Rejection::kDistance:
      return "too far";
    case Rejection::kDuplicateId:
      return "duplicate id in image";
  }
  return "?";
}

void ScanMarkerOptions::check() const {
  detector.check();
  pose.check();
  fusion.check();
  if (!(max_reprojection_error_px > 0.0)) {
    throw Error("must be positive (pixels)", {.field = "max_reprojection_error_px"});
  }
  if (!(max_distance > 0.0)) throw Error("must be positive (metres)", {.field = "max_distance"});
  if (cube_face_size < 64 || cube_face_size > 16384) {
    throw Error("must be in [64, 16384] pixels", {.field = "cube_face_size"});
  }
}

ImageSightings sightings_in_image(const cv::Mat& image, const Camera& camera,
                                  const SE3& global_from_image, const std::string& name,
                                  const MarkerDetector& detector,
                                  const ScanMarkerOptions& options) {
  ImageSightings out;
  out.observations = detector.detect(image);
  std::map<int, int> count;
  for (const MarkerObservation& o : out.observations)
    ++count[o.id];
  for (const MarkerObservation& o : out.observations) {
    RejectedDetection rejected{.id = o.id, .image = name};
    if (count[o.id] > 1) {
      rejected.reason = Rejection::kDuplicateId;
      out.rejected.push_back(rejected);
      continue;
    }
    const auto pose = estimate_marker_pose(camera, o, options.pose);
    if (!pose) {
      rejected.reason = Rejection::kNoPose;
      out.rejected.push_back(rejected);
      continue;
    }
    rejected.reprojection_error_px = pose->reprojection_error_px();
    rejected.distance = pose->distance();
    if (pose->reprojection_error_px() > options.max_reprojection_error_px) {
      rejected.reason = Rejection::kReprojection;
      out.rejected.push_back(rejected);
      continue;
    }
    if (pose->distance() > options.max_distance) {
      rejected.reason = Rejection::kDistance;
      out.rejected.push_back(rejected);
      continue;
    }
    // The paper's global corners: global_from_image * image_from_marker * corner.
    Sighting s;
    s.id = o.id;
    s.image = name;
    s.corners =
        global_corners(global_from_image * pose->best.camera_from_marker, options.pose.marker_size);
    s.alternative = global_corners(global_from_image * pose->alternative.camera_from_marker,
                                   options.pose.marker_size);
    s.ambiguous = pose->ambiguous;
    s.reprojection_error_px = pose->reprojection_error_px();
    s.distance = pose->distance();
    s.edge_length = options.pose.marker_size;
    out.sightings.push_back(s);
  }
  return out;
}

ScanMarkersResult scan_markers(const std::filesystem::path& e57_path,
                               const ScanMarkerOptions& options) {
  options.check();
  if (!options.debug_dir.empty()) std::filesystem::create_directories(options.debug_dir);
  const MarkerDetector detector(options.detector);
  ScanMarkersResult result;
  result.map.dictionary = options.detector.dictionary;
  result.map.source = e57_path.string();
  try {
    const e57::Reader reader(e57_path);
    const std::vector<ImageJob> jobs = plan_images(reader, result);
    for (const std::string& s : result.skipped)
      spdlog::info("scan-markers: skipped {}", s);
    if (jobs.empty()) {
      throw Error("no image with a pose and a pinhole, spherical or cylindrical representation (" +
                      std::to_string(reader.images().size()) +
                      " images2D entries): cannot place markers in the scan's frame",
                  {.file = e57_path.string(), .field = "images2D"});
    }
    int total = 0;
    for (const ImageJob& job : jobs)
      total += job.pinhole ? 1 : kCubeFaces;
    Progress progress("scan-markers", static_cast<std::uint64_t>(total), options.quiet);
    const auto run = [&](const cv::Mat& image, const Camera& camera, const SE3& global_from_image,
                         const std::string& name) {
      ImageSightings found =
          sightings_in_image(image, camera, global_from_image, name, detector, options);
      write_debug(options, image, found, name, result.faces_searched);
      result.map.images.push_back(name);
      ++result.faces_searched;
      result.sightings.insert(result.sightings.end(), found.sightings.begin(),
                              found.sightings.end());
      result.rejected.insert(result.rejected.end(), found.rejected.begin(), found.rejected.end());
      progress.advance();
    };
    for (const ImageJob& job : jobs) {
      const std::vector<std::uint8_t> bytes = reader.read_image(job.index);
      const cv::Mat image = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
      const std::string size = std::to_string(image.cols) + "x" + std::to_string(image.rows);
      const int want_w = job.pinhole ? image_width(*job.pinhole) : job.panorama->width;
      const int want_h = job.pinhole ? image_height(*job.pinhole) : job.panorama->height;
      if (image.empty() || image.cols != want_w || image.rows != want_h) {
        result.skipped.push_back(job.name + ": image " + (image.empty() ? "not decodable" : size) +
                                 " does not match its header");
        progress.advance(job.pinhole ? 1 : kCubeFaces);
        continue;
      }
      ++result.images_searched;
      if (job.pinhole) {
        run(image, *job.pinhole, job.global_from_image, job.name);
        continue;
      }
      const auto rotations = cube_face_rotations();
      const Camera face_camera = cube_face_camera(options.cube_face_size);
      for (int f = 0; f < kCubeFaces; ++f) {
        const cv::Mat face = resample_cube_face(image, *job.panorama, f, options.cube_face_size);
        const SE3 image_from_face(rotations[f], Eigen::Vector3d::Zero());
        run(face, face_camera, job.global_from_image * image_from_face,
            job.name + " face " + cube_face_name(f));
      }
    }
    progress.finish();
  } catch (const e57::Error& e) {
    throw Error(std::string("cannot read the scan: ") + e.what(), {.file = e57_path.string()});
  }
  result.map.markers = fuse_all(result.sightings, options.fusion);
  return result;
}

}  // namespace coloc::markers
