#include "yore/growth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace yore {
namespace {

// The growth table: one falloff, four rules.
constexpr std::array<GrowthRule, 4> kGrowthRules{{
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

/// A stroke's path as polyline parts, for nearest-point and tangent queries.
class PathGeometry {
 public:
  struct Nearest {
    double distance = std::numeric_limits<double>::infinity();
    std::size_t part = 0;  ///< index into m_parts
    double arc = 0.0;      ///< arc length along that part, m
  };

  PathGeometry(const Positions& path, const std::vector<std::int32_t>& labels) {
    for (Eigen::Index k = 0; k < path.rows(); ++k) {
      if (k == 0 || labels[static_cast<std::size_t>(k)] != labels[static_cast<std::size_t>(k) - 1]) {
        m_parts.emplace_back();
      }
      Part& part = m_parts.back();
      const Eigen::RowVector3d point = path.row(k);
      part.arc.push_back(part.points.empty() ? 0.0
                                             : part.arc.back() + (point - part.points.back()).norm());
      part.points.push_back(point);
    }
  }

  Nearest nearest(const Eigen::RowVector3d& x) const {
    Nearest best;
    for (std::size_t p = 0; p < m_parts.size(); ++p) {
      const Part& part = m_parts[p];
      if (part.points.size() == 1) {
        const double d = (x - part.points[0]).norm();
        if (d < best.distance) best = {d, p, 0.0};
        continue;
      }
      for (std::size_t k = 0; k + 1 < part.points.size(); ++k) {
        const Eigen::RowVector3d a = part.points[k], segment = part.points[k + 1] - a;
        const double length2 = segment.squaredNorm();
        const double t = length2 > 0.0 ? std::clamp((x - a).dot(segment) / length2, 0.0, 1.0) : 0.0;
        const double d = (x - a - t * segment).norm();
        if (d < best.distance) best = {d, p, part.arc[k] + t * (part.arc[k + 1] - part.arc[k])};
      }
    }
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
  static Eigen::RowVector3d at(const Part& part, double s) {
    const auto upper = std::upper_bound(part.arc.begin(), part.arc.end(), s);
    if (upper == part.arc.begin()) return part.points.front();
    if (upper == part.arc.end()) return part.points.back();
    const auto k = static_cast<std::size_t>(upper - part.arc.begin());
    const double span = part.arc[k] - part.arc[k - 1];
    const double t = span > 0.0 ? (s - part.arc[k - 1]) / span : 0.0;
    return (1.0 - t) * part.points[k - 1] + t * part.points[k];
  }
  std::vector<Part> m_parts;
};

bool outside(const Eigen::RowVector3d& x, const Eigen::RowVector3d& lower,
             const Eigen::RowVector3d& upper) {
  return (x.array() < lower.array()).any() || (x.array() > upper.array()).any();
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
      const double edge = (positions.row(faces(f, c)) - positions.row(faces(f, (c + 1) % 3))).norm();
      reach = std::max(reach, edge);
      edge_sum += edge;
    }
  }
  band.reach = reach;
  band.tangent_span = crossed_faces.empty() ? 0.0 : edge_sum / (3.0 * static_cast<double>(crossed_faces.size()));
  if (path.rows() > 0) {
    const PathGeometry geometry(path, path_part);
    const Eigen::RowVector3d lower = path.colwise().minCoeff().array() - reach;
    const Eigen::RowVector3d upper = path.colwise().maxCoeff().array() + reach;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::RowVector3d x = positions.row(i);
      if (outside(x, lower, upper)) continue;
      const PathGeometry::Nearest nearest = geometry.nearest(x);
      band.vertex_distance[i] = nearest.distance;
      band.vertex_tangent.row(i) = geometry.tangent(nearest, band.tangent_span);
      band.vertex_weight[i] = width > 0.0 ? falloff_weight(nearest.distance, 0.5 * width) : 0.0;
    }
  }
  std::vector<char> in_band(static_cast<std::size_t>(faces.rows()), 0);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    if (crossed[static_cast<std::size_t>(f)]) {
      in_band[static_cast<std::size_t>(f)] = 1;
      for (int c = 0; c < 3; ++c) band.vertex_weight[faces(f, c)] = 1.0;
      continue;
    }
    if (width > 0.0) {
      for (int c = 0; c < 3; ++c) {
        if (band.vertex_distance[faces(f, c)] < 0.5 * width) in_band[static_cast<std::size_t>(f)] = 1;
      }
    }
  }
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    if (in_band[static_cast<std::size_t>(f)]) band.faces.push_back(static_cast<std::int32_t>(f));
  }
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
  const PathGeometry geometry(band.path, band.path_part);
  const auto count = static_cast<Eigen::Index>(springs.size());
  Growth growth;
  growth.rest_lengths = Eigen::Map<const Eigen::VectorXd>(springs.rest_length.data(), count);
  growth.weights = Eigen::VectorXd::Zero(count);
  for (Eigen::Index k = 0; k < count; ++k) {
    const std::int32_t i = springs.first[static_cast<std::size_t>(k)];
    const std::int32_t j = springs.second[static_cast<std::size_t>(k)];
    const double w = std::min(band.vertex_weight[i], band.vertex_weight[j]);
    growth.weights[k] = w;
    if (!(w > 0.0) || !(rule.grows_along || rule.grows_across)) continue;
    const double g = 1.0 + (expansion - 1.0) * w;
    const double rest = growth.rest_lengths[k];
    double grown = rest * g;
    if (rule.grows_along != rule.grows_across) {
      const Eigen::RowVector3d d = positions.row(j) - positions.row(i);
      const Eigen::RowVector3d middle = 0.5 * (positions.row(i) + positions.row(j));
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
