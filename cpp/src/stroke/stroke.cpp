// The CGAL translation unit of yore_geometry: AABB trees for stroke location.
#include "yore/stroke/stroke.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "yore/platform/interrupt.hpp"

namespace yore {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

Eigen::Vector3d barycentric_of(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a, d = p - a;
  const double d11 = e1.dot(e1), d12 = e1.dot(e2), d22 = e2.dot(e2);
  const double d1 = d.dot(e1), d2 = d.dot(e2);
  const double denominator = d11 * d22 - d12 * d12;
  double v = (d22 * d1 - d12 * d2) / denominator;
  double w = (d11 * d2 - d12 * d1) / denominator;
  // The point lies on the triangle (it came from a query on it): clamp round-off.
  v = std::clamp(v, 0.0, 1.0);
  w = std::clamp(w, 0.0, 1.0 - v);
  return {1.0 - v - w, v, w};
}

Eigen::Vector3d to_eigen(const Point& p) { return {p.x(), p.y(), p.z()}; }

bool edge_adjacent(const Faces& faces, std::int32_t f, std::int32_t g) {
  int shared = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) shared += faces(f, i) == faces(g, j);
  return shared >= 2;
}

}  // namespace

struct SurfaceLocator::Impl {
  Positions positions;  // copies: the locator does not depend on its inputs' lifetime
  Faces faces;
  std::vector<Triangle> triangles;
  Tree tree;
  Impl(const Positions& p, const Faces& f) : positions(p), faces(f) {}
};

SurfaceLocator::SurfaceLocator(const Positions& positions, const Faces& faces)
    : m_impl(std::make_unique<Impl>(positions, faces)) {
  if (faces.rows() == 0) throw std::invalid_argument("the surface has no faces");
  auto point = [&](std::int32_t v) {
    return Point(positions(v, 0), positions(v, 1), positions(v, 2));
  };
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      if (faces(f, c) < 0 || faces(f, c) >= positions.rows()) {
        throw std::invalid_argument("SurfaceLocator: face index out of range");
      }
    }
  }
  m_impl->triangles.reserve(static_cast<std::size_t>(faces.rows()));
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    m_impl->triangles.emplace_back(point(faces(f, 0)), point(faces(f, 1)), point(faces(f, 2)));
  }
  m_impl->tree.insert(m_impl->triangles.cbegin(), m_impl->triangles.cend());
  m_impl->tree.accelerate_distance_queries();
}

SurfaceLocator::~SurfaceLocator() = default;

SurfaceHit SurfaceLocator::closest(const Eigen::Vector3d& point) const {
  const Point query(point.x(), point.y(), point.z());
  const auto [closest, primitive] = m_impl->tree.closest_point_and_primitive(query);
  SurfaceHit hit;
  hit.face = static_cast<std::int32_t>(primitive - m_impl->triangles.cbegin());
  const Eigen::Vector3d p = to_eigen(closest);
  const Positions& x = m_impl->positions;
  const Faces& f = m_impl->faces;
  hit.barycentric =
      barycentric_of(p, x.row(f(hit.face, 0)), x.row(f(hit.face, 1)), x.row(f(hit.face, 2)));
  hit.distance = (p - point).norm();
  return hit;
}

std::optional<SurfaceHit> SurfaceLocator::first_hit(const Eigen::Vector3d& origin,
                                                    const Eigen::Vector3d& direction) const {
  const Kernel::Ray_3 ray(Point(origin.x(), origin.y(), origin.z()),
                          Kernel::Vector_3(direction.x(), direction.y(), direction.z()));
  const auto primitive = m_impl->tree.first_intersected_primitive(ray);
  if (!primitive) return std::nullopt;
  SurfaceHit hit;
  hit.face = static_cast<std::int32_t>(*primitive - m_impl->triangles.cbegin());
  const Positions& x = m_impl->positions;
  const Faces& f = m_impl->faces;
  const Eigen::Vector3d a = x.row(f(hit.face, 0)), b = x.row(f(hit.face, 1)),
                        c = x.row(f(hit.face, 2));
  // Ray–plane intersection of the face CGAL found first.
  const Eigen::Vector3d normal = (b - a).cross(c - a);
  const double t = normal.dot(a - origin) / normal.dot(direction);
  const Eigen::Vector3d p = origin + t * direction;
  hit.barycentric = barycentric_of(p, a, b, c);
  hit.distance = t * direction.norm();
  return hit;
}

namespace {

// The error of a stroke that needs more than max_samples samples: about `needed` (> 0) at this
// spacing over this length, or (needed 0) reached while refining where it crosses faces.
std::invalid_argument too_many_samples(std::int64_t max_samples, double needed, double spacing,
                                       double length) {
  std::ostringstream msg;
  msg << "the stroke needs more than " << max_samples << " samples (the limit; ";
  if (needed > 0.0) {
    msg << "about " << needed << " at a spacing of " << spacing << " over " << length
        << " of its length near the cloth";
  } else {
    msg << "reached while refining where it crosses faces";
  }
  msg << "); draw a shorter stroke or split it";
  return std::invalid_argument(msg.str());
}

// One evaluation of a stroke's curve: its arc length and what it hit.
struct TraceSample {
  double s;
  std::optional<SurfaceHit> hit;
};

// The arc lengths sampled first: `length` in steps of at most `spacing`, and the breakpoints
// inside it, sorted and unique.
std::vector<double> sample_starts(double length, double spacing,
                                  const std::vector<double>& breakpoints) {
  const auto intervals =
      std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(length / spacing)));
  std::vector<double> starts;
  starts.reserve(static_cast<std::size_t>(intervals) + 1 + breakpoints.size());
  for (std::int64_t k = 0; k <= intervals; ++k) {
    starts.push_back(length * static_cast<double>(k) / static_cast<double>(intervals));
  }
  for (const double s : breakpoints) {
    if (s > 0.0 && s < length) starts.push_back(s);
  }
  std::sort(starts.begin(), starts.end());
  starts.erase(std::unique(starts.begin(), starts.end()), starts.end());
  return starts;
}

// The samples that hit, in stroke order, as the trace's path (a new part after each miss) and
// its crossed faces (each with the mean barycentric coordinates of its samples).
void collect_hits(const std::vector<TraceSample>& samples, StrokeTrace& trace) {
  std::map<std::int32_t, std::size_t> slot_of_face;
  std::int32_t part = 0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const TraceSample& sample = samples[k];
    if (!sample.hit) {
      if (k > 0 && samples[k - 1].hit) ++part;
      continue;
    }
    trace.path.push_back({sample.hit->face, sample.hit->barycentric, part});
    const auto [it, inserted] = slot_of_face.emplace(sample.hit->face, trace.crossings.size());
    if (inserted) trace.crossings.push_back({sample.hit->face, Eigen::Vector3d::Zero(), 0});
    StrokeCrossing& crossing = trace.crossings[it->second];
    crossing.barycentric += sample.hit->barycentric;
    ++crossing.samples;
  }
  for (StrokeCrossing& crossing : trace.crossings) crossing.barycentric /= crossing.samples;
}

}  // namespace

StrokeTrace trace_stroke(const std::function<std::optional<SurfaceHit>(double)>& query,
                         double length, double spacing, double resolution, const Faces& faces,
                         const std::vector<double>& breakpoints, std::int64_t max_samples) {
  if (!(length >= 0.0) || !std::isfinite(length) || !(spacing > 0.0) || !(resolution > 0.0)) {
    throw std::invalid_argument(
        "trace_stroke: length finite and >= 0, spacing > 0 and resolution > 0");
  }
  const double needed = std::ceil(length / spacing) + 1.0 + static_cast<double>(breakpoints.size());
  if (!(needed <= static_cast<double>(max_samples)))
    throw too_many_samples(max_samples, needed, spacing, length);
  using Sample = TraceSample;
  StrokeTrace trace;
  std::vector<Sample> samples;
  auto evaluate = [&](double s) {
    if (trace.samples >= max_samples) throw too_many_samples(max_samples, 0.0, spacing, length);
    if (trace.samples % 64 == 0) poll_interrupt();
    ++trace.samples;
    Sample sample{s, query(s)};
    if (!sample.hit) ++trace.missed_samples;
    return sample;
  };
  // Depth-first bisection keeps the samples in stroke order.
  std::function<void(const Sample&, const Sample&)> refine = [&](const Sample& left,
                                                                 const Sample& right) {
    const bool settled =
        (!left.hit && !right.hit) || (left.hit && right.hit &&
                                      (left.hit->face == right.hit->face ||
                                       edge_adjacent(faces, left.hit->face, right.hit->face)));
    if (settled || right.s - left.s < resolution) return;
    const Sample middle = evaluate(0.5 * (left.s + right.s));
    refine(left, middle);
    samples.push_back(middle);
    refine(middle, right);
  };
  const std::vector<double> starts = sample_starts(length, spacing, breakpoints);
  Sample previous = evaluate(starts.front());
  samples.push_back(previous);
  for (std::size_t k = 1; k < starts.size(); ++k) {
    const Sample next = evaluate(starts[k]);
    refine(previous, next);
    samples.push_back(next);
    previous = next;
  }
  collect_hits(samples, trace);
  return trace;
}

std::vector<Positions> clip_polyline(const Positions& points, const Eigen::Vector3d& lower,
                                     const Eigen::Vector3d& upper) {
  std::vector<Positions> parts;
  std::vector<Eigen::Vector3d> open;  // the part being built; empty when the last one closed
  auto close = [&] {
    if (open.empty()) return;
    Positions part(static_cast<Eigen::Index>(open.size()), 3);
    for (std::size_t k = 0; k < open.size(); ++k) {
      part.row(static_cast<Eigen::Index>(k)) = open[k].transpose();
    }
    parts.push_back(std::move(part));
    open.clear();
  };
  auto inside = [&](const Eigen::Vector3d& p) {
    return (p.array() >= lower.array()).all() && (p.array() <= upper.array()).all();
  };
  if (points.rows() == 1) {
    if (inside(points.row(0).transpose())) parts.push_back(points);
    return parts;
  }
  for (Eigen::Index k = 0; k + 1 < points.rows(); ++k) {
    const Eigen::Vector3d a = points.row(k).transpose(), b = points.row(k + 1).transpose();
    const Eigen::Vector3d d = b - a;
    // Liang–Barsky: the parameter interval [enter, leave] of a + t d inside the box.
    double enter = 0.0, leave = 1.0;
    for (int axis = 0; axis < 3 && enter <= leave; ++axis) {
      if (d[axis] == 0.0) {
        if (a[axis] < lower[axis] || a[axis] > upper[axis]) enter = 2.0;  // parallel, outside
        continue;
      }
      double t0 = (lower[axis] - a[axis]) / d[axis], t1 = (upper[axis] - a[axis]) / d[axis];
      if (t0 > t1) std::swap(t0, t1);
      enter = std::max(enter, t0);
      leave = std::min(leave, t1);
    }
    if (!(enter <= leave)) {
      close();
      continue;
    }
    const Eigen::Vector3d first = enter == 0.0 ? a : Eigen::Vector3d(a + enter * d);
    const Eigen::Vector3d last = leave == 1.0 ? b : Eigen::Vector3d(a + leave * d);
    if (enter > 0.0) close();  // entering from outside starts a new part
    if (open.empty()) open.push_back(first);
    open.push_back(last);
    if (leave < 1.0) close();
  }
  close();
  return parts;
}

Polyline::Polyline(const Positions& points) : m_points(points) {
  if (points.rows() == 0) throw std::invalid_argument("the stroke has no points");
  if (!points.allFinite()) throw std::invalid_argument("the stroke has non-finite points");
  m_lengths.assign(static_cast<std::size_t>(points.rows()), 0.0);
  for (Eigen::Index k = 1; k < points.rows(); ++k) {
    m_lengths[static_cast<std::size_t>(k)] =
        m_lengths[static_cast<std::size_t>(k) - 1] + (points.row(k) - points.row(k - 1)).norm();
  }
  if (!std::isfinite(m_lengths.back())) {
    throw std::invalid_argument("the stroke is too long to measure (its length overflows)");
  }
}

Eigen::Vector3d Polyline::at(double s) const {
  const auto upper = std::upper_bound(m_lengths.begin(), m_lengths.end(), s);
  if (upper == m_lengths.begin()) return m_points.row(0);
  if (upper == m_lengths.end()) return m_points.row(m_points.rows() - 1);
  const auto k = static_cast<Eigen::Index>(upper - m_lengths.begin());
  const double span =
      m_lengths[static_cast<std::size_t>(k)] - m_lengths[static_cast<std::size_t>(k) - 1];
  const double t = span > 0.0 ? (s - m_lengths[static_cast<std::size_t>(k) - 1]) / span : 0.0;
  return ((1.0 - t) * m_points.row(k - 1) + t * m_points.row(k)).transpose();
}

namespace {

/// Traces the parts of a clipped stroke one after another as one stroke: crossings in the order
/// the stroke first enters their faces, a face's barycentric point the mean over all its samples.
StrokeTrace trace_parts(
    const Polyline& stroke, const std::vector<Positions>& parts, double spacing, const Faces& faces,
    const std::function<std::optional<SurfaceHit>(const Eigen::Vector3d&)>& query) {
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    std::ostringstream msg;
    msg << "the stroke's sampling spacing must be finite and > 0, got " << spacing;
    throw std::invalid_argument(msg.str());
  }
  std::vector<Polyline> lines;
  double needed = 0.0;
  for (const Positions& part : parts) {
    lines.emplace_back(part);
    needed += std::ceil(lines.back().length() / spacing) + 1.0 + static_cast<double>(part.rows());
  }
  if (!(needed <= static_cast<double>(kMaxStrokeSamples))) {
    std::ostringstream msg;
    msg << "the stroke needs about " << needed << " samples, more than the limit of "
        << kMaxStrokeSamples << " (a spacing of " << spacing << " along the parts of the stroke "
        << "near the cloth); draw a shorter stroke or split it";
    throw std::invalid_argument(msg.str());
  }
  StrokeTrace merged;
  // The clipped-away length counts as missed samples at `spacing` (counted, not evaluated), so
  // missed_samples / samples still tells how much of the stroke missed.
  double inside = 0.0;
  for (const Polyline& line : lines) inside += line.length();
  const double outside = std::max(0.0, stroke.length() - inside) / spacing;
  const auto clipped = static_cast<std::int64_t>(std::min(std::round(outside), 1e18));
  std::map<std::int32_t, std::size_t> slot_of_face;
  for (const Polyline& line : lines) {
    const StrokeTrace trace =
        trace_stroke([&](double s) { return query(line.at(s)); }, line.length(), spacing,
                     1e-4 * spacing, faces, line.corners(), kMaxStrokeSamples - merged.samples);
    merged.samples += trace.samples;
    merged.missed_samples += trace.missed_samples;
    const std::int32_t offset = merged.path.empty() ? 0 : merged.path.back().part + 1;
    for (StrokePoint point : trace.path) {
      point.part += offset;
      merged.path.push_back(point);
    }
    for (const StrokeCrossing& crossing : trace.crossings) {
      const auto [it, inserted] = slot_of_face.emplace(crossing.face, merged.crossings.size());
      if (inserted) {
        merged.crossings.push_back(crossing);
        continue;
      }
      StrokeCrossing& into = merged.crossings[it->second];
      into.barycentric =
          (into.barycentric * into.samples + crossing.barycentric * crossing.samples) /
          (into.samples + crossing.samples);
      into.samples += crossing.samples;
    }
  }
  merged.samples += clipped;
  merged.missed_samples += clipped;
  return merged;
}

}  // namespace

StrokeTrace trace_closest(const Positions& positions, const Faces& faces, const Positions& stroke,
                          double max_distance, double spacing) {
  if (!(max_distance >= 0.0) || !std::isfinite(max_distance)) {
    std::ostringstream msg;
    msg << "max_distance must be finite and >= 0, got " << max_distance;
    throw std::invalid_argument(msg.str());
  }
  const SurfaceLocator locator(positions, faces);
  const Polyline line(stroke);  // checks the points before clipping
  // Farther than max_distance from the surface's bounding box is farther from the surface.
  const Eigen::Vector3d lower = positions.colwise().minCoeff().transpose();
  const Eigen::Vector3d upper = positions.colwise().maxCoeff().transpose();
  const double margin = max_distance * (1.0 + 1e-9) + 1e-12 * (upper - lower).norm();
  const std::vector<Positions> parts =
      clip_polyline(stroke, lower.array() - margin, upper.array() + margin);
  return trace_parts(line, parts, spacing, faces,
                     [&](const Eigen::Vector3d& point) -> std::optional<SurfaceHit> {
                       const SurfaceHit hit = locator.closest(point);
                       if (hit.distance > max_distance) return std::nullopt;
                       return hit;
                     });
}

StrokeTrace trace_rays(const Positions& positions, const Faces& faces, const Positions& pixels,
                       const Eigen::Vector3d& eye, const Eigen::Vector3d& base_direction,
                       const Eigen::Vector3d& direction_per_pixel_x,
                       const Eigen::Vector3d& direction_per_pixel_y, double spacing_pixels) {
  const SurfaceLocator locator(positions, faces);
  const Polyline line(pixels);  // checks the points before clipping
  // The pixel (px, py) of a point p solves λ (p − eye) = d0 + px dx + py dy; a ray outside the
  // pixel bounding box of the vertices misses every triangle, as long as all vertices lie in
  // front of the image plane (otherwise a triangle's projection is unbounded: no clipping).
  const Eigen::Vector3d normal = direction_per_pixel_x.cross(direction_per_pixel_y);
  const double depth_scale = base_direction.dot(normal);
  Eigen::Vector3d lower = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d upper = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  bool clip = depth_scale != 0.0 && std::isfinite(depth_scale);
  Eigen::Vector2d pixel_min = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d pixel_max = -pixel_min;
  Eigen::Matrix<double, 3, 2> plane;
  plane << direction_per_pixel_x, direction_per_pixel_y;
  const auto solve = plane.colPivHouseholderQr();
  for (Eigen::Index i = 0; i < positions.rows() && clip; ++i) {
    const Eigen::Vector3d q = positions.row(i).transpose() - eye;
    const double along = q.dot(normal);
    const double lambda = depth_scale / along;  // q's ray meets the image plane at λ q
    if (!(lambda > 0.0) || !std::isfinite(lambda)) {
      clip = false;
      break;
    }
    const Eigen::Vector2d pixel = solve.solve(lambda * q - base_direction);
    pixel_min = pixel_min.cwiseMin(pixel);
    pixel_max = pixel_max.cwiseMax(pixel);
  }
  if (clip && pixel_min.allFinite() && pixel_max.allFinite()) {
    const double margin = 2.0 + 0.01 * (pixel_max - pixel_min).norm();
    lower.head<2>() = pixel_min.array() - margin;
    upper.head<2>() = pixel_max.array() + margin;
  }
  const std::vector<Positions> parts = clip_polyline(pixels, lower, upper);
  return trace_parts(line, parts, spacing_pixels, faces, [&](const Eigen::Vector3d& pixel) {
    return locator.first_hit(eye, base_direction + pixel.x() * direction_per_pixel_x +
                                      pixel.y() * direction_per_pixel_y);
  });
}

std::vector<std::optional<SurfaceHit>> pick_rays(const Positions& positions, const Faces& faces,
                                                 const Positions& pixels,
                                                 const Eigen::Vector3d& eye,
                                                 const Eigen::Vector3d& base_direction,
                                                 const Eigen::Vector3d& direction_per_pixel_x,
                                                 const Eigen::Vector3d& direction_per_pixel_y) {
  std::vector<std::optional<SurfaceHit>> hits(static_cast<std::size_t>(pixels.rows()));
  if (pixels.rows() == 0) return hits;
  const SurfaceLocator locator(positions, faces);
  for (Eigen::Index k = 0; k < pixels.rows(); ++k) {
    const Eigen::Vector3d direction = base_direction + pixels(k, 0) * direction_per_pixel_x +
                                      pixels(k, 1) * direction_per_pixel_y;
    hits[static_cast<std::size_t>(k)] = locator.first_hit(eye, direction);
  }
  return hits;
}

}  // namespace yore
