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
  std::vector<char> crossed(static_cast<std::size_t>(faces.rows()), 0);
  double reach = 0.5 * width;  // how far from the path distances matter
  for (const std::int32_t f : crossed_faces) {
    if (f < 0 || f >= faces.rows()) {
      std::ostringstream msg;
      msg << "stroke_band: face " << f << " out of range [0, " << faces.rows() << ")";
      throw std::invalid_argument(msg.str());
    }
    crossed[static_cast<std::size_t>(f)] = 1;
    for (int c = 0; c < 3; ++c) {
      reach = std::max(reach, (positions.row(faces(f, c)) - positions.row(faces(f, (c + 1) % 3))).norm());
    }
  }
  if (path.rows() > 0) {
    const Eigen::RowVector3d lower = path.colwise().minCoeff().array() - reach;
    const Eigen::RowVector3d upper = path.colwise().maxCoeff().array() + reach;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::RowVector3d x = positions.row(i);
      if ((x.array() < lower.array()).any() || (x.array() > upper.array()).any()) continue;
      double best = std::numeric_limits<double>::infinity();
      Eigen::RowVector3d tangent = Eigen::RowVector3d::Zero();
      for (Eigen::Index k = 0; k < path.rows(); ++k) {
        const bool joined = k + 1 < path.rows() &&
                            path_part[static_cast<std::size_t>(k)] == path_part[static_cast<std::size_t>(k) + 1];
        const Eigen::RowVector3d a = path.row(k);
        if (!joined) {  // a lone point (or a part's last): its distance, the segment covers it
          const double d = (x - a).norm();
          if (d < best) best = d;
          continue;
        }
        const Eigen::RowVector3d segment = path.row(k + 1) - a;
        const double length2 = segment.squaredNorm();
        const double t = length2 > 0.0 ? std::clamp((x - a).dot(segment) / length2, 0.0, 1.0) : 0.0;
        const double d = (x - a - t * segment).norm();
        if (d < best || (d == best && tangent.isZero() && length2 > 0.0)) {
          best = d;
          if (length2 > 0.0) tangent = segment / std::sqrt(length2);
        }
      }
      band.vertex_distance[i] = best;
      band.vertex_tangent.row(i) = tangent;
      band.vertex_weight[i] = width > 0.0 ? falloff_weight(best, 0.5 * width) : 0.0;
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
      const std::int32_t nearer = band.vertex_distance[i] <= band.vertex_distance[j] ? i : j;
      Eigen::RowVector3d tangent = band.vertex_tangent.row(nearer);
      if (tangent.isZero()) tangent = band.vertex_tangent.row(nearer == i ? j : i);
      const Eigen::RowVector3d d = positions.row(j) - positions.row(i);
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
