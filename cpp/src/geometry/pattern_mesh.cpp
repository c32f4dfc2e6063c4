// A CGAL translation unit of yore_geometry: flat patterns meshed by the 2-D constrained
// Delaunay mesher.
#include "yore/geometry/pattern_mesh.hpp"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"

namespace yore {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_2;
using Segment = Kernel::Segment_2;
using Polygon = CGAL::Polygon_2<Kernel>;
using VertexBase = CGAL::Delaunay_mesh_vertex_base_2<Kernel>;
using FaceBase = CGAL::Delaunay_mesh_face_base_2<Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds>;
using Criteria = CGAL::Delaunay_mesh_size_criteria_2<Cdt>;
using Mesher = CGAL::Delaunay_mesher_2<Cdt, Criteria>;

constexpr double kPi = 3.14159265358979323846;

/// Bad input naming the argument at fault: "outline", "holes", "edge_length" or "min_angle"
/// (a mesh too fine for max_vertices is edge_length's).
[[noreturn]] void fail(const std::string& message, const std::string& argument) {
  throw InvalidArgument("pattern: " + message, argument);
}

std::string polygon_argument(const std::string& name) {
  return name.rfind("hole", 0) == 0 ? "holes" : "outline";
}

// The polygon of `points` (a closing repeat of the first point dropped), checked: at least 3
// points, finite, simple, non-zero area; `name` says which polygon in messages.
Polygon checked_polygon(const Polygon2& points, const std::string& name) {
  Eigen::Index count = points.rows();
  if (count >= 2 && points.row(0) == points.row(count - 1)) --count;  // closed by repetition
  if (count < 3) {
    std::ostringstream msg;
    msg << name << " has " << count << " distinct points; a polygon needs at least 3";
    fail(msg.str(), polygon_argument(name));
  }
  Polygon polygon;
  for (Eigen::Index i = 0; i < count; ++i) {
    if (!std::isfinite(points(i, 0)) || !std::isfinite(points(i, 1))) {
      std::ostringstream msg;
      msg << name << " point " << i << " is not finite";
      fail(msg.str(), polygon_argument(name));
    }
    if (std::abs(points(i, 0)) > kPatternMaxCoordinate ||
        std::abs(points(i, 1)) > kPatternMaxCoordinate) {
      std::ostringstream msg;
      msg << name << " point " << i << " (" << points(i, 0) << ", " << points(i, 1)
          << ") is beyond +-" << kPatternMaxCoordinate << " m";
      fail(msg.str(), polygon_argument(name));
    }
    polygon.push_back(Point(points(i, 0), points(i, 1)));
  }
  if (!polygon.is_simple()) {
    fail(name + " intersects itself (or repeats a point): it must be a simple polygon",
         polygon_argument(name));
  }
  if (!(std::abs(polygon.area()) > 0.0)) fail(name + " has zero area", polygon_argument(name));
  return polygon;
}

bool edges_meet(const Polygon& a, const Polygon& b) {
  for (auto e = a.edges_begin(); e != a.edges_end(); ++e) {
    for (auto f = b.edges_begin(); f != b.edges_end(); ++f) {
      if (CGAL::do_intersect(*e, *f)) return true;
    }
  }
  return false;
}

// Throws naming the first point closer than `least` to an edge (of any of the polygons) that it
// is not an end of; `names` are the polygons' names in messages.
void check_thin_features(const std::vector<const Polygon*>& polygons,
                         const std::vector<std::string>& names, double least) {
  const double least_squared = least * least;
  for (std::size_t a = 0; a < polygons.size(); ++a) {
    const Polygon& points = *polygons[a];
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Point& p = points.vertex(static_cast<std::ptrdiff_t>(i));
      for (std::size_t b = 0; b < polygons.size(); ++b) {
        const Polygon& edges = *polygons[b];
        const std::size_t n = edges.size();
        for (std::size_t j = 0; j < n; ++j) {
          if (a == b && (j == i || (j + 1) % n == i)) continue;  // an edge p is an end of
          const Segment edge = edges.edge(static_cast<std::ptrdiff_t>(j));
          if (CGAL::to_double(CGAL::squared_distance(p, edge)) >= least_squared) continue;
          std::ostringstream msg;
          msg << names[a] << " point " << i << " is "
              << std::sqrt(CGAL::to_double(CGAL::squared_distance(p, edge))) << " m from edge " << j
              << " of " << names[b] << ": thinner than " << kPatternFeatureFraction
              << " of the outline's size (" << least << " m), which the mesher cannot resolve; "
              << "widen the feature or leave it out";
          fail(msg.str(), polygon_argument(names[a]));
        }
      }
    }
  }
}

// A point strictly inside a simple polygon: the centroid of a face of its own constrained
// triangulation that lies inside it (any polygon has one).
Point interior_point(const Polygon& polygon) {
  Cdt local;
  local.insert_constraint(polygon.vertices_begin(), polygon.vertices_end(), true);
  for (auto face = local.finite_faces_begin(); face != local.finite_faces_end(); ++face) {
    const Point c = CGAL::centroid(face->vertex(0)->point(), face->vertex(1)->point(),
                                   face->vertex(2)->point());
    if (polygon.bounded_side(c) == CGAL::ON_BOUNDED_SIDE) return c;
  }
  fail("could not find a point inside a hole", "holes");  // unreachable for a simple polygon
}

}  // namespace

namespace {

void check_pattern_options(const PatternMeshOptions& options) {
  if (!std::isfinite(options.edge_length) || !(options.edge_length > 0.0)) {
    std::ostringstream msg;
    msg << "edge_length must be finite and > 0 (m), got " << options.edge_length;
    fail(msg.str(), "edge_length");
  }
  if (!std::isfinite(options.min_angle_degrees) || !(options.min_angle_degrees > 0.0) ||
      options.min_angle_degrees > kPatternMaxAngleDegrees) {
    std::ostringstream msg;
    msg << "min_angle must be in (0, " << kPatternMaxAngleDegrees << "] degrees, got "
        << options.min_angle_degrees;
    fail(msg.str(), "min_angle");
  }
  if (options.max_vertices < 3) fail("max_vertices must be at least 3", "edge_length");
}

// The holes as polygons, each checked (checked_polygon) and strictly inside the outline and
// apart from the others; throws naming the first that is not.
std::vector<Polygon> checked_holes(const Polygon& outer, const std::vector<Polygon2>& holes) {
  std::vector<Polygon> inner;
  for (std::size_t h = 0; h < holes.size(); ++h) {
    const std::string name = "hole " + std::to_string(h);
    inner.push_back(checked_polygon(holes[h], name));
    const Polygon& hole = inner.back();
    for (auto v = hole.vertices_begin(); v != hole.vertices_end(); ++v) {
      if (outer.bounded_side(*v) != CGAL::ON_BOUNDED_SIDE) {
        fail(name + " is not inside the outline", "holes");
      }
    }
    if (edges_meet(hole, outer)) fail(name + " crosses the outline", "holes");
    for (std::size_t g = 0; g < h; ++g) {
      const Polygon& other = inner[g];
      if (edges_meet(hole, other) ||
          other.bounded_side(*hole.vertices_begin()) != CGAL::ON_UNBOUNDED_SIDE ||
          hole.bounded_side(*other.vertices_begin()) != CGAL::ON_UNBOUNDED_SIDE) {
        std::ostringstream msg;
        msg << name << " overlaps hole " << g << ": holes must lie apart";
        fail(msg.str(), "holes");
      }
    }
  }
  return inner;
}

void check_point_count(const Polygon2& outline, const std::vector<Polygon2>& holes) {
  std::int64_t total = outline.rows();
  for (const Polygon2& hole : holes) total += hole.rows();
  if (total > kPatternMaxPoints) {
    std::ostringstream msg;
    msg << "the outline and holes have " << total << " points; at most " << kPatternMaxPoints
        << " are meshed";
    fail(msg.str(), holes.empty() ? "outline" : "holes");
  }
}

// check_thin_features over the outline and the holes, at kPatternFeatureFraction of the
// outline's bounding-box diagonal.
void check_thin_features(const Polygon& outer, const std::vector<Polygon>& inner) {
  const CGAL::Bbox_2 box = outer.bbox();
  const double size = std::hypot(box.xmax() - box.xmin(), box.ymax() - box.ymin());
  std::vector<const Polygon*> all{&outer};
  std::vector<std::string> names{"the outline"};
  for (std::size_t h = 0; h < inner.size(); ++h) {
    all.push_back(&inner[h]);
    names.push_back("hole " + std::to_string(h));
  }
  check_thin_features(all, names, kPatternFeatureFraction * size);
}

// Refines one point at a time, so that a refinement too fine for max_vertices stops with an
// error (and Ctrl-C is answered) instead of running on.
void refine(Mesher& mesher, const Cdt& cdt, const PatternMeshOptions& options) {
  // Every refinement step inserts a point; a run of steps that adds none is a mesher going in
  // circles on an input it cannot resolve, stopped rather than left to spin.
  std::int64_t steps = 0, idle = 0;
  std::size_t last_count = cdt.number_of_vertices();
  while (!mesher.is_refinement_done()) {
    mesher.try_one_step_refine_mesh();
    const std::size_t count = cdt.number_of_vertices();
    if (static_cast<std::int64_t>(count) > options.max_vertices) {
      std::ostringstream msg;
      msg << "meshing at edge_length " << options.edge_length << " m needs more than "
          << options.max_vertices << " vertices; use a larger edge_length";
      fail(msg.str(), "edge_length");
    }
    idle = count == last_count ? idle + 1 : 0;
    last_count = count;
    if (idle > 10'000) {
      fail(
          "the mesher stopped adding points on this outline (an angle or a feature too small "
          "for it to resolve): smooth the outline or lower min_angle",
          "outline");
    }
    if (++steps % 64 == 0) poll_interrupt();
  }
}

}  // namespace

PatternMesh pattern_mesh(const Polygon2& outline, const std::vector<Polygon2>& holes,
                         const PatternMeshOptions& options) {
  check_pattern_options(options);

  check_point_count(outline, holes);
  const Polygon outer = checked_polygon(outline, "the outline");
  const std::vector<Polygon> inner = checked_holes(outer, holes);
  check_thin_features(outer, inner);

  Cdt cdt;
  cdt.insert_constraint(outer.vertices_begin(), outer.vertices_end(), true);
  std::vector<Point> seeds;  // one inside each hole: its region stays unmeshed
  for (const Polygon& hole : inner) {
    cdt.insert_constraint(hole.vertices_begin(), hole.vertices_end(), true);
    seeds.push_back(interior_point(hole));
  }
  const double sine = std::sin(options.min_angle_degrees * kPi / 180.0);
  Mesher mesher(cdt);
  mesher.set_criteria(Criteria(sine * sine, options.edge_length));
  mesher.set_seeds(seeds.begin(), seeds.end(), false);
  mesher.init();
  refine(mesher, cdt, options);

  PatternMesh mesh;
  std::unordered_map<const void*, std::int32_t> index;
  std::vector<Point> points;
  std::vector<std::array<std::int32_t, 3>> faces;
  for (auto face = cdt.finite_faces_begin(); face != cdt.finite_faces_end(); ++face) {
    if (!face->is_in_domain()) continue;
    std::array<std::int32_t, 3> corners{};
    for (int k = 0; k < 3; ++k) {
      const auto vertex = face->vertex(k);
      const auto [slot, added] = index.emplace(&*vertex, static_cast<std::int32_t>(points.size()));
      if (added) points.push_back(vertex->point());
      corners[static_cast<std::size_t>(k)] = slot->second;
    }
    faces.push_back(corners);
  }
  mesh.points.resize(static_cast<Eigen::Index>(points.size()), 2);
  for (std::size_t i = 0; i < points.size(); ++i) {
    mesh.points(static_cast<Eigen::Index>(i), 0) = points[i].x();
    mesh.points(static_cast<Eigen::Index>(i), 1) = points[i].y();
  }
  mesh.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      mesh.faces(static_cast<Eigen::Index>(f), k) = faces[f][static_cast<std::size_t>(k)];
    }
  }
  std::vector<char> on_outline(points.size(), 0);
  for (auto edge = cdt.finite_edges_begin(); edge != cdt.finite_edges_end(); ++edge) {
    if (!cdt.is_constrained(*edge)) continue;
    for (const int k : {Cdt::cw(edge->second), Cdt::ccw(edge->second)}) {
      const auto found = index.find(&*edge->first->vertex(k));
      if (found != index.end()) on_outline[static_cast<std::size_t>(found->second)] = 1;
    }
  }
  for (const char flag : on_outline) mesh.outline_vertices += flag;
  return mesh;
}

}  // namespace yore
