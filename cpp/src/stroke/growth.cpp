#include "yore/stroke/growth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace yore {
namespace {

// The growth table: one falloff, four rules.
constexpr std::array<GrowthRule, kGrowthModeCount> kGrowthRules{{
    {"paper", true, false, false},
    {"isotropic", false, true, true},
    {"along", false, true, false},
    {"across", false, false, true},
}};

}  // namespace

const GrowthRule& growth_rule(GrowthMode mode) {
  return kGrowthRules[static_cast<std::size_t>(mode)];
}

GrowthMode growth_mode(const std::string& name) {
  for (std::size_t k = 0; k < kGrowthRules.size(); ++k) {
    if (name == kGrowthRules[k].name) return static_cast<GrowthMode>(k);
  }
  std::ostringstream msg;
  msg << "unknown growth '" << name << "'; expected one of";
  for (const GrowthRule& rule : kGrowthRules) msg << " '" << rule.name << "'";
  throw std::invalid_argument(msg.str());
}

double falloff_weight(double distance, double half_width) {
  if (!(half_width > 0.0)) return distance <= 0.0 ? 1.0 : 0.0;
  const double t = std::clamp(distance / half_width, 0.0, 1.0);
  return 1.0 - t * t * (3.0 - 2.0 * t);
}

namespace {

/// A stroke's path as polyline parts, for nearest-point and tangent queries within `reach`:
/// segments are bucketed in a grid of cells `reach` wide, so a query looks at its cell and the
/// 26 around it (every segment within reach of the point overlaps one of them).
class PathGeometry {
 public:
  struct Nearest {
    double distance = std::numeric_limits<double>::infinity();  ///< +inf: nothing within reach
    std::size_t part = 0;                                       ///< index into m_parts
    double arc = 0.0;                                           ///< arc length along that part, m
  };

  PathGeometry(const Positions& path, const std::vector<std::int32_t>& labels, double reach)
      : m_cell(reach) {
    for (Eigen::Index k = 0; k < path.rows(); ++k) {
      if (k == 0 ||
          labels[static_cast<std::size_t>(k)] != labels[static_cast<std::size_t>(k) - 1]) {
        m_parts.emplace_back();
      }
      Part& part = m_parts.back();
      const Eigen::RowVector3d point = path.row(k);
      part.arc.push_back(
          part.points.empty() ? 0.0 : part.arc.back() + (point - part.points.back()).norm());
      part.points.push_back(point);
    }
    for (std::size_t p = 0; p < m_parts.size(); ++p) {
      const Part& part = m_parts[p];
      const std::size_t count = std::max<std::size_t>(1, part.points.size() - 1);
      for (std::size_t k = 0; k < count; ++k) {
        const std::size_t next = std::min(k + 1, part.points.size() - 1);
        const auto id = static_cast<std::int32_t>(m_segments.size());
        m_segments.push_back({part.points[k], part.points[next], p, part.arc[k], part.arc[next]});
        if (!(m_cell > 0.0)) continue;
        const Eigen::RowVector3d lower = part.points[k].cwiseMin(part.points[next]);
        const Eigen::RowVector3d upper = part.points[k].cwiseMax(part.points[next]);
        const Cell lo = cell_of(lower), hi = cell_of(upper);
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
          for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
            for (std::int64_t z = lo[2]; z <= hi[2]; ++z) m_grid[key({x, y, z})].push_back(id);
      }
    }
  }

  Nearest nearest(const Eigen::RowVector3d& x) const {
    Nearest best;
    auto consider = [&](const Segment& segment) {
      const Eigen::RowVector3d along = segment.b - segment.a;
      const double length2 = along.squaredNorm();
      const double t =
          length2 > 0.0 ? std::clamp((x - segment.a).dot(along) / length2, 0.0, 1.0) : 0.0;
      const double d = (x - segment.a - t * along).norm();
      if (d < best.distance) {
        best = {d, segment.part, segment.arc_a + t * (segment.arc_b - segment.arc_a)};
      }
    };
    if (!(m_cell > 0.0)) {
      for (const Segment& segment : m_segments) consider(segment);
      return best;
    }
    const Cell c = cell_of(x);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = m_grid.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == m_grid.end()) continue;
          for (const std::int32_t id : it->second)
            consider(m_segments[static_cast<std::size_t>(id)]);
        }
    if (best.distance > m_cell) best = Nearest{};  // beyond reach: not measured
    return best;
  }

  /// Unit chord of the part over [arc − span/2, arc + span/2] (clamped to the part), or 0.
  Eigen::RowVector3d tangent(const Nearest& where, double span) const {
    if (!std::isfinite(where.distance)) return Eigen::RowVector3d::Zero();
    const Part& part = m_parts[where.part];
    const double end = part.arc.back();
    const Eigen::RowVector3d chord = at(part, std::min(end, where.arc + 0.5 * span)) -
                                     at(part, std::max(0.0, where.arc - 0.5 * span));
    const double length = chord.norm();
    return length > 0.0 ? Eigen::RowVector3d(chord / length) : Eigen::RowVector3d::Zero();
  }

 private:
  struct Part {
    std::vector<Eigen::RowVector3d> points;
    std::vector<double> arc;
  };
  struct Segment {
    Eigen::RowVector3d a, b;
    std::size_t part;
    double arc_a, arc_b;
  };
  using Cell = std::array<std::int64_t, 3>;
  Cell cell_of(const Eigen::RowVector3d& x) const {
    return {static_cast<std::int64_t>(std::floor(x[0] / m_cell)),
            static_cast<std::int64_t>(std::floor(x[1] / m_cell)),
            static_cast<std::int64_t>(std::floor(x[2] / m_cell))};
  }
  static std::uint64_t key(const Cell& c) {
    // Cells of one stroke span far fewer than 2^21 per axis: pack 21 bits each.
    const auto bits = [](std::int64_t v) { return static_cast<std::uint64_t>(v) & 0x1fffffu; };
    return bits(c[0]) | (bits(c[1]) << 21) | (bits(c[2]) << 42);
  }
  static Eigen::RowVector3d at(const Part& part, double s) {
    const auto upper = std::upper_bound(part.arc.begin(), part.arc.end(), s);
    if (upper == part.arc.begin()) return part.points.front();
    if (upper == part.arc.end()) return part.points.back();
    const auto k = static_cast<std::size_t>(upper - part.arc.begin());
    const double span = part.arc[k] - part.arc[k - 1];
    const double t = span > 0.0 ? (s - part.arc[k - 1]) / span : 0.0;
    return (1.0 - t) * part.points[k - 1] + t * part.points[k];
  }
  double m_cell;
  std::vector<Part> m_parts;
  std::vector<Segment> m_segments;
  std::unordered_map<std::uint64_t, std::vector<std::int32_t>> m_grid;
};

bool outside(const Eigen::RowVector3d& x, const Eigen::RowVector3d& lower,
             const Eigen::RowVector3d& upper) {
  return (x.array() < lower.array()).any() || (x.array() > upper.array()).any();
}

// Each vertex within the band's reach of the path: its distance, the path's tangent there and
// its falloff weight (0 without a width).
void measure_vertices(const Positions& positions, const Positions& path,
                      const std::vector<std::int32_t>& path_part, double width, StrokeBand& band) {
  const double reach = band.reach;
  const PathGeometry geometry(path, path_part, reach);
  const Eigen::RowVector3d lower = path.colwise().minCoeff().array() - reach;
  const Eigen::RowVector3d upper = path.colwise().maxCoeff().array() + reach;
  for (Eigen::Index i = 0; i < positions.rows(); ++i) {
    const Eigen::RowVector3d x = positions.row(i);
    if (outside(x, lower, upper)) continue;
    const PathGeometry::Nearest nearest = geometry.nearest(x);
    band.vertex_distance[i] = nearest.distance;
    band.vertex_tangent.row(i) = geometry.tangent(nearest, band.tangent_span);
    band.vertex_weight[i] = width > 0.0 ? falloff_weight(nearest.distance, 0.5 * width) : 0.0;
  }
}

// The band's faces: the crossed ones (whose corners weigh 1 without a width), and with a width
// every face with a corner closer than half of it.
void select_faces(const Faces& faces, const std::vector<char>& crossed, double width,
                  StrokeBand& band) {
  std::vector<char> in_band(static_cast<std::size_t>(faces.rows()), 0);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    if (crossed[static_cast<std::size_t>(f)]) {
      // with a width the weights are the falloff's alone (forcing the crossed faces' corners
      // to 1 would grow a strip one face wide in full: O(h) more area on coarser meshes)
      in_band[static_cast<std::size_t>(f)] = 1;
      if (!(width > 0.0)) {
        for (int c = 0; c < 3; ++c) band.vertex_weight[faces(f, c)] = 1.0;
      }
      continue;
    }
    if (width > 0.0) {
      for (int c = 0; c < 3; ++c) {
        if (band.vertex_distance[faces(f, c)] < 0.5 * width)
          in_band[static_cast<std::size_t>(f)] = 1;
      }
    }
  }
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    if (in_band[static_cast<std::size_t>(f)]) band.faces.push_back(static_cast<std::int32_t>(f));
  }
}

// Half the length of the longest spring with an end in the band (weight > 0).
double half_longest_band_spring(const Positions& positions, const SpringSet& springs,
                                const StrokeBand& band) {
  double half_spring = 0.0;
  for (std::size_t k = 0; k < springs.size(); ++k) {
    const std::int32_t i = springs.first[k], j = springs.second[k];
    if (band.vertex_weight[i] > 0.0 || band.vertex_weight[j] > 0.0) {
      half_spring = std::max(half_spring, 0.5 * (positions.row(j) - positions.row(i)).norm());
    }
  }
  return half_spring;
}

// The path's bounding box grown by the band's reach (midpoints outside it weigh 0); an empty
// box for an empty path.
void path_box(const StrokeBand& band, Eigen::RowVector3d& lower, Eigen::RowVector3d& upper) {
  if (band.path.rows() > 0) {
    lower = band.path.colwise().minCoeff().array() - band.reach;
    upper = band.path.colwise().maxCoeff().array() + band.reach;
  } else {
    lower.setConstant(std::numeric_limits<double>::infinity());
    upper.setConstant(-std::numeric_limits<double>::infinity());
  }
}

}  // namespace

StrokeBand stroke_band(const Positions& positions, const Faces& faces, const Positions& path,
                       const std::vector<std::int32_t>& path_part,
                       const std::vector<std::int32_t>& crossed_faces, double width) {
  if (!std::isfinite(width) || width < 0.0) {
    std::ostringstream msg;
    msg << "width must be finite and >= 0 (m), got " << width;
    throw std::invalid_argument(msg.str());
  }
  if (static_cast<std::size_t>(path.rows()) != path_part.size()) {
    throw std::invalid_argument("stroke_band: path and path_part differ in length");
  }
  const Eigen::Index n = positions.rows();
  StrokeBand band;
  band.vertex_distance = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  band.vertex_weight = Eigen::VectorXd::Zero(n);
  band.vertex_tangent = Positions::Zero(n, 3);
  band.path = path;
  band.path_part = path_part;
  std::vector<char> crossed(static_cast<std::size_t>(faces.rows()), 0);
  double reach = 0.5 * width, edge_sum = 0.0;  // how far from the path distances matter
  for (const std::int32_t f : crossed_faces) {
    if (f < 0 || f >= faces.rows()) {
      std::ostringstream msg;
      msg << "stroke_band: face " << f << " out of range [0, " << faces.rows() << ")";
      throw std::invalid_argument(msg.str());
    }
    crossed[static_cast<std::size_t>(f)] = 1;
    for (int c = 0; c < 3; ++c) {
      const double edge =
          (positions.row(faces(f, c)) - positions.row(faces(f, (c + 1) % 3))).norm();
      reach = std::max(reach, edge);
      edge_sum += edge;
    }
  }
  band.reach = reach;
  band.half_width = 0.5 * width;
  band.tangent_span =
      crossed_faces.empty() ? 0.0 : edge_sum / (3.0 * static_cast<double>(crossed_faces.size()));
  if (path.rows() > 0) measure_vertices(positions, path, path_part, width, band);
  select_faces(faces, crossed, width, band);
  return band;
}

Growth grow_rest_lengths(const Positions& positions, const SpringSet& springs,
                         const StrokeBand& band, GrowthMode mode, double expansion) {
  if (!std::isfinite(expansion) || expansion <= 0.0) {
    std::ostringstream msg;
    msg << "expansion must be finite and > 0, got " << expansion;
    throw std::invalid_argument(msg.str());
  }
  const Eigen::Index n = positions.rows();
  if (band.vertex_weight.size() != n || band.vertex_tangent.rows() != n ||
      band.vertex_distance.size() != n) {
    throw std::invalid_argument("grow_rest_lengths: the band was made for another mesh");
  }
  const GrowthRule& rule = growth_rule(mode);
  // the springs' midpoints are looked up too: reach half the longest spring with an end in
  // the band further, so every spring that grows finds its tangent
  const PathGeometry geometry(band.path, band.path_part,
                              band.reach + half_longest_band_spring(positions, springs, band));
  Eigen::RowVector3d lower = Eigen::RowVector3d::Zero(), upper = Eigen::RowVector3d::Zero();
  path_box(band, lower, upper);
  const auto count = static_cast<Eigen::Index>(springs.size());
  Growth growth;
  growth.rest_lengths = Eigen::Map<const Eigen::VectorXd>(springs.rest_length.data(), count);
  growth.weights = Eigen::VectorXd::Zero(count);
  for (Eigen::Index k = 0; k < count; ++k) {
    const std::int32_t i = springs.first[static_cast<std::size_t>(k)];
    const std::int32_t j = springs.second[static_cast<std::size_t>(k)];
    const Eigen::RowVector3d middle = 0.5 * (positions.row(i) + positions.row(j));
    double w = std::min(band.vertex_weight[i], band.vertex_weight[j]);
    if (band.half_width > 0.0 && (band.vertex_weight[i] > 0.0 || band.vertex_weight[j] > 0.0 ||
                                  !outside(middle, lower, upper))) {
      const double centre = falloff_weight(geometry.nearest(middle).distance, band.half_width);
      w = (band.vertex_weight[i] + 4.0 * centre + band.vertex_weight[j]) / 6.0;
    }
    growth.weights[k] = w;
    if (!(w > 0.0) || !(rule.grows_along || rule.grows_across)) continue;
    const double g = 1.0 + (expansion - 1.0) * w;
    const double rest = growth.rest_lengths[k];
    double grown = rest * g;
    if (rule.grows_along != rule.grows_across) {
      const Eigen::RowVector3d d = positions.row(j) - positions.row(i);
      const Eigen::RowVector3d tangent =
          geometry.tangent(geometry.nearest(middle), band.tangent_span);
      const double length = d.norm();
      const double c = length > 0.0 ? std::min(1.0, std::abs(d.dot(tangent)) / length) : 0.0;
      const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
      const double a = rule.grows_along ? g : 1.0, b = rule.grows_across ? g : 1.0;
      grown = rest * std::sqrt(a * a * c * c + b * b * s * s);
    }
    if (grown != rest) {
      ++growth.springs_grown;
      growth.rest_added += grown - rest;
      growth.rest_lengths[k] = grown;
    }
  }
  return growth;
}

}  // namespace yore
