// Tests of cpp/src/cloth/membrane.cpp and cpp/src/cloth/membrane_elements.cpp
// (cpp/include/yore/cloth/membrane.hpp): St. Venant–Kirchhoff constant-strain triangles and the
// smoothed strain's per-vertex elements — rest layout, closed-form energies, derivatives against
// finite differences, the filtered Hessian's definiteness, and the cloth's membrane wiring.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

#include "helpers.hpp"
#include "yore/cloth/cloth.hpp"
#include "yore/cloth/membrane.hpp"

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

double energy_at(const Face& face, const Vec9& x, Vec9* gradient = nullptr, Mat9* hessian = nullptr,
                 TransverseFilter filter = TransverseFilter::exact) {
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
  CHECK(sliver.area ==
        doctest::Approx(0.5 * 1.0 * yore::kMembraneMinRestHeight * 1.99999).epsilon(1e-14));
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
  yore::Cloth cloth(
      mesh.positions, mesh.faces, Eigen::VectorXd::Constant(9, 0.01),
      yore_test::material(0.0, 0.0, 0.0, 0.0, yore::BendingModel::springs, 0.0, material()));
  REQUIRE(cloth.has_membrane());
  for (std::size_t k = 0; k < cloth.springs().size(); ++k)
    CHECK(cloth.springs().stiffness[k] == 0.0);
  yore::Positions x = mesh.positions;
  x.col(0) *= 1.2;  // uniform stretch: every face has the closed-form energy
  x(4, 2) = 0.05;
  cloth.set_positions(x);
  REQUIRE(cloth.membrane_faces().edge_springs.size() == 8);
  REQUIRE_FALSE(cloth.has_smoothed_membrane());  // bending springs keep no rest state
  const yore::MembraneElements& elements = cloth.membrane_elements();
  REQUIRE(elements.size() == 8);  // the faces alone, each with its whole energy
  const double energy = yore::membrane_energy(elements, material(), x);
  CHECK(cloth.energy(Vec3::Zero()).membrane == energy);
  CHECK(energy > 0.0);
  // the summed gradient against a finite difference of the summed energy at vertex 4
  yore::Positions gradient = yore::Positions::Zero(9, 3);
  yore::MembraneElementWork work;
  CHECK(yore::membrane_add_gradient(elements, material(), x, gradient, work) ==
        doctest::Approx(energy).epsilon(1e-14));
  // central differences with h = 1e-7 m: round-off ε E / h ≈ 1e-9 N dominates; 1e-6 of the
  // largest force is well above it
  const double tolerance = 1e-6 * gradient.cwiseAbs().maxCoeff();
  for (int c = 0; c < 3; ++c) {
    yore::Positions plus = x, minus = x;
    plus(4, c) += 1e-7;
    minus(4, c) -= 1e-7;
    const double numeric = (yore::membrane_energy(elements, material(), plus) -
                            yore::membrane_energy(elements, material(), minus)) /
                           2e-7;
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
  CHECK_THROWS_WITH_AS(
      yore::Cloth(mesh.positions, mesh.faces, masses,
                  yore_test::material(10.0, 0, 0, 0, yore::BendingModel::springs, 0.0, material())),
      doctest::Contains("stretch_stiffness must be 0"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(
      yore::Cloth(
          mesh.positions, mesh.faces, masses,
          yore_test::material(0.0, 0, 0, 0, yore::BendingModel::springs, 0.0, {kYoung, 1.0})),
      doctest::Contains("poisson_ratio must be in (-1, 1)"), std::invalid_argument);
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

namespace {

// A grid over [0, width] × [0, height] whose interior vertices are moved by up to ±30 % of the
// spacing (a fixed pseudo-random sequence): every triangle irregular, none aligned with y.
yore_test::Mesh irregular_mesh(int nx, int ny, double width, double height) {
  yore_test::Mesh mesh = yore_test::grid_mesh(nx, ny, width, height);
  std::uint64_t seed = 0x2545F4914F6CDD1DULL;
  auto next = [&]() {
    seed ^= seed >> 12;
    seed ^= seed << 25;
    seed ^= seed >> 27;
    return static_cast<double>((seed * 0x2545F4914F6CDD1DULL) >> 11) * 0x1.0p-53 - 0.5;
  };
  for (int j = 1; j + 1 < ny; ++j) {
    for (int i = 1; i + 1 < nx; ++i) {
      mesh.positions(j * nx + i, 0) += 0.6 * next() * width / (nx - 1);
      mesh.positions(j * nx + i, 1) += 0.6 * next() * height / (ny - 1);
    }
  }
  return mesh;
}

yore::Cloth smoothed_cloth(const yore_test::Mesh& mesh, const yore::MembraneMaterial& m) {
  yore::Cloth cloth(mesh.positions, mesh.faces,
                    Eigen::VectorXd::Constant(mesh.positions.rows(), 0.01),
                    yore_test::material(0.0, 0.0, 0.0, 0.0, yore::BendingModel::quadratic, 0.0, m));
  cloth.set_membrane_smoothed(true);
  return cloth;
}

}  // namespace

TEST_CASE("an element of three corners is the constant-strain face") {
  const Face face = reference_face();
  const std::array<Eigen::Vector2d, 3> d = yore::membrane_shape_gradients(face.rest);
  yore::MembraneElements elements;
  elements.starts = {0, 3};
  elements.corners = {0, 1, 2};
  for (const auto& dk : d) {
    elements.gradient_u.push_back(dk.x());
    elements.gradient_v.push_back(dk.y());
  }
  elements.area = {face.rest.area};
  const Vec9 x = stack(Vec3(0.01, -0.02, 0.03), Vec3(0.55, 0.05, -0.04), Vec3(0.1, 0.3, 0.02));
  yore::Positions positions(3, 3);
  for (int k = 0; k < 3; ++k) positions.row(k) = x.segment<3>(3 * k).transpose();
  for (const TransverseFilter filter :
       {TransverseFilter::exact, TransverseFilter::clamp, TransverseFilter::abs}) {
    Vec9 gradient;
    Mat9 hessian;
    const double energy = energy_at(face, x, &gradient, &hessian, filter);
    yore::MembraneElementWork work;
    const auto m = material();
    CHECK(yore::membrane_element(elements, 0, positions, m.mu(), m.lambda(), filter, work, true,
                                 true) == doctest::Approx(energy).epsilon(1e-13));
    const double scale = hessian.cwiseAbs().maxCoeff();
    for (int p = 0; p < 3; ++p) {
      CHECK((work.gradient[p] - gradient.segment<3>(3 * p)).norm() <= 1e-12 * gradient.norm());
      for (int q = 0; q <= p; ++q) {
        CHECK((work.blocks[p * (p + 1) / 2 + q] - hessian.block<3, 3>(3 * p, 3 * q))
                  .cwiseAbs()
                  .maxCoeff() <= 1e-12 * scale);
      }
    }
  }
}

TEST_CASE("the smoothed strain is exact for homogeneous deformations and passes the patch test") {
  const yore_test::Mesh mesh = irregular_mesh(9, 7, 0.4, 0.3);
  yore::Cloth cloth = smoothed_cloth(mesh, material());
  REQUIRE(cloth.has_smoothed_membrane());
  const yore::MembraneElements& elements = cloth.membrane_elements();
  CHECK(elements.face_elements == (yore::kMembraneFaceShare > 0.0 ? mesh.faces.rows() : 0));
  // one per vertex (and the faces when they keep a share), each vertex with its subcells
  CHECK(elements.size() ==
        static_cast<std::size_t>(elements.face_elements + mesh.positions.rows()));
  REQUIRE(elements.subcell_starts.size() == elements.size() + 1);
  CHECK(static_cast<Eigen::Index>(elements.subcell_area.size()) == 3 * mesh.faces.rows());
  // the shares sum to the sheet's area
  double area = 0.0;
  for (const double a : elements.area) area += a;
  CHECK(area == doctest::Approx(0.12).epsilon(1e-12));
  // rest, a rigid motion: no energy; an affine stretch then rotation: the area times W
  CHECK(std::abs(cloth.energy(Vec3::Zero()).membrane) <= 1e-20);  // round-off
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.7, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  Eigen::Matrix3d stretch = Eigen::Matrix3d::Identity();
  stretch(0, 0) = 1.1;
  stretch(1, 1) = 0.96;
  stretch(0, 1) = 0.05;  // a shear too
  yore::Positions x = mesh.positions * (rotation * stretch).transpose();
  cloth.set_positions(mesh.positions * rotation.transpose());
  CHECK(std::abs(cloth.energy(Vec3::Zero()).membrane) <= 1e-20);
  cloth.set_positions(x);
  const Eigen::Matrix2d F2 = stretch.topLeftCorner<2, 2>();
  const Eigen::Matrix2d E = 0.5 * (F2.transpose() * F2 - Eigen::Matrix2d::Identity());
  const auto m = material();
  const double W = m.mu() * E.squaredNorm() + 0.5 * m.lambda() * E.trace() * E.trace();
  CHECK(cloth.energy(Vec3::Zero()).membrane == doctest::Approx(0.12 * W).epsilon(1e-10));
  // the patch test: that homogeneous stress is in balance at every interior vertex (the mean
  // runs over exactly the face thirds that make up each vertex's area)
  yore::Positions gradient = yore::Positions::Zero(x.rows(), 3);
  yore::MembraneElementWork work;
  yore::membrane_add_gradient(elements, m, x, gradient, work);
  const double largest = gradient.cwiseAbs().maxCoeff();
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const double u = mesh.positions(i, 0), v = mesh.positions(i, 1);
    if (u > 1e-9 && u < 0.4 - 1e-9 && v > 1e-9 && v < 0.3 - 1e-9) {
      CHECK(gradient.row(i).cwiseAbs().maxCoeff() <= 1e-12 * largest);
    }
  }
}

TEST_CASE("the smoothed strain's gradient and blocks match finite differences") {
  const yore_test::Mesh mesh = irregular_mesh(6, 6, 0.3, 0.3);
  yore::Cloth cloth = smoothed_cloth(mesh, material());
  std::uint64_t seed = 7;
  auto next = [&]() {
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(seed >> 11) * 0x1.0p-53 - 0.5;
  };
  yore::Positions x = mesh.positions;
  x.col(0) *= 1.07;
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    for (int c = 0; c < 3; ++c) x(i, c) += 0.004 * next();
  }
  const yore::MembraneElements& elements = cloth.membrane_elements();
  const auto m = material();
  yore::Positions gradient = yore::Positions::Zero(x.rows(), 3);
  yore::MembraneElementWork work;
  yore::membrane_add_gradient(elements, m, x, gradient, work);
  const double h = 1e-7;
  const double tolerance = 1e-6 * gradient.cwiseAbs().maxCoeff();
  for (const Eigen::Index i : {Eigen::Index{0}, Eigen::Index{14}, Eigen::Index{21}}) {
    for (int c = 0; c < 3; ++c) {
      yore::Positions plus = x, minus = x;
      plus(i, c) += h;
      minus(i, c) -= h;
      const double numeric =
          (yore::membrane_energy(elements, m, plus) - yore::membrane_energy(elements, m, minus)) /
          (2 * h);
      CHECK(std::abs(numeric - gradient(i, c)) < tolerance);
    }
  }
  // one interior vertex's element: its exact blocks against differences of its gradient
  const std::size_t e = static_cast<std::size_t>(elements.face_elements) + 14;
  const auto begin = static_cast<std::size_t>(elements.starts[e]);
  const std::size_t corners = static_cast<std::size_t>(elements.starts[e + 1]) - begin;
  REQUIRE(corners >= 5);
  yore::membrane_element(elements, e, x, m.mu(), m.lambda(), TransverseFilter::exact, work, true,
                         true);
  const std::vector<yore::Mat3> blocks = work.blocks;
  double largest = 0.0;
  for (const auto& block : blocks) largest = std::max(largest, block.cwiseAbs().maxCoeff());
  for (std::size_t q = 0; q < corners; ++q) {
    for (int c = 0; c < 3; ++c) {
      yore::Positions plus = x, minus = x;
      plus(elements.corners[begin + q], c) += h;
      minus(elements.corners[begin + q], c) -= h;
      yore::membrane_element(elements, e, plus, m.mu(), m.lambda(), TransverseFilter::exact, work,
                             true, false);
      const std::vector<Vec3> up(work.gradient.begin(), work.gradient.begin() + corners);
      yore::membrane_element(elements, e, minus, m.mu(), m.lambda(), TransverseFilter::exact, work,
                             true, false);
      for (std::size_t p = 0; p < corners; ++p) {
        const Vec3 numeric = (up[p] - work.gradient[p]) / (2 * h);
        const Vec3 exact = p >= q ? Vec3(blocks[p * (p + 1) / 2 + q].col(c))
                                  : Vec3(blocks[q * (q + 1) / 2 + p].row(c).transpose());
        CHECK((numeric - exact).cwiseAbs().maxCoeff() <= 1e-6 * largest);
      }
    }
  }
}

TEST_CASE("rest lengths set the smoothed metric: a sheet grown by 1.1 rests at 1.1 its size") {
  const yore_test::Mesh mesh = irregular_mesh(7, 6, 0.3, 0.25);
  yore::Cloth cloth = smoothed_cloth(mesh, material());
  const Eigen::VectorXd rest = Eigen::Map<const Eigen::VectorXd>(
      cloth.springs().rest_length.data(), static_cast<Eigen::Index>(cloth.springs().size()));
  cloth.set_rest_lengths(1.1 * rest);
  cloth.set_positions(1.1 * mesh.positions);
  // the stress-free state of the new metric (round-off only, against 0.4 J per 1 % strain)
  CHECK(std::abs(cloth.energy(Vec3::Zero()).membrane) <= 1e-20);
  cloth.set_positions(mesh.positions);  // now compressed by 1/1.1 everywhere
  const double s = 1.0 / 1.1, e = 0.5 * (s * s - 1.0);
  const auto m = material();
  const double W = 2.0 * m.mu() * e * e + 0.5 * m.lambda() * 4.0 * e * e;
  CHECK(cloth.energy(Vec3::Zero()).membrane == doctest::Approx(0.075 * 1.21 * W).epsilon(1e-10));
}

TEST_CASE("the smoothed strain charges a wrinkle along the tension less than the faces") {
  // A sheet stretched along x by 1.1 (ν = 0: no stress across), then a wrinkle z = a sin(k y)
  // running along x: the continuum's energy does not change to second order in a (∂z/∂x = 0,
  // S_yy = 0), so the increment over ½ S_xx a² k² A/2 is ε², the square of the spurious slope
  // the interpolation gives it (its "artificial bending"). Averaged over four phases (their
  // cos² sum to 2 everywhere), over the elements inside [0.06, 0.24]² and over the whole
  // sheet, at 12 points per wavelength.
  const yore_test::Mesh mesh = irregular_mesh(25, 25, 0.3, 0.3);
  const yore::MembraneMaterial no_poisson{kYoung, 0.0};
  yore::Cloth smoothed = smoothed_cloth(mesh, no_poisson);
  yore::Cloth faces(
      mesh.positions, mesh.faces, Eigen::VectorXd::Constant(mesh.positions.rows(), 0.01),
      yore_test::material(0.0, 0.0, 0.0, 0.0, yore::BendingModel::springs, 0.0, no_poisson));
  REQUIRE_FALSE(faces.has_smoothed_membrane());
  const double a = 1e-6, k = 2.0 * M_PI / 0.15;  // 0.15 m: 12 spacings of 12.5 mm
  const double Sxx = 2.0 * no_poisson.mu() * 0.5 * (1.21 - 1.0);
  auto inside = [&](Eigen::Index i) {
    return mesh.positions(i, 0) > 0.06 && mesh.positions(i, 0) < 0.24 &&
           mesh.positions(i, 1) > 0.06 && mesh.positions(i, 1) < 0.24;
  };
  auto epsilon_squared = [&](const yore::Cloth& cloth, bool inner_only) {
    const yore::MembraneElements& elements = cloth.membrane_elements();
    yore::MembraneElementWork work;
    double increment = 0.0, area = 0.0;
    for (int phase = 0; phase < 4; ++phase) {
      yore::Positions flat = mesh.positions, wrinkled = mesh.positions;
      flat.col(0) *= 1.1;
      wrinkled.col(0) *= 1.1;
      for (Eigen::Index i = 0; i < wrinkled.rows(); ++i) {
        wrinkled(i, 2) = a * std::sin(k * mesh.positions(i, 1) + phase * M_PI / 4.0);
      }
      for (std::size_t e = 0; e < elements.size(); ++e) {
        bool keep = true;
        for (auto c = elements.starts[e]; c < elements.starts[e + 1]; ++c) {
          keep = keep && (!inner_only || inside(elements.corners[static_cast<std::size_t>(c)]));
        }
        if (!keep) continue;
        const auto m = no_poisson;
        increment += yore::membrane_element(elements, e, wrinkled, m.mu(), m.lambda(),
                                            TransverseFilter::exact, work, false, false) -
                     yore::membrane_element(elements, e, flat, m.mu(), m.lambda(),
                                            TransverseFilter::exact, work, false, false);
        if (phase == 0) area += elements.area[e];
      }
    }
    return increment / (0.5 * Sxx * a * a * k * k * 2.0 * area);
  };
  const double with_faces = epsilon_squared(faces, true);
  const double with_fit = epsilon_squared(smoothed, true);
  // measured: inside, faces 5.3e-3 and smoothed 2.8e-4 with a 1 % share of the faces; the
  // subcells' penalty adds nothing at second order in the wrinkle's amplitude
  CHECK(with_faces > 1e-3);  // the artefact is there to remove
  CHECK(with_fit < (yore::kMembraneFaceShare + 0.08) * with_faces);
  CHECK(with_fit >= yore::kMembraneFaceShare * with_faces);
  CHECK(with_fit >= 0.0);
  CHECK(epsilon_squared(smoothed, false) <
        (yore::kMembraneFaceShare + 0.08) * epsilon_squared(faces, false));
}
