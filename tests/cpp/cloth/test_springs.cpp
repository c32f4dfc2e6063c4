// Tests of cpp/src/cloth/springs.cpp (cpp/include/yore/cloth/springs.hpp): the per-spring kernels
// (energy, gradient, Hessian, damping force) and the SpringSet structure of arrays.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "yore/cloth/springs.hpp"

using yore::Mat3;
using yore::TransverseFilter;
using yore::Vec3;

namespace {

const Vec3 kXi(0.3, -0.2, 0.9), kXj(-0.5, 0.4, 0.1);  // |xi − xj| = √1.64 ≈ 1.28 m
constexpr double kStiffness = 12.0;

// Central differences have an O(h²) truncation error and an O(ε E / h) round-off error; with
// h = 1e-6 m on O(1) lengths and energies both are ~1e-10, far below the 1e-7 relative bound.
constexpr double kStep = 1e-6;

double fd_gradient_error(double rest) {
  const Vec3 gradient = yore::spring_gradient(kXi, kXj, rest, kStiffness);
  double error = 0.0;
  for (int c = 0; c < 3; ++c) {
    Vec3 step = Vec3::Zero();
    step[c] = kStep;
    const double numeric = (yore::spring_energy(kXi + step, kXj, rest, kStiffness) -
                            yore::spring_energy(kXi - step, kXj, rest, kStiffness)) /
                           (2 * kStep);
    error = std::max(error, std::abs(numeric - gradient[c]));
  }
  return error / gradient.norm();
}

double fd_hessian_error(double rest) {
  const Mat3 hessian = yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::exact);
  double error = 0.0;
  for (int c = 0; c < 3; ++c) {
    Vec3 step = Vec3::Zero();
    step[c] = kStep;
    const Vec3 column = (yore::spring_gradient(kXi + step, kXj, rest, kStiffness) -
                         yore::spring_gradient(kXi - step, kXj, rest, kStiffness)) /
                        (2 * kStep);
    error = std::max(error, (column - hessian.col(c)).cwiseAbs().maxCoeff());
  }
  return error / hessian.norm();
}

}  // namespace

TEST_CASE("spring gradient is the finite difference of the energy, stretched and compressed") {
  CHECK(fd_gradient_error(0.7) < 1e-7);  // stretched: ℓ ≈ 1.28 > L
  CHECK(fd_gradient_error(2.0) < 1e-7);  // compressed
}

TEST_CASE("exact spring Hessian is the finite difference of the gradient") {
  CHECK(fd_hessian_error(0.7) < 1e-7);
  CHECK(fd_hessian_error(2.0) < 1e-7);
}

TEST_CASE("energy and gradient follow ½k(ℓ − L)² on an axis-aligned spring") {
  const Vec3 xi(2.0, 0.0, 0.0), xj(0.0, 0.0, 0.0);
  // ℓ = 2, L = 0.5: E = ½·4·1.5² = 4.5 J, ∇_xi E = k(ℓ − L) x̂ = 6 N along x (exact in binary)
  CHECK(yore::spring_energy(xi, xj, 0.5, 4.0) == 4.5);
  CHECK(yore::spring_gradient(xi, xj, 0.5, 4.0) == Vec3(6.0, 0.0, 0.0));
  // with respect to the other end the gradient is the negative (Newton's third law)
  CHECK(yore::spring_gradient(xj, xi, 0.5, 4.0) == Vec3(-6.0, 0.0, 0.0));
}

TEST_CASE("zero force at rest, translation invariance, zero-length convention") {
  const Vec3 d = kXi - kXj;
  CHECK(yore::spring_gradient(kXi, kXj, d.norm(), kStiffness).norm() < 1e-12);
  CHECK(yore::spring_energy(kXi, kXj, d.norm(), kStiffness) < 1e-24);
  const Vec3 shift(5.0, -3.0, 2.0);
  // the kernels see xi − xj only: shifting both ends changes the result by round-off of the
  // difference (|shift| ε ≈ 1e-15), far below 1e-12
  CHECK((yore::spring_gradient(kXi + shift, kXj + shift, 0.7, kStiffness) -
         yore::spring_gradient(kXi, kXj, 0.7, kStiffness))
            .norm() < 1e-12);
  CHECK(std::abs(yore::spring_energy(kXi + shift, kXj + shift, 0.7, kStiffness) -
                 yore::spring_energy(kXi, kXj, 0.7, kStiffness)) < 1e-12);
  // at zero length: no gradient, and the Hessian k·I, as documented
  CHECK(yore::spring_gradient(kXi, kXi, 0.7, kStiffness) == Vec3::Zero());
  CHECK(yore::spring_hessian(kXi, kXi, 0.7, kStiffness, true) == kStiffness * Mat3::Identity());
  CHECK(yore::spring_damping_force(kXi, kXi, Vec3(1, 2, 3), Vec3::Zero(), 0.5) == Vec3::Zero());
}

TEST_CASE("Hessian eigenvalues: k along the spring, k(1 − L/ℓ) across, filtered when compressed") {
  const double length = (kXi - kXj).norm();
  const auto eigenvalues = [](const Mat3& m) {
    CHECK((m - m.transpose()).norm() == 0.0);  // built from d̂d̂ᵀ and I: symmetric exactly
    return Eigen::SelfAdjointEigenSolver<Mat3>(m).eigenvalues();  // increasing
  };
  // Eigen's symmetric 3×3 solver is accurate to ~1e-15 relative; 1e-12 × k is ample.
  const double tol = 1e-12 * kStiffness;
  SUBCASE("stretched: every filter is the exact Hessian") {
    const double rest = 0.7, transverse = kStiffness * (1 - rest / length);
    const Mat3 exact = yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::exact);
    CHECK(yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::clamp) == exact);
    CHECK(yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::abs) == exact);
    CHECK(yore::spring_hessian(kXi, kXj, rest, kStiffness, true) == exact);
    const Vec3 values = eigenvalues(exact);
    CHECK(values[0] == doctest::Approx(transverse).epsilon(1e-12));
    CHECK(values[1] == doctest::Approx(transverse).epsilon(1e-12));
    CHECK(values[2] == doctest::Approx(kStiffness).epsilon(1e-12));
  }
  SUBCASE("compressed: exact is indefinite, clamp is PSD with 0 across, abs takes |λ|") {
    const double rest = 2.0, transverse = kStiffness * (1 - rest / length);  // < 0
    REQUIRE(transverse < 0.0);
    const Vec3 exact =
        eigenvalues(yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::exact));
    CHECK(exact[0] == doctest::Approx(transverse).epsilon(1e-12));
    const Vec3 clamped =
        eigenvalues(yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::clamp));
    CHECK(std::abs(clamped[0]) < tol);
    CHECK(std::abs(clamped[1]) < tol);
    CHECK(clamped[2] == doctest::Approx(kStiffness).epsilon(1e-12));
    CHECK(yore::spring_hessian(kXi, kXj, rest, kStiffness, true) ==
          yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::clamp));
    const Vec3 absolute =
        eigenvalues(yore::spring_hessian(kXi, kXj, rest, kStiffness, TransverseFilter::abs));
    CHECK(absolute[0] == doctest::Approx(-transverse).epsilon(1e-12));
    CHECK(absolute[1] == doctest::Approx(-transverse).epsilon(1e-12));
  }
}

TEST_CASE("Hessian with a given force equals the spring Hessian at the actual force") {
  const double length = (kXi - kXj).norm();
  for (const double rest : {0.7, 2.0}) {
    const double force = kStiffness * (length - rest);
    for (const TransverseFilter filter :
         {TransverseFilter::exact, TransverseFilter::clamp, TransverseFilter::abs}) {
      // f/(kℓ) = 1 − L/ℓ up to a rounding or two: 1e-13 relative
      const Mat3 expected = yore::spring_hessian(kXi, kXj, rest, kStiffness, filter);
      const Mat3 given = yore::spring_hessian_with_force(kXi, kXj, kStiffness, force, filter);
      CHECK((given - expected).norm() < 1e-13 * expected.norm());
    }
  }
  // a spring of stiffness 0 has no transverse term; zero length gives k·I
  CHECK(yore::spring_hessian_with_force(kXi, kXj, 0.0, 5.0, TransverseFilter::exact) ==
        Mat3::Zero());
  CHECK(yore::spring_hessian_with_force(kXi, kXi, 3.0, 5.0, TransverseFilter::exact) ==
        3.0 * Mat3::Identity());
}

TEST_CASE("damping force acts along the spring on the relative velocity only") {
  const Vec3 xi(1.0, 0.0, 0.0), xj(0.0, 0.0, 0.0);
  const double c = 0.5;
  // relative velocity (2, 3, −1): only its x component (along the spring) is damped
  const Vec3 force = yore::spring_damping_force(xi, xj, Vec3(2, 3, -1), Vec3::Zero(), c);
  CHECK(force == Vec3(-1.0, 0.0, 0.0));
  // a common velocity of both ends is not damped
  CHECK(yore::spring_damping_force(kXi, kXj, Vec3(1, 2, 3), Vec3(1, 2, 3), c) == Vec3::Zero());
  // general direction: f = −c ((vi − vj)·d̂) d̂, parallel to d and dissipative
  const Vec3 vi(0.4, -1.0, 0.2), vj(-0.3, 0.5, 0.1);
  const Vec3 f = yore::spring_damping_force(kXi, kXj, vi, vj, c);
  const Vec3 n = (kXi - kXj).normalized();
  CHECK(f.cross(n).norm() < 1e-15);
  CHECK(f.dot(vi - vj) <= 0.0);
  CHECK((f + c * (vi - vj).dot(n) * n).norm() < 1e-15);
}

TEST_CASE("SpringSet adds, keeps and clears all of its arrays together") {
  yore::SpringSet springs;
  springs.add(0, 1, 1.0, 10.0, 0.1, yore::SpringKind::structural);
  springs.add(1, 2, 2.0, 20.0, 0.2, yore::SpringKind::bending, 2.5);
  springs.add(2, 3, 3.0, 30.0, 0.3, yore::SpringKind::structural);
  REQUIRE(springs.size() == 3);
  // without an explicit reference length it is the rest length
  CHECK(springs.reference_length[0] == 1.0);
  CHECK(springs.reference_length[1] == 2.5);
  springs.keep({1, 0, 1});
  REQUIRE(springs.size() == 2);
  for (const auto* array :
       {&springs.rest_length, &springs.stiffness, &springs.damping, &springs.reference_length})
    CHECK(array->size() == 2);
  CHECK(springs.first == std::vector<std::int32_t>{0, 2});
  CHECK(springs.second == std::vector<std::int32_t>{1, 3});
  CHECK(springs.rest_length == std::vector<double>{1.0, 3.0});
  CHECK(springs.stiffness == std::vector<double>{10.0, 30.0});
  CHECK(springs.kind[1] == yore::SpringKind::structural);
  springs.clear();
  CHECK(springs.size() == 0);
  CHECK(springs.kind.empty());
  CHECK(springs.reference_length.empty());
}
