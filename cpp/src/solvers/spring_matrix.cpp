#include "yore/solvers/spring_matrix.hpp"

#include <algorithm>
#include <utility>

namespace yore {

namespace {

// The lower triangle's pattern of `unknowns` columns: the diagonal first in each column, then
// the rows of `coupled` ((column, row) pairs, row > column; sorted and made unique here).
void fill_pattern(std::int32_t unknowns,
                  std::vector<std::pair<std::int32_t, std::int32_t>>& coupled,
                  SymmetricPattern& pattern) {
  std::sort(coupled.begin(), coupled.end());
  coupled.erase(std::unique(coupled.begin(), coupled.end()), coupled.end());
  pattern.size = unknowns;
  pattern.column_starts.assign(static_cast<std::size_t>(unknowns) + 1, 0);
  pattern.row_indices.clear();
  pattern.row_indices.reserve(static_cast<std::size_t>(unknowns) + coupled.size());
  std::size_t next = 0;
  for (std::int32_t column = 0; column < unknowns; ++column) {
    pattern.column_starts[static_cast<std::size_t>(column)] =
        static_cast<std::int32_t>(pattern.row_indices.size());
    pattern.row_indices.push_back(column);  // the diagonal comes first
    while (next < coupled.size() && coupled[next].first == column) {
      pattern.row_indices.push_back(coupled[next++].second);
    }
  }
  pattern.column_starts.back() = static_cast<std::int32_t>(pattern.row_indices.size());
}

}  // namespace

void build_scalar_spring_pattern(const Cloth& cloth, ScalarSpringPattern& out) {
  const Eigen::Index n = cloth.vertex_count();
  const SpringSet& springs = cloth.springs();
  out.free_of_vertex.assign(static_cast<std::size_t>(n), -1);
  out.free_vertices.clear();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (cloth.inverse_masses()[i] == 0.0) continue;
    out.free_of_vertex[static_cast<std::size_t>(i)] =
        static_cast<std::int32_t>(out.free_vertices.size());
    out.free_vertices.push_back(static_cast<std::int32_t>(i));
  }
  const auto unknowns = static_cast<std::int32_t>(out.free_vertices.size());
  std::vector<std::pair<std::int32_t, std::int32_t>> coupled;  // (column, row), row > column
  coupled.reserve(springs.size());
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t a = out.free_of_vertex[static_cast<std::size_t>(springs.first[s])];
    const std::int32_t b = out.free_of_vertex[static_cast<std::size_t>(springs.second[s])];
    if (a >= 0 && b >= 0) coupled.emplace_back(std::min(a, b), std::max(a, b));
  }
  const QuadraticBendingMatrix* bending =
      cloth.has_quadratic_bending() ? &cloth.quadratic_bending() : nullptr;
  if (bending != nullptr) {  // a hinge couples all four of its vertices
    for_each_free_entry(
        *bending, out.free_of_vertex,
        [&](std::int32_t, std::int32_t i, std::int32_t j, std::int32_t a, std::int32_t b) {
          if (j > i) coupled.emplace_back(a, b);
        });
  }
  fill_pattern(unknowns, coupled, out.pattern);
  const SymmetricPattern& pattern = out.pattern;
  out.spring_slot.assign(springs.size(), -1);
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t a = out.free_of_vertex[static_cast<std::size_t>(springs.first[s])];
    const std::int32_t b = out.free_of_vertex[static_cast<std::size_t>(springs.second[s])];
    if (a < 0 || b < 0) continue;
    const std::int32_t column = std::min(a, b), row = std::max(a, b);
    const auto begin = pattern.row_indices.begin() + pattern.column_starts[column] + 1;
    const auto end = pattern.row_indices.begin() + pattern.column_starts[column + 1];
    out.spring_slot[s] = std::lower_bound(begin, end, row) - pattern.row_indices.begin();
  }
  out.bending_slot.clear();
  if (bending != nullptr) {
    out.bending_slot.assign(bending->columns.size(), -1);
    for_each_free_entry(
        *bending, out.free_of_vertex,
        [&](std::int32_t k, std::int32_t i, std::int32_t j, std::int32_t a, std::int32_t b) {
          if (j == i) {
            out.bending_slot[static_cast<std::size_t>(k)] = pattern.column_starts[a];
            return;
          }
          // free unknowns are numbered in vertex order, so j > i gives b > a: row b of column a
          const auto begin = pattern.row_indices.begin() + pattern.column_starts[a] + 1;
          const auto end = pattern.row_indices.begin() + pattern.column_starts[a + 1];
          out.bending_slot[static_cast<std::size_t>(k)] =
              std::lower_bound(begin, end, b) - pattern.row_indices.begin();
        });
  }
}

void fill_scalar_spring_matrix(const Cloth& cloth, double h, const ScalarSpringPattern& structure,
                               std::vector<double>& values) {
  const SymmetricPattern& pattern = structure.pattern;
  values.assign(pattern.row_indices.size(), 0.0);
  const double drag = cloth.drag();
  for (std::size_t b = 0; b < structure.free_vertices.size(); ++b) {
    const double m = cloth.masses()[structure.free_vertices[b]];
    values[static_cast<std::size_t>(pattern.column_starts[b])] += m / (h * h) + drag * m / h;
  }
  const SpringSet& springs = cloth.springs();
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const double weight = springs.stiffness[s] + springs.damping[s] / h;
    const std::int32_t a = structure.free_of_vertex[static_cast<std::size_t>(springs.first[s])];
    const std::int32_t b = structure.free_of_vertex[static_cast<std::size_t>(springs.second[s])];
    if (a >= 0) values[static_cast<std::size_t>(pattern.column_starts[a])] += weight;
    if (b >= 0) values[static_cast<std::size_t>(pattern.column_starts[b])] += weight;
    if (structure.spring_slot[s] >= 0) {
      values[static_cast<std::size_t>(structure.spring_slot[s])] -= weight;
    }
  }
  if (cloth.has_membrane()) {
    // The membrane's rest stiffness averaged over the in-plane directions: per face
    // (1.5 μ + 0.5 λ) A d_k·d_l (half the trace of its 2×2 in-plane block at rest), on the
    // diagonal and on its edges' structural springs' entries. An approximation (the membrane
    // couples the coordinates): good enough for quasi-Newton's initial Hessian.
    const MembraneMaterial& material = cloth.membrane();
    const double weight = 1.5 * material.mu() + 0.5 * material.lambda();
    const MembraneFaces& map = cloth.membrane_faces();
    const Faces& faces = cloth.faces();
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
      const MembraneRest rest = membrane_face_rest(map, springs, static_cast<std::size_t>(f));
      const std::array<Eigen::Vector2d, 3> d = membrane_shape_gradients(rest);
      for (int k = 0; k < 3; ++k) {
        const std::int32_t a = structure.free_of_vertex[static_cast<std::size_t>(faces(f, k))];
        if (a >= 0) {
          values[static_cast<std::size_t>(pattern.column_starts[a])] +=
              weight * rest.area * d[static_cast<std::size_t>(k)].squaredNorm();
        }
        const std::int64_t slot = structure.spring_slot[static_cast<std::size_t>(
            map.edge_springs[static_cast<std::size_t>(f)][static_cast<std::size_t>(k)])];
        if (slot >= 0) {
          values[static_cast<std::size_t>(slot)] +=
              weight * rest.area *
              d[static_cast<std::size_t>(k)].dot(d[static_cast<std::size_t>((k + 1) % 3)]);
        }
      }
    }
  }
  if (!structure.bending_slot.empty()) {
    const QuadraticBendingMatrix& bending = cloth.quadratic_bending();
    for (std::size_t k = 0; k < structure.bending_slot.size(); ++k) {
      if (structure.bending_slot[k] < 0) continue;
      values[static_cast<std::size_t>(structure.bending_slot[k])] +=
          cloth.bending_modulus() * bending.values[k];
    }
  }
}

double spring_material_checksum(const Cloth& cloth) {
  const SpringSet& springs = cloth.springs();
  double sum = cloth.drag();
  for (std::size_t s = 0; s < springs.size(); ++s) {
    sum += springs.stiffness[s] * static_cast<double>(1 + s % 7) +
           springs.damping[s] * static_cast<double>(2 + s % 5);
  }
  if (cloth.has_membrane()) {  // its matrix follows the rest lengths too
    for (std::size_t s = 0; s < springs.size(); ++s) {
      sum += springs.rest_length[s] * static_cast<double>(3 + s % 11);
    }
    sum += 5.0 * cloth.membrane().young_modulus + 7.0 * cloth.membrane().poisson_ratio;
  }
  return sum + 3.0 * cloth.bending_modulus();
}

}  // namespace yore
