// Tests of cpp/src/membrane.cpp (cpp/include/yore/membrane.hpp): St. Venant–Kirchhoff
// constant-strain triangles — rest layout, closed-form energies, derivatives against finite
// differences, the filtered Hessian's definiteness, and the cloth's membrane wiring.
#include "yore/membrane.hpp"

#include "yore/cloth.hpp"
#include "helpers.hpp"

#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>

using yore::Mat9;
using yore::TransverseFilter;
using yore::Vec3;
using yore::Vec9;

namespace {

constexpr double kYoung = 1000.0, kPoisson = 0.3;

yore::MembraneMaterial material() { return {kYoung, kPoisson}; }

// A rest triangle with sides 0.5 (01), 0.6 (12) and 0.4 (20), and its corners laid flat.
struct Face {
  yore::MembraneRest rest;
  Vec3 x0, x1, x2;
};

Face reference_face() {
  Face face;
  face.rest = yore::membrane_rest(0.5, 0.6, 0.4);
  const double cx = (0.25 + 0.16 - 0.36) / 1.0;  // (l01² + l20² − l12²) / (2 l01)
  face.x0 = Vec3::Zero();
  face.x1 = Vec3(0.5, 0, 0);
  face.x2 = Vec3(cx, std::sqrt(0.16 - cx * cx), 0);
  return face;
}

Vec9 stack(const Vec3& a, const Vec3& b, const Vec3& c) {
  Vec9 out;
  out << a, b, c;
  return out;
}

double energy_at(const Face& face, const Vec9& x, Vec9* gradient = nullptr,
                 Mat9* hessian = nullptr, TransverseFilter filter = TransverseFilter::exact) {
  const auto m = material();
  return yore::membrane_face(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6), face.rest, m.mu(),
                             m.lambda(), gradient, hessian, filter);
}

}  // namespace

TEST_CASE("Lamé constants of a plane-stress sheet") {
  const auto m = material();
  CHECK(m.mu() == doctest::Approx(kYoung / 2.6).epsilon(1e-15));
  CHECK(m.lambda() == doctest::Approx(kYoung * 0.3 / 0.91).epsilon(1e-15));
}

TEST_CASE("the rest triangle from edge lengths: Heron's area, an inverse of its edges") {
  const Face face = reference_face();
  CHECK_FALSE(face.rest.clamped);
  CHECK(face.rest.area == doctest::Approx(yore::area_from_sides(0.5, 0.6, 0.4)).epsilon(1e-14));
  Eigen::Matrix2d Dm;
  Dm << face.x1.head<2>() - face.x0.head<2>(), face.x2.head<2>() - face.x0.head<2>();
  CHECK((Dm * face.rest.inverse - Eigen::Matrix2d::Identity()).norm() < 1e-14);
  // shape-function gradients: a partition of unity (sum 0) that reproduces the rest corners
  const auto d = yore::membrane_shape_gradients(face.rest);
  CHECK((d[0] + d[1] + d[2]).norm() < 1e-14);
  const Eigen::Matrix2d identity = face.x0.head<2>() * d[0].transpose() +
                                   face.x1.head<2>() * d[1].transpose() +
                                   face.x2.head<2>() * d[2].transpose();
  CHECK((identity - Eigen::Matrix2d::Identity()).norm() < 1e-14);
  // a sliver whose sides nearly break the triangle inequality gets the minimum height
  const yore::MembraneRest sliver = yore::membrane_rest(1.0, 1.0, 1.99999);
  CHECK(sliver.clamped);
  CHECK(sliver.area == doctest::Approx(0.5 * 1.0 * yore::kMembraneMinRestHeight * 1.99999)
                           .epsilon(1e-14));
}

TEST_CASE("zero energy and force at rest and after any rigid motion") {
  const Face face = reference_face();
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Vec3 shift(0.3, -2.0, 1.0);
  for (const bool moved : {false, true}) {
    const Vec9 x = moved ? stack(rotation * face.x0 + shift, rotation * face.x1 + shift,
                                 rotation * face.x2 + shift)
                         : stack(face.x0, face.x1, face.x2);
    Vec9 gradient;
    const double energy = energy_at(face, x, &gradient);
    // E is O(ε) of the rest metric: energies ~Y A ε² and forces ~Y ℓ ε are round-off
    CHECK(std::abs(energy) < 1e-20);
    CHECK(gradient.norm() < 1e-10);
  }
}

TEST_CASE("a homogeneous stretch has the closed-form energy; forces balance") {
  const Face face = reference_face();
  const double s = 1.1;  // stretch along the rest x axis, F = diag(s, 1)
  const Vec9 x = stack(Vec3(face.x0.x() * s, face.x0.y(), 0), Vec3(face.x1.x() * s, 0, 0),
                       Vec3(face.x2.x() * s, face.x2.y(), 0));
  Vec9 gradient;
  const double energy = energy_at(face, x, &gradient);
  const double exx = 0.5 * (s * s - 1.0);  // Green strain
  const auto m = material();
  const double expected = face.rest.area * (m.mu() * exx * exx + 0.5 * m.lambda() * exx * exx);
  CHECK(energy == doctest::Approx(expected).epsilon(1e-12));
  // internal forces: no net force (translation invariance) and no net torque
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  for (int k = 0; k < 3; ++k) {
    force += gradient.segment<3>(3 * k);
    torque += x.segment<3>(3 * k).cross(gradient.segment<3>(3 * k));
  }
  CHECK(force.norm() < 1e-10 * gradient.norm());
  CHECK(torque.norm() < 1e-10 * gradient.norm());
}

TEST_CASE("gradient and exact Hessian match finite differences in tension and compression") {
  const Face face = reference_face();
  // a general 3-D deformation (stretched): corners moved off the plane
  for (const double scale : {1.15, 0.8}) {
    CAPTURE(scale);
    const Vec9 x = stack(Vec3(0.01, -0.02, 0.03), Vec3(0.5 * scale, 0.05, -0.04),
                         scale * face.x2 + Vec3(0.0, 0.02, 0.1));
    Vec9 gradient;
    Mat9 hessian;
    energy_at(face, x, &gradient, &hessian, TransverseFilter::exact);
    // central differences, h = 1e-6 m: truncation O(h²) and round-off O(ε E/h) ~1e-10 of
    // the scale; 1e-6 relative is safe and still catches any wrong term
    const double h = 1e-6;
    Vec9 numeric_gradient;
    Mat9 numeric_hessian;
    for (int i = 0; i < 9; ++i) {
      Vec9 step = Vec9::Zero();
      step[i] = h;
      numeric_gradient[i] = (energy_at(face, x + step) - energy_at(face, x - step)) / (2 * h);
      Vec9 gp, gm;
      energy_at(face, x + step, &gp);
      energy_at(face, x - step, &gm);
      numeric_hessian.col(i) = (gp - gm) / (2 * h);
    }
    CHECK((numeric_gradient - gradient).norm() < 1e-6 * gradient.norm());
    CHECK((numeric_hessian - hessian).norm() < 1e-6 * hessian.norm());
    CHECK((hessian - hessian.transpose()).norm() < 1e-9 * hessian.norm());
  }
}

TEST_CASE("under compression the filtered Hessians are positive semidefinite, exact is not") {
  const Face face = reference_face();
  const Vec9 x = stack(face.x0, 0.6 * face.x1, 0.6 * face.x2);  // shrunk to 60 %
  Mat9 exact, clamped, absolute;
  energy_at(face, x, nullptr, &exact, TransverseFilter::exact);
  energy_at(face, x, nullptr, &clamped, TransverseFilter::clamp);
  energy_at(face, x, nullptr, &absolute, TransverseFilter::abs);
  const auto lowest = [](const Mat9& m) {
    return Eigen::SelfAdjointEigenSolver<Mat9>(0.5 * (m + m.transpose())).eigenvalues()[0];
  };
  const double scale = exact.norm();
  CHECK(lowest(exact) < -1e-3 * scale);  // compressed: buckling directions
  // rigid modes give zero eigenvalues: round-off ~1e-15 of the scale, 1e-12 is ample
  CHECK(lowest(clamped) > -1e-12 * scale);
  CHECK(lowest(absolute) > -1e-12 * scale);
  // a collapsed face (all corners on a line) gives finite values
  Vec9 gradient;
  Mat9 hessian;
  const double energy = energy_at(face, stack(Vec3::Zero(), Vec3(0.5, 0, 0), Vec3(0.25, 0, 0)),
                                  &gradient, &hessian, TransverseFilter::clamp);
  CHECK(std::isfinite(energy));
  CHECK(gradient.allFinite());
  CHECK(hessian.allFinite());
}

TEST_CASE("a membrane cloth: 0 N/m structural springs, summed energy and gradient, status") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3, 0.4, 0.4);
  yore::Cloth cloth(mesh.positions, mesh.faces, Eigen::VectorXd::Constant(9, 0.01), 0.0, 0.0,
                    0.0, 0.0, yore::BendingModel::springs, 0.0, material());
  REQUIRE(cloth.has_membrane());
  for (std::size_t k = 0; k < cloth.springs().size(); ++k)
    CHECK(cloth.springs().stiffness[k] == 0.0);
  yore::Positions x = mesh.positions;
  x.col(0) *= 1.2;  // uniform stretch: every face has the closed-form energy
  x(4, 2) = 0.05;
  cloth.set_positions(x);
  const auto& map = cloth.membrane_faces();
  REQUIRE(map.edge_springs.size() == 8);
  const double energy = yore::membrane_energy(cloth.faces(), map, cloth.springs(), material(), x);
  CHECK(cloth.energy(Vec3::Zero()).membrane == energy);
  CHECK(energy > 0.0);
  // the summed gradient against a finite difference of the summed energy at vertex 4
  yore::Positions gradient = yore::Positions::Zero(9, 3);
  CHECK(yore::membrane_add_gradient(cloth.faces(), map, cloth.springs(), material(), x,
                                    gradient) == doctest::Approx(energy).epsilon(1e-14));
  // central differences with h = 1e-7 m: round-off ε E / h ≈ 1e-9 N dominates; 1e-6 of the
  // largest force is well above it
  const double tolerance = 1e-6 * gradient.cwiseAbs().maxCoeff();
  for (int c = 0; c < 3; ++c) {
    yore::Positions plus = x, minus = x;
    plus(4, c) += 1e-7;
    minus(4, c) -= 1e-7;
    const double numeric =
        (yore::membrane_energy(cloth.faces(), map, cloth.springs(), material(), plus) -
         yore::membrane_energy(cloth.faces(), map, cloth.springs(), material(), minus)) / 2e-7;
    CHECK(std::abs(numeric - gradient(4, c)) < tolerance);
  }
  // status: rest area = the grid's, current area larger; crushing a corner face collapses it
  yore::MembraneStatus status = cloth.membrane_status();
  CHECK(status.rest_area == doctest::Approx(0.16).epsilon(1e-12));
  CHECK(status.current_area > status.rest_area);
  CHECK(status.collapsed_faces == 0);
  CHECK(status.clamped_rest_faces == 0);
  x.row(1) = x.row(0);  // squashes every face at vertices 0 and 1 to zero area
  cloth.set_positions(x);
  status = cloth.membrane_status();
  CHECK(status.collapsed_faces >= 1);
}

TEST_CASE("membrane inputs are checked") {
  const yore_test::Mesh mesh = yore_test::grid_mesh(3, 3);
  const Eigen::VectorXd masses = Eigen::VectorXd::Constant(9, 0.01);
  CHECK_THROWS_WITH_AS(yore::Cloth(mesh.positions, mesh.faces, masses, 10.0, 0, 0, 0,
                                   yore::BendingModel::springs, 0.0, material()),
                       doctest::Contains("stretch_stiffness must be 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(yore::Cloth(mesh.positions, mesh.faces, masses, 0.0, 0, 0, 0,
                                   yore::BendingModel::springs, 0.0, {kYoung, 1.0}),
                       doctest::Contains("poisson_ratio must be in (-1, 1)"),
                       std::invalid_argument);
  // a face whose edge has no structural spring
  yore::SpringSet springs;
  springs.add(0, 1, 1.0, 0.0, 0.0, yore::SpringKind::structural);
  springs.add(1, 2, 1.0, 0.0, 0.0, yore::SpringKind::structural);
  springs.add(2, 0, 1.0, 0.0, 0.0, yore::SpringKind::bending);
  yore::Faces face(1, 3);
  face << 0, 1, 2;
  CHECK_THROWS_WITH_AS(yore::membrane_faces(face, springs),
                       doctest::Contains("edge (2, 0) of face 0 has no structural spring"),
                       std::invalid_argument);
}
