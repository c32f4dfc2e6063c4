#include "yore/cloth/quadratic_bending.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <utility>

namespace yore {
namespace {

using Point = Eigen::Vector3d;

/// cot of the angle between u and v (both non-zero, not parallel: checked by the caller's area).
double cotangent(const Point& u, const Point& v) { return u.dot(v) / u.cross(v).norm(); }

/// (row, column, value) triplets, summed, into out's CSR arrays (out.size rows; the diagonal
/// first in every row, even if 0, then the other columns in increasing order).
void fill_rows(std::vector<std::tuple<std::int32_t, std::int32_t, double>>& triplets,
               QuadraticBendingMatrix& out) {
  const std::int64_t n = out.size;
  // Stable sort: equal entries are summed in the order they were made (reproducible values).
  std::stable_sort(triplets.begin(), triplets.end(), [](const auto& a, const auto& b) {
    return std::get<0>(a) != std::get<0>(b) ? std::get<0>(a) < std::get<0>(b)
                                            : std::get<1>(a) < std::get<1>(b);
  });
  out.row_starts.assign(static_cast<std::size_t>(n) + 1, 0);
  out.columns.reserve(triplets.size() / 2 + static_cast<std::size_t>(n));
  out.values.reserve(out.columns.capacity());
  std::size_t t = 0;
  for (std::int64_t row = 0; row < n; ++row) {
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
}

}  // namespace

namespace {

// Every face's three edges as (lower end, upper end, opposite vertex, face), sorted: the two
// sides of an interior edge are neighbours. Checks the faces' vertex indices against n.
std::vector<std::array<std::int32_t, 4>> sorted_sides(const Faces& faces, Eigen::Index n) {
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
  return sides;
}

// A face's rest area, m²; refuses a degenerate or non-finite one.
double rest_face_area(const Positions& rest_positions, std::int32_t a, std::int32_t b,
                      std::int32_t c, std::int32_t face) {
  const Point xa = rest_positions.row(a), xb = rest_positions.row(b), xc = rest_positions.row(c);
  const double area = 0.5 * (xb - xa).cross(xc - xa).norm();
  if (!(area > 0.0) || !std::isfinite(area)) {
    std::ostringstream msg;
    msg << "quadratic bending: face " << face << " has rest area " << area
        << " m²; it must be finite and > 0";
    throw std::invalid_argument(msg.str());
  }
  return area;
}

// The hinge stencil (Bergou et al. 2006: cotangent weights, the normalisation by the two
// faces' rest areas, the outer product into Q), one hinge per interior edge. With values
// false it only checks the mesh and counts the hinges and their fold energy (the fitted
// builder's scales).
QuadraticBendingMatrix hinge_matrix(const Positions& rest_positions, const Faces& faces,
                                    bool values) {
  const Eigen::Index n = rest_positions.rows();
  QuadraticBendingMatrix out;
  out.size = n;
  const std::vector<std::array<std::int32_t, 4>> sides = sorted_sides(faces, n);
  auto face_area = [&](std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t face) {
    return rest_face_area(rest_positions, a, b, c, face);
  };

  std::vector<std::tuple<std::int32_t, std::int32_t, double>> triplets;  // (row, column, value)
  for (std::size_t s = 0; s + 1 < sides.size(); ++s) {
    if (sides[s][0] != sides[s + 1][0] || sides[s][1] != sides[s + 1][1]) continue;
    // A hinge: edge (v0, v1), opposite vertices v2 (one face) and v3 (the other).
    const std::array<std::int32_t, 4> v = {sides[s][0], sides[s][1], sides[s][2], sides[s + 1][2]};
    const Point x0 = rest_positions.row(v[0]), x1 = rest_positions.row(v[1]),
                x2 = rest_positions.row(v[2]), x3 = rest_positions.row(v[3]);
    const double area =
        face_area(v[0], v[1], v[2], sides[s][3]) + face_area(v[0], v[1], v[3], sides[s + 1][3]);
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
    for (int r = 0; r < 4 && values; ++r) {
      for (int c = 0; c < 4; ++c)
        triplets.emplace_back(v[r], v[c], scale * weights[r] * weights[c]);
    }
    out.fold_energy += 2.0 * e.squaredNorm() / area;  // ½ (2|e|)² / (A₀ + A₁) at θ = π
    ++out.hinge_count;
    ++s;  // both sides consumed
  }
  if (values) fill_rows(triplets, out);
  return out;
}

}  // namespace

QuadraticBendingMatrix quadratic_bending_matrix(const Positions& rest_positions,
                                                const Faces& faces) {
  return hinge_matrix(rest_positions, faces, true);
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

namespace yore {
namespace {

/// Smallest singular value allowed of a patch's design matrix, relative to its largest (in
/// coordinates scaled by the patch radius): below it the fitted curvature would amplify the
/// positions' round-off and the patch grows instead. A regular 1-ring (6 neighbours) has 0.2,
/// a valence-5 one 0.1; a valence-4 one is rank deficient and grows.
constexpr double kFitConditioning = 1e-2;

/// Weight of the fit's residual in the energy, per point, in units of the patch's curvature
/// scale (below). The Hessian of a least-squares quadratic is blind to what the quadratic does
/// not explain (a valence-6 patch has one such pattern: a spike of the centre against its
/// ring); without this term those mesh-scale shapes would cost nothing from this patch, and
/// sharp one-face tents would be cheaper than with the hinge energy. The residual of a
/// quadratic field is zero, so it keeps the energy exact there; on a smooth surface it is
/// O(h³) per point, an O(h²) relative term (the cylinder test: below 0.1 % at 9 vertices
/// across).
constexpr double kResidualWeight = 1.0;

/// Largest patch a fit may grow to (a 1-ring has ~7 points, a corner's grown patch ~10).
constexpr std::size_t kMaxPatch = 40;

/// One vertex's fit: the vertices of its patch and the patch's energy matrix per unit area,
/// K = W Wᵀ + β/(m ρ⁴) (I − P) (W: the three weights per point that give the fitted Hessian's
/// (H_uu, √2 H_uv, H_vv); P the fit's projection; β = kResidualWeight; ρ² the patch's mean
/// squared distance from its vertex), so the vertex adds A_p fᵀ K f for a field f.
struct VertexFit {
  std::vector<std::int32_t> patch;
  Eigen::MatrixXd energy;
};

/// The least-squares quadratic over `patch` (tangent-plane coordinates about `centre`, axes
/// `u`, `v`) and its energy matrix K (above), or an empty matrix when the patch is too small or
/// its points too nearly on one conic (kFitConditioning). The fit runs in coordinates whitened
/// by the patch's own spread (an affine map, under which quadratics stay quadratics), so a
/// stretched mesh's patch is judged like the regular one it is an image of.
Eigen::MatrixXd fit_energy(const Positions& rest, const std::vector<std::int32_t>& patch,
                           const Point& centre, const Point& u, const Point& v) {
  const auto m = static_cast<Eigen::Index>(patch.size());
  const Eigen::MatrixXd none;
  if (m < 6) return none;
  Eigen::MatrixX2d d(m, 2);
  for (Eigen::Index k = 0; k < m; ++k) {
    const Point offset = rest.row(patch[static_cast<std::size_t>(k)]).transpose() - centre;
    d(k, 0) = offset.dot(u);
    d(k, 1) = offset.dot(v);
  }
  const Eigen::Matrix2d spread = d.transpose() * d / static_cast<double>(m);
  const double scale2 = spread.trace();  // ρ²
  if (!(scale2 > 0.0) || !(spread.determinant() > 1e-12 * scale2 * scale2)) return none;
  const Eigen::Matrix2d lower = spread.llt().matrixL();  // spread = L Lᵀ
  const Eigen::Matrix2d to_white = lower.inverse();      // s = L⁻¹ d
  const Eigen::MatrixX2d s = d * to_white.transpose();
  Eigen::MatrixXd design(m, 6);
  design.col(0).setOnes();
  design.col(1) = s.col(0);
  design.col(2) = s.col(1);
  design.col(3) = s.col(0).cwiseProduct(s.col(0));
  design.col(4) = s.col(0).cwiseProduct(s.col(1));
  design.col(5) = s.col(1).cwiseProduct(s.col(1));
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(design, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd sigma = svd.singularValues();
  if (!(sigma(5) >= kFitConditioning * sigma(0))) return none;
  // Coefficients c = V Σ⁻¹ Uᵀ f; rows 3–5 (a, b, c of a s₁² + b s₁ s₂ + c s₂²) give the
  // whitened Hessian [[2a, b], [b, 2c]], and the tangent-plane one is L⁻ᵀ H_s L⁻¹.
  const Eigen::MatrixXd coefficients =
      svd.matrixV() * sigma.cwiseInverse().asDiagonal() * svd.matrixU().transpose();
  Eigen::MatrixX3d weights(m, 3);
  for (Eigen::Index k = 0; k < m; ++k) {
    Eigen::Matrix2d white;
    white << 2.0 * coefficients(3, k), coefficients(4, k), coefficients(4, k),
        2.0 * coefficients(5, k);
    const Eigen::Matrix2d hessian = to_white.transpose() * white * to_white;
    weights(k, 0) = hessian(0, 0);
    weights(k, 1) = std::sqrt(2.0) * hessian(0, 1);
    weights(k, 2) = hessian(1, 1);
  }
  const Eigen::MatrixXd residual =
      Eigen::MatrixXd::Identity(m, m) - svd.matrixU() * svd.matrixU().transpose();
  return weights * weights.transpose() +
         (kResidualWeight / (static_cast<double>(m) * scale2 * scale2)) * residual;
}

/// Unit axes of the plane normal to `normal` (not zero).
std::pair<Point, Point> tangent_axes(const Point& normal) {
  const Point n = normal.normalized();
  const Point seed = std::abs(n.x()) < 0.9 ? Point::UnitX() : Point::UnitY();
  const Point u = (seed - seed.dot(n) * n).normalized();
  return {u, n.cross(u)};
}

/// Vertex `c`'s fit: its 1-ring, grown by the nearest vertices of the next ring, one at a
/// time, until the fit is well posed. Throws std::invalid_argument when its whole mesh
/// component cannot pose one.
VertexFit fit_vertex(const Positions& rest, const std::vector<std::vector<std::int32_t>>& ring,
                     std::int32_t c, const Point& normal) {
  const auto [u, v] = tangent_axes(normal);
  const Point centre = rest.row(c).transpose();
  VertexFit fit;
  fit.patch = ring[static_cast<std::size_t>(c)];
  fit.patch.push_back(c);
  std::sort(fit.patch.begin(), fit.patch.end());
  std::vector<std::int32_t> candidates;
  for (;;) {
    fit.energy = fit_energy(rest, fit.patch, centre, u, v);
    if (fit.energy.rows() > 0) return fit;
    if (fit.patch.size() >= kMaxPatch) {
      std::ostringstream msg;
      msg << "quadratic bending: vertex " << c << " has no well-posed fit within its nearest "
          << kMaxPatch << " vertices (slivers, or points along one curve); use "
          << "bending=\"hinge\" or \"springs\" here";
      throw std::invalid_argument(msg.str());
    }
    if (candidates.empty()) {  // the next ring, nearest last
      for (const std::int32_t p : fit.patch) {
        for (const std::int32_t q : ring[static_cast<std::size_t>(p)]) {
          if (!std::binary_search(fit.patch.begin(), fit.patch.end(), q)) candidates.push_back(q);
        }
      }
      std::sort(candidates.begin(), candidates.end());
      candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
      std::stable_sort(candidates.begin(), candidates.end(), [&](std::int32_t a, std::int32_t b) {
        return (rest.row(a).transpose() - centre).squaredNorm() >
               (rest.row(b).transpose() - centre).squaredNorm();
      });
      if (candidates.empty()) {
        std::ostringstream msg;
        msg << "quadratic bending: vertex " << c << "'s part of the mesh has only "
            << fit.patch.size() << " vertices, or all of them near one conic: the fitted "
            << "curvature needs 6 well spread; use bending=\"hinge\" or \"springs\" here";
        throw std::invalid_argument(msg.str());
      }
    }
    fit.patch.insert(std::upper_bound(fit.patch.begin(), fit.patch.end(), candidates.back()),
                     candidates.back());
    candidates.pop_back();
  }
}

}  // namespace

QuadraticBendingMatrix fitted_bending_matrix(const Positions& rest_positions, const Faces& faces) {
  // The hinge walk checks indices and areas and gives the scale terms (fold_energy, the
  // hinge count); the values are the fits'.
  QuadraticBendingMatrix out = hinge_matrix(rest_positions, faces, false);
  const Eigen::Index n = rest_positions.rows();
  std::vector<std::vector<std::int32_t>> ring(static_cast<std::size_t>(n));
  std::vector<Point> normal(static_cast<std::size_t>(n), Point::Zero());
  Eigen::VectorXd area = Eigen::VectorXd::Zero(n);  // a third of each face at each corner
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Point a = rest_positions.row(faces(f, 0)), b = rest_positions.row(faces(f, 1)),
                c = rest_positions.row(faces(f, 2));
    const Point twice_area = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) {
      const std::int32_t p = faces(f, k);
      area(p) += twice_area.norm() / 6.0;
      normal[static_cast<std::size_t>(p)] += twice_area;
      auto& neighbours = ring[static_cast<std::size_t>(p)];
      for (int d = 1; d < 3; ++d) neighbours.push_back(faces(f, (k + d) % 3));
    }
  }
  std::vector<std::tuple<std::int32_t, std::int32_t, double>> triplets;
  for (Eigen::Index p = 0; p < n; ++p) {
    auto& r = ring[static_cast<std::size_t>(p)];
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
  }
  for (Eigen::Index p = 0; p < n; ++p) {
    if (!(area(p) > 0.0)) continue;  // on no face: no curvature to measure
    Point axis = normal[static_cast<std::size_t>(p)];
    if (!(axis.norm() > 0.0)) axis = Point::UnitZ();  // a fold's faces cancel: any plane
    const VertexFit fit = fit_vertex(rest_positions, ring, static_cast<std::int32_t>(p), axis);
    // A_p K, each pair's value taken from one triangle of K and stored at (i, j) and (j, i):
    // Q is symmetric to the bit.
    for (Eigen::Index i = 0; i < fit.energy.rows(); ++i) {
      for (Eigen::Index j = i; j < fit.energy.rows(); ++j) {
        const double value = area(p) * fit.energy(i, j);
        const std::int32_t a = fit.patch[static_cast<std::size_t>(i)];
        const std::int32_t b = fit.patch[static_cast<std::size_t>(j)];
        triplets.emplace_back(a, b, value);
        if (b != a) triplets.emplace_back(b, a, value);
      }
    }
  }
  fill_rows(triplets, out);
  return out;
}

}  // namespace yore
