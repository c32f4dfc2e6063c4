// C++ checks of the core without Python: kernels against finite differences, the wiring of a
// 3×3 grid, and a single oscillator against its analytic solution. Exit code 0 means all passed.
#include "yore/cloth.hpp"
#include "yore/explicit.hpp"
#include "yore/mesh.hpp"
#include "yore/springs.hpp"

#include <cmath>
#include <cstdio>

namespace {

int failures = 0;

void check(bool condition, const char* what) {
  std::printf("%s: %s\n", condition ? "ok  " : "FAIL", what);
  if (!condition) ++failures;
}

void kernels_match_finite_differences() {
  const yore::Vec3 xi(0.3, -0.2, 0.9), xj(-0.5, 0.4, 0.1);
  const double rest = 0.7, k = 12.0, h = 1e-6;
  const yore::Vec3 gradient = yore::spring_gradient(xi, xj, rest, k);
  const yore::Mat3 hessian = yore::spring_hessian(xi, xj, rest, k, false);
  double gradient_error = 0.0, hessian_error = 0.0;
  for (int c = 0; c < 3; ++c) {
    yore::Vec3 step = yore::Vec3::Zero();
    step[c] = h;
    const double numeric = (yore::spring_energy(xi + step, xj, rest, k) -
                            yore::spring_energy(xi - step, xj, rest, k)) / (2 * h);
    gradient_error = std::max(gradient_error, std::abs(numeric - gradient[c]));
    const yore::Vec3 column = (yore::spring_gradient(xi + step, xj, rest, k) -
                               yore::spring_gradient(xi - step, xj, rest, k)) / (2 * h);
    hessian_error = std::max(hessian_error, (column - hessian.col(c)).cwiseAbs().maxCoeff());
  }
  check(gradient_error < 1e-7 * gradient.norm(), "spring gradient = FD of energy");
  check(hessian_error < 1e-7 * hessian.norm(), "spring Hessian = FD of gradient");
}

void grid_wiring() {
  // 3×3 vertices, alternating diagonals meeting at the centre (vertex 4).
  yore::Faces faces(8, 3);
  faces << 0, 1, 4, 0, 4, 3, 1, 2, 4, 2, 5, 4, 3, 4, 6, 4, 7, 6, 4, 5, 8, 4, 8, 7;
  yore::Positions positions(9, 3);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) positions.row(3 * j + i) << i, j, 0.0;
  yore::validate_mesh(positions, faces);
  const yore::MeshConnectivity c = yore::mesh_connectivity(faces);
  check(c.edges.size() == 16, "3x3 grid: 16 structural springs");
  check(c.bending_pairs.size() == 8, "3x3 grid: 8 bending springs");
  check(c.boundary_edge_count == 8, "3x3 grid: 8 boundary edges");
}

void oscillator_period() {
  const double m = 0.2, k = 50.0, amplitude = 0.1;
  yore::Positions positions(2, 3);
  positions << 0, 0, 0, 0, -(1.0 + amplitude), 0;
  yore::Edges edges(1, 2);
  edges << 0, 1;
  yore::Cloth cloth = yore::Cloth::from_springs(positions, edges, Eigen::VectorXd::Ones(1),
                                                Eigen::VectorXd::Constant(2, m), k, 0.0, 0.0);
  cloth.fix({0});
  const double omega = std::sqrt(k / m), period = 2 * M_PI / omega, dt = period / 2000;
  yore::ExplicitIntegrator integrator;
  integrator.advance(cloth, yore::Vec3::Zero(), dt, 2000);
  const double displacement = -cloth.positions()(1, 1) - 1.0;
  // one period later the mass is back near its start: symplectic Euler's error ≈ a·ω·dt/2
  check(std::abs(displacement - amplitude) < amplitude * omega * dt, "oscillator returns after T");
}

void state_round_trip_and_clock() {
  // A driven chain: from_state(state()) continues exactly like the original, and the clock
  // gives the same time whether 30 steps come in one call or in 13 + 17.
  yore::Positions positions(3, 3);
  positions << 0, 0, 0, 0.4, 0, 0, 0.8, 0.1, 0;
  yore::Edges edges(2, 2);
  edges << 0, 1, 1, 2;
  yore::Cloth original = yore::Cloth::from_springs(positions, edges, Eigen::VectorXd(),
                                                   Eigen::VectorXd::Constant(3, 0.1), 40.0,
                                                   0.01, 0.1);
  original.drive_rotation({0}, yore::Vec3(0, 0.2, 0), yore::Vec3(0, 0, 1), 3.0);
  yore::ExplicitIntegrator first, second;
  const yore::Vec3 gravity(0, -9.81, 0);
  first.advance(original, gravity, 1e-3, 13);
  yore::Cloth copy = yore::Cloth::from_state(original.state());
  first.advance(original, gravity, 1e-3, 17);
  second.advance(copy, gravity, 1e-3, 17);
  check(original.positions() == copy.positions() && original.velocities() == copy.velocities(),
        "restored cloth continues bit for bit");
  check(original.time() == 30 * 1e-3, "clock: time = origin + steps * dt");
}

}  // namespace

int main() {
  kernels_match_finite_differences();
  grid_wiring();
  oscillator_period();
  state_round_trip_and_clock();
  std::printf("%d failed\n", failures);
  return failures == 0 ? 0 : 1;
}
