#include "yore/quadratic_bending.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace yore {
namespace {

using Point = Eigen::Vector3d;

/// cot of the angle between u and v (both non-zero, not parallel: checked by the caller's area).
double cotangent(const Point& u, const Point& v) { return u.dot(v) / u.cross(v).norm(); }

}  // namespace

// over 80 lines: the hinge stencil (Bergou et al. 2006: cotangent weights, the normalisation
// by the two faces' rest areas, the outer product into Q) is one formula per hinge, read best
// in one piece beside the edge sort that finds the hinges.
QuadraticBendingMatrix quadratic_bending_matrix(const Positions& rest_positions,
                                                const Faces& faces) {
  const Eigen::Index n = rest_positions.rows();
  QuadraticBendingMatrix out;
  out.size = n;
  // Every face's three edges as (lower end, upper end, opposite vertex, face); sorted, the two
  // sides of an interior edge are neighbours.
  std::vector<std::array<std::int32_t, 4>> sides;
  sides.reserve(static_cast<std::size_t>(3 * faces.rows()));
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const std::int32_t i = faces(f, c), j = faces(f, (c + 1) % 3), k = faces(f, (c + 2) % 3);
      if (i < 0 || i >= n || j < 0 || j >= n || k < 0 || k >= n) {
        std::ostringstream msg;
        msg << "face " << f << " has a vertex index out of range [0, " << n << ")";
        throw std::invalid_argument(msg.str());
      }
      sides.push_back({std::min(i, j), std::max(i, j), k, static_cast<std::int32_t>(f)});
    }
  }
  std::sort(sides.begin(), sides.end());
  auto face_area = [&](std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t face) {
    const Point xa = rest_positions.row(a), xb = rest_positions.row(b), xc = rest_positions.row(c);
    const double area = 0.5 * (xb - xa).cross(xc - xa).norm();
    if (!(area > 0.0) || !std::isfinite(area)) {
      std::ostringstream msg;
      msg << "quadratic bending: face " << face << " has rest area " << area
          << " m²; it must be finite and > 0";
      throw std::invalid_argument(msg.str());
    }
    return area;
  };

  std::vector<std::tuple<std::int32_t, std::int32_t, double>> triplets;  // (row, column, value)
  for (std::size_t s = 0; s + 1 < sides.size(); ++s) {
    if (sides[s][0] != sides[s + 1][0] || sides[s][1] != sides[s + 1][1]) continue;
    // A hinge: edge (v0, v1), opposite vertices v2 (one face) and v3 (the other).
    const std::array<std::int32_t, 4> v = {sides[s][0], sides[s][1], sides[s][2],
                                           sides[s + 1][2]};
    const Point x0 = rest_positions.row(v[0]), x1 = rest_positions.row(v[1]),
                x2 = rest_positions.row(v[2]), x3 = rest_positions.row(v[3]);
    const double area = face_area(v[0], v[1], v[2], sides[s][3]) +
                        face_area(v[0], v[1], v[3], sides[s + 1][3]);
    const Point e = x1 - x0;
    // Angles at the edge's ends: α in the face of v2, β in the face of v3.
    const double cot_alpha0 = cotangent(e, x2 - x0), cot_alpha1 = cotangent(-e, x2 - x1);
    const double cot_beta0 = cotangent(e, x3 - x0), cot_beta1 = cotangent(-e, x3 - x1);
    // Σ K_j x_j: each face contributes |e| times its in-plane unit normal to e (pointing from
    // the opposite vertex to the edge); the two cancel on a flat hinge.
    const std::array<double, 4> weights = {cot_alpha1 + cot_beta1, cot_alpha0 + cot_beta0,
                                           -(cot_alpha0 + cot_alpha1), -(cot_beta0 + cot_beta1)};
    // 1/(A₀ + A₁): with it E = ½ κ xᵀQx tends to ½ κ ∫ (2H)² dA (H the mean curvature) under
    // refinement — measured for a strip rolled onto a cylinder on grid_mesh at 0°, 45° and 90°
    // to its lines and on an equilateral mesh (tests/test_quadratic_bending.py), so κ is the
    // plate's bending rigidity D. Bergou et al.'s 3/(A₀ + A₁) gives three times that.
    const double scale = 1.0 / area;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) triplets.emplace_back(v[r], v[c], scale * weights[r] * weights[c]);
    }
    out.fold_energy += 2.0 * e.squaredNorm() / area;  // ½ (2|e|)² / (A₀ + A₁) at θ = π
    ++out.hinge_count;
    ++s;  // both sides consumed
  }
  // Stable sort: equal entries are summed in hinge order, so the values are reproducible.
  std::stable_sort(triplets.begin(), triplets.end(), [](const auto& a, const auto& b) {
    return std::get<0>(a) != std::get<0>(b) ? std::get<0>(a) < std::get<0>(b)
                                            : std::get<1>(a) < std::get<1>(b);
  });
  out.row_starts.assign(static_cast<std::size_t>(n) + 1, 0);
  out.columns.reserve(triplets.size() / 2 + static_cast<std::size_t>(n));
  out.values.reserve(out.columns.capacity());
  std::size_t t = 0;
  for (Eigen::Index row = 0; row < n; ++row) {
    out.row_starts[static_cast<std::size_t>(row)] = static_cast<std::int32_t>(out.columns.size());
    const std::size_t diagonal = out.columns.size();
    out.columns.push_back(static_cast<std::int32_t>(row));  // the diagonal first, even if 0
    out.values.push_back(0.0);
    for (; t < triplets.size() && std::get<0>(triplets[t]) == row; ++t) {
      const std::int32_t column = std::get<1>(triplets[t]);
      const double value = std::get<2>(triplets[t]);
      if (column == row) {
        out.values[diagonal] += value;
      } else if (out.columns.size() > diagonal + 1 && out.columns.back() == column) {
        out.values.back() += value;
      } else {
        out.columns.push_back(column);
        out.values.push_back(value);
      }
    }
  }
  out.row_starts.back() = static_cast<std::int32_t>(out.columns.size());
  return out;
}

namespace {

// (Q x)ᵢ, one row of the product, per coordinate.
Eigen::RowVector3d row_product(const QuadraticBendingMatrix& matrix, const Positions& positions,
                               Eigen::Index i) {
  Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
  for (std::int32_t k = matrix.row_starts[static_cast<std::size_t>(i)];
       k < matrix.row_starts[static_cast<std::size_t>(i) + 1]; ++k) {
    sum += matrix.values[static_cast<std::size_t>(k)] *
           positions.row(matrix.columns[static_cast<std::size_t>(k)]);
  }
  return sum;
}

}  // namespace

double quadratic_bending_gradient(const QuadraticBendingMatrix& matrix, double modulus,
                                  const Positions& positions, Positions& gradient) {
  const Eigen::Index n = positions.rows();
  gradient.resize(n, 3);
  double twice_energy = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    gradient.row(i) = modulus * row_product(matrix, positions, i);
    twice_energy += positions.row(i).dot(gradient.row(i));
  }
  return 0.5 * twice_energy;
}

double quadratic_bending_energy(const QuadraticBendingMatrix& matrix, double modulus,
                                const Positions& positions) {
  double twice_energy = 0.0;
  for (Eigen::Index i = 0; i < positions.rows(); ++i) {
    twice_energy += positions.row(i).dot(row_product(matrix, positions, i));
  }
  return 0.5 * modulus * twice_energy;
}

}  // namespace yore
