#include "projtour/tour/run_checks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "projtour/head/kinematics.hpp"
#include "projtour/navigation/occupancy_map.hpp"
#include "projtour/perception/model.hpp"

namespace projtour {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

std::string metres(double value_m) {
  std::ostringstream s;
  s.precision(3);
  s << value_m << " m";
  return s.str();
}

std::string point_text(const Vector3d& p) {
  std::ostringstream s;
  s.precision(4);
  s << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return s.str();
}

// Diagnostics about one target, each at one of its fields.
class TargetProblems {
 public:
  TargetProblems(const host::LoadedMission& mission, std::size_t index, host::Diagnostics& diag)
      : mission_(mission), prefix_("targets[" + std::to_string(index) + "]"), diag_(diag) {}

  // At `field` when it was written, else at `fallback` (a default value has no line of its own).
  void error(const std::string& field, const std::string& message,
             const std::string& fallback = "") const {
    const std::string path = prefix_ + "." + field;
    const bool written = mission_.marks.count(path) != 0 || fallback.empty();
    diag_.error(mission_.mark_of(written ? path : prefix_ + "." + fallback), path, message);
  }

 private:
  const host::LoadedMission& mission_;
  std::string prefix_;
  host::Diagnostics& diag_;
};

// The mesh, or the first reason a run could not use it.
std::string mesh_problem(const perception::TriangleMesh& mesh) {
  if (mesh.vertices.size() > kMaxModelVertices) {
    return "holds " + std::to_string(mesh.vertices.size()) + " vertices; expected at most " +
           std::to_string(kMaxModelVertices);
  }
  if (mesh.triangles.size() > kMaxModelTriangles) {
    return "holds " + std::to_string(mesh.triangles.size()) + " triangles; expected at most " +
           std::to_string(kMaxModelTriangles);
  }
  double reach_m = 0.0;
  std::size_t farthest = 0;
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f& v = mesh.vertices[i];
    if (!v.allFinite()) {
      return "vertex " + std::to_string(i) + " is not finite " + point_text(v.cast<double>()) +
             "; expected finite coordinates in metres";
    }
    if (v.cast<double>().norm() > reach_m) {
      reach_m = v.cast<double>().norm();
      farthest = i;
    }
  }
  if (reach_m > kMaxModelReachM) {
    return "vertex " + std::to_string(farthest) + " lies " + metres(reach_m) +
           " from the model's origin; expected a model in metres within " +
           metres(kMaxModelReachM) + " of its origin";
  }
  return "";
}

// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Vector3d closest_on_triangle(const Vector3d& p, const Vector3d& a, const Vector3d& b,
                             const Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  }
  const double denom = va + vb + vc;
  // A degenerate (zero-area) triangle: its corners stand for it.
  if (!(denom > 0)) return (p - a).norm() < (p - b).norm() ? a : b;
  return a + ab * (vb / denom) + ac * (vc / denom);
}

double distance_to_surface(const perception::TriangleMesh& mesh, const Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Vector3d q =
        closest_on_triangle(p, mesh.vertices[t[0]].cast<double>(),
                            mesh.vertices[t[1]].cast<double>(), mesh.vertices[t[2]].cast<double>());
    best = std::min(best, (q - p).norm());
  }
  return best;
}

// > 0 when c lies left of a -> b.
double orientation(const Vector2d& a, const Vector2d& b, const Vector2d& c) {
  const Vector2d u = b - a, v = c - a;
  return u.x() * v.y() - u.y() * v.x();
}

bool segments_cross(const Vector2d& a, const Vector2d& b, const Vector2d& c, const Vector2d& d) {
  // The loader refused three points on one line, so touching without crossing does not occur.
  return orientation(a, b, c) * orientation(a, b, d) < 0 &&
         orientation(c, d, a) * orientation(c, d, b) < 0;
}

void check_model_points_shape(const TargetSpec& target, const TargetProblems& problems) {
  const auto& q = target.model_points;
  // The plane of the first corner's triangle (never degenerate after the loader's check); a
  // quadrilateral a little off plane keeps its order there.
  const Vector3d normal = (q[1] - q[0]).cross(q[3] - q[0]).normalized();
  const Vector3d e1 = (q[1] - q[0]).normalized();
  const Vector3d e2 = normal.cross(e1);
  std::array<Vector2d, 4> p;
  for (std::size_t i = 0; i < 4; ++i) p[i] = Vector2d((q[i] - q[0]).dot(e1), (q[i] - q[0]).dot(e2));
  if (segments_cross(p[0], p[1], p[2], p[3]) || segments_cross(p[1], p[2], p[3], p[0])) {
    problems.error("model_points",
                   "the four points cross over themselves (a bow-tie); expected them in order "
                   "around the area: top-left, top-right, bottom-right, bottom-left");
    return;
  }
  // Half the diagonals' cross product is the area vector, which points away from the side the
  // corners are seen going clockwise from; top-left, top-right, bottom-right, bottom-left go
  // clockwise seen from the front, so the front is against it.
  const Vector3d facing = -(q[2] - q[0]).cross(q[3] - q[1]);
  if (!(facing.x() > 0.0)) {
    problems.error("model_points",
                   "the four points face away from the model's front (+x): seen from the front "
                   "they run counter-clockwise, so the content would show mirrored; expected "
                   "top-left, top-right, bottom-right, bottom-left as seen from +x");
  }
}

void check_model_points_on_surface(const TargetSpec& target, const perception::TriangleMesh& mesh,
                                   const TargetProblems& problems) {
  for (std::size_t i = 0; i < 4; ++i) {
    const double d_m = distance_to_surface(mesh, target.model_points[i]);
    if (d_m > kModelPointSurfaceToleranceM) {
      problems.error("model_points[" + std::to_string(i) + "]",
                     "point " + point_text(target.model_points[i]) + " lies " + metres(d_m) +
                         " from the model's surface; expected within " +
                         metres(kModelPointSurfaceToleranceM) + " of it",
                     "model_points");
    }
  }
}

// How far the model reaches toward its stand-off pose, along the floor, from its origin.
double front_reach_m(const TargetSpec& target, const perception::TriangleMesh* mesh,
                     const Pose2D& standoff) {
  if (mesh == nullptr) return 0.0;
  const Vector2d toward(-std::cos(standoff.yaw_rad), -std::sin(standoff.yaw_rad));
  double reach_m = 0.0;
  for (const Eigen::Vector3f& v : mesh->vertices) {
    const Vector3d p_map_rel = target.T_map_model.linear() * v.cast<double>();
    reach_m = std::max(reach_m, p_map_rel.head<2>().dot(toward));
  }
  return reach_m;
}

void check_standoff_and_aim(const host::LoadedMission& mission, const TargetSpec& target,
                            const perception::TriangleMesh* mesh, const TargetProblems& problems) {
  const Pose2D standoff = navigation::standoff_pose(target);
  const double radius_m = mission.robot.base.radius_m;
  const double least_m = radius_m + front_reach_m(target, mesh, standoff) + kStandoffMarginM;
  if (target.standoff_m < least_m) {
    problems.error("standoff_m",
                   "stand-off " + metres(target.standoff_m) + " puts the robot's base (radius " +
                       metres(radius_m) + ") into the target or within " +
                       metres(kStandoffMarginM) + " of its front; expected at least " +
                       metres(least_m),
                   "pose");
    return;
  }
  // Where aim points the projector by default (the aim behaviour's aim point), seen from the
  // stand-off pose with the robot file's head.
  Vector3d p_model = Vector3d::Zero();
  for (const Vector3d& p : target.model_points) p_model += p / 4.0;
  const Vector3d p_base = isometry_from_pose2d(standoff).inverse() * (target.T_map_model * p_model);
  std::string why;
  if (!head::HeadKinematics(mission.robot).aim_projector_at(p_base, &why)) {
    problems.error("standoff_m",
                   "from the stand-off pose the aim point (the Model Points' centre, " +
                       point_text(p_base) + " m in the base frame) is out of the head's reach: " +
                       why + "; expected a stand-off and pose the pan-tilt limits can aim from",
                   "pose");
  }
}

// Decoded as the project step will: an image whole, a video's first frame.
void check_content(const std::filesystem::path& content, const std::string& field,
                   const TargetProblems& problems) {
  const std::string file = content.string();
  // The loader let an image extension through only with an image signature behind it.
  const bool image = cv::haveImageReader(file);
  cv::Mat first;
  if (image) {
    first = cv::imread(file, cv::IMREAD_COLOR);
  } else {
    cv::VideoCapture video(file);
    if (!video.isOpened() || !video.read(first)) first.release();
  }
  if (first.empty()) {
    problems.error(field, std::string("cannot decode ") + file +
                              (image ? "; expected an image OpenCV can decode"
                                     : "; expected a video whose first frame OpenCV can decode"));
  } else if (first.cols < 2 || first.rows < 2) {
    problems.error(field, file + " is " + std::to_string(first.cols) + "x" +
                              std::to_string(first.rows) +
                              " pixels; expected at least 2x2 (a homography needs an area)");
  }
}

}  // namespace

void check_run_assets(const host::LoadedMission& mission, host::Diagnostics& diag) {
  // Targets often share a model: each file is read once.
  std::map<std::filesystem::path, std::shared_ptr<const perception::TriangleMesh>> meshes;
  for (std::size_t i = 0; i < mission.targets.size(); ++i) {
    const TargetSpec& target = mission.targets[i];
    const TargetProblems problems(mission, i, diag);
    auto [it, fresh] = meshes.emplace(target.model, nullptr);
    if (fresh) {
      try {
        auto mesh = std::make_shared<perception::TriangleMesh>(perception::load_mesh(target.model));
        const std::string problem = mesh_problem(*mesh);
        if (problem.empty()) {
          it->second = std::move(mesh);
        } else {
          problems.error("model", target.model.string() + ": " + problem);
        }
      } catch (const std::exception& e) {
        problems.error("model", std::string(e.what()) + "; expected a triangle mesh (PLY or OFF)");
      }
    }
    const perception::TriangleMesh* mesh = it->second.get();
    check_model_points_shape(target, problems);
    if (mesh != nullptr) check_model_points_on_surface(target, *mesh, problems);
    check_standoff_and_aim(mission, target, mesh, problems);
    // A content list's every item: a run shows each in its turn.
    const std::vector<std::filesystem::path>* list =
        i < mission.target_times.size() ? &mission.target_times[i].content : nullptr;
    if (list != nullptr && list->size() > 1) {
      for (std::size_t k = 0; k < list->size(); ++k) {
        check_content((*list)[k], "content[" + std::to_string(k) + "]", problems);
      }
    } else {
      check_content(target.content, "content", problems);
    }
  }
}

}  // namespace projtour
