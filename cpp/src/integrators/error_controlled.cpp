#include "yore/integrators/error_controlled.hpp"

#include <arkode/arkode_arkstep.h>
#include <cvode/cvode.h>
#include <cvode/cvode_ls.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "yore/cloth/springs.hpp"
#include "yore/platform/errors.hpp"
#include "yore/platform/interrupt.hpp"
#include "yore/platform/timer.hpp"

namespace yore {

namespace {

void check_options(const ErrorControlledOptions& o) {
  auto positive = [](double value, const char* name) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      throw std::invalid_argument(std::string(name) + " must be finite and > 0");
    }
  };
  positive(o.rtol, "rtol");
  positive(o.atol, "atol");
  if (!(o.atol_velocity >= 0.0) || !std::isfinite(o.atol_velocity)) {
    throw std::invalid_argument("atol_velocity must be finite and >= 0 (0: atol)");
  }
  if (o.max_order < 1 || o.max_order > 5) {
    throw std::invalid_argument("max_order must be an integer from 1 to 5 (CVODE's BDF orders)");
  }
  if (o.order < 2 || o.order > 4) {
    throw std::invalid_argument(
        "order must be 2, 3 or 4 (ARKODE's stiffly accurate ESDIRK "
        "tables)");
  }
  if (!(o.max_dt >= 0.0) || !std::isfinite(o.max_dt)) {
    throw std::invalid_argument("max_dt must be finite and >= 0 (0: no limit)");
  }
  if (o.max_steps < 1) throw std::invalid_argument("max_steps must be at least 1");
  if (o.max_nonlinear_iterations < 1 || o.max_nonlinear_iterations > 100) {
    throw std::invalid_argument("max_nonlinear_iterations must be an integer from 1 to 100");
  }
  if (o.projection != HessianProjection::clamp && o.projection != HessianProjection::abs) {
    throw std::invalid_argument(
        "projection must be clamp or abs for the error-controlled "
        "integrators (their iteration matrix must be SPD)");
  }
  positive(o.divergence_energy_factor, "divergence_energy_factor");
}

ImplicitOptions inner_options(const ErrorControlledOptions& o) {
  ImplicitOptions inner;
  inner.method = ImplicitMethod::backward_euler;
  inner.projection = o.projection;
  inner.linear_solver = o.linear_solver;
  if (inner.linear_solver.solver == "pcg") {
    throw std::invalid_argument(
        "the error-controlled integrators need a Cholesky solver "
        "(cholmod or eigen-ldlt): their factor is kept across steps");
  }
  return inner;
}

// The SUNLinearSolver: an "iterative" solver whose solve is one application of the
// preconditioner, which is the exact solve of the reduced system. Declared iterative so that
// SUNDIALS drives it through its preconditioner hooks (setup with jok/jcur and γ), which is
// what keeps a factor across steps until SUNDIALS asks for a new one.
struct SolverContent {
  void* data = nullptr;
  SUNPSetupFn setup = nullptr;
  SUNPSolveFn solve = nullptr;
  int last_flag = 0;
};

SolverContent* content(SUNLinearSolver solver) {
  return static_cast<SolverContent*>(solver->content);
}

SUNLinearSolver make_solver(SUNContext context) {
  SUNLinearSolver solver = SUNLinSolNewEmpty(context);
  if (solver == nullptr) throw std::bad_alloc();
  solver->content = new SolverContent();
  solver->ops->gettype = [](SUNLinearSolver) { return SUNLINEARSOLVER_ITERATIVE; };
  solver->ops->getid = [](SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; };
  solver->ops->setpreconditioner = [](SUNLinearSolver s, void* data, SUNPSetupFn setup,
                                      SUNPSolveFn solve) {
    content(s)->data = data;
    content(s)->setup = setup;
    content(s)->solve = solve;
    return 0;
  };
  // SUNDIALS requires an iterative solver to take a J·v routine; the exact solve needs none.
  solver->ops->setatimes = [](SUNLinearSolver, void*, SUNATimesFn) { return 0; };
  solver->ops->initialize = [](SUNLinearSolver) { return 0; };
  solver->ops->setup = [](SUNLinearSolver s, SUNMatrix) {
    SolverContent* c = content(s);
    c->last_flag = c->setup != nullptr ? c->setup(c->data) : 0;
    return c->last_flag;
  };
  solver->ops->solve = [](SUNLinearSolver s, SUNMatrix, N_Vector x, N_Vector b, realtype tol) {
    SolverContent* c = content(s);
    c->last_flag = c->solve(c->data, b, x, tol, SUN_PREC_LEFT);
    return c->last_flag;
  };
  solver->ops->numiters = [](SUNLinearSolver) { return 1; };
  solver->ops->resnorm = [](SUNLinearSolver) -> realtype { return 0.0; };
  solver->ops->lastflag = [](SUNLinearSolver s) -> sunindextype { return content(s)->last_flag; };
  solver->ops->free = [](SUNLinearSolver s) {
    if (s == nullptr) return 0;
    delete content(s);
    s->content = nullptr;
    SUNLinSolFreeEmpty(s);
    return 0;
  };
  return solver;
}

// y = (x, v) of the free vertices and the absolute tolerance of each component (atol for the
// positions, atol_v for the velocities); nothing free: one dummy unknown at rest, which keeps
// SUNDIALS well-defined.
void load_state(double* y, double* atol, const std::vector<std::int32_t>& free, const Positions& x,
                const Positions& v, double atol_x, double atol_v) {
  const std::size_t free_count = free.size();
  for (std::size_t b = 0; b < free_count; ++b) {
    for (int c = 0; c < 3; ++c) {
      y[3 * b + static_cast<std::size_t>(c)] = x(free[b], c);
      y[3 * (free_count + b) + static_cast<std::size_t>(c)] = v(free[b], c);
      atol[3 * b + static_cast<std::size_t>(c)] = atol_x;
      atol[3 * (free_count + b) + static_cast<std::size_t>(c)] = atol_v;
    }
  }
  if (free_count == 0) {
    y[0] = 0.0;
    atol[0] = atol_x;
  }
}

}  // namespace

/// SUNDIALS' objects of one problem size.
struct ErrorControlledIntegrator::Backend {
  ErrorControlledIntegrator* owner = nullptr;
  ErrorControlledMethod method = ErrorControlledMethod::cvode;
  SUNContext context = nullptr;
  void* memory = nullptr;
  N_Vector y = nullptr, weights = nullptr;
  SUNLinearSolver solver = nullptr;
  sunindextype size = 0;

  ~Backend() {
    if (memory != nullptr) {
      if (method == ErrorControlledMethod::cvode) {
        CVodeFree(&memory);
      } else {
        ARKStepFree(&memory);
      }
    }
    if (solver != nullptr) SUNLinSolFree(solver);
    if (y != nullptr) N_VDestroy(y);
    if (weights != nullptr) N_VDestroy(weights);
    if (context != nullptr) SUNContext_Free(&context);
  }

  static ErrorControlledIntegrator* self(void* data) {
    return static_cast<ErrorControlledIntegrator*>(data);
  }
  // Every callback catches: an exception must not unwind through SUNDIALS' C frames. It is
  // kept and rethrown once SUNDIALS has returned (its failure flag is unrecoverable: -1).
  template <class Work>
  static int guarded(void* data, Work&& work) {
    ErrorControlledIntegrator* owner = self(data);
    try {
      work(owner);
      return 0;
    } catch (...) {
      owner->m_error = std::current_exception();
      return -1;
    }
  }
  static int rhs(realtype t, N_Vector y, N_Vector ydot, void* data) {
    return guarded(data, [&](ErrorControlledIntegrator* owner) {
      owner->right_hand_side(t, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot));
    });
  }
  static int setup(realtype t, N_Vector y, N_Vector, booleantype jok, booleantype* jcur,
                   realtype gamma, void* data) {
    return guarded(data, [&](ErrorControlledIntegrator* owner) {
      bool current = false;
      owner->setup(t, N_VGetArrayPointer(y), jok != SUNFALSE, current, gamma);
      *jcur = current ? SUNTRUE : SUNFALSE;
    });
  }
  static int solve(realtype, N_Vector, N_Vector, N_Vector r, N_Vector z, realtype gamma, realtype,
                   int, void* data) {
    return guarded(data, [&](ErrorControlledIntegrator* owner) {
      owner->solve(N_VGetArrayPointer(r), N_VGetArrayPointer(z), gamma);
    });
  }
  static void error_handler(int, const char* module, const char* function, char* message,
                            void* data) {
    ErrorControlledIntegrator* owner = self(data);
    owner->m_message = std::string(module) + "." + function + ": " + message;
  }

  void check(int flag, const char* what) const {
    if (flag < 0) {
      std::ostringstream msg;
      msg << "SUNDIALS refused " << what << " (flag " << flag << ")";
      throw std::runtime_error(msg.str());
    }
  }

  /// A fresh integrator memory for y (its current values) at t0.
  void create(const ErrorControlledOptions& o, double t0) {
    if (solver == nullptr) solver = make_solver(context);  // the context: ensure_backend's
    if (method == ErrorControlledMethod::cvode) {
      memory = CVodeCreate(CV_BDF, context);
      if (memory == nullptr) throw std::bad_alloc();
      check(CVodeSetErrHandlerFn(memory, error_handler, owner), "the error handler");
      check(CVodeInit(memory, rhs, t0, y), "CVodeInit");
      check(CVodeSVtolerances(memory, o.rtol, weights), "the tolerances");
      check(CVodeSetUserData(memory, owner), "the user data");
      check(CVodeSetMaxOrd(memory, o.max_order), "max_order");
      check(CVodeSetMaxNumSteps(memory, o.max_steps), "max_steps");
      check(CVodeSetMaxStep(memory, o.max_dt), "max_dt");
      check(CVodeSetStabLimDet(memory, SUNTRUE), "stability-limit detection");
      check(CVodeSetMaxNonlinIters(memory, o.max_nonlinear_iterations), "max_nonlinear_iterations");
      check(CVodeSetLinearSolver(memory, solver, nullptr), "the linear solver");
      check(CVodeSetPreconditioner(memory, setup, solve), "the preconditioner hooks");
    } else {
      memory = ARKStepCreate(nullptr, rhs, t0, y, context);
      if (memory == nullptr) throw std::bad_alloc();
      check(ARKStepSetErrHandlerFn(memory, error_handler, owner), "the error handler");
      const ARKODE_DIRKTableID table = o.order == 2   ? ARKODE_TRBDF2_3_3_2
                                       : o.order == 3 ? ARKODE_ARK324L2SA_DIRK_4_2_3
                                                      : ARKODE_ARK436L2SA_DIRK_6_3_4;
      check(ARKStepSetTableNum(memory, table, ARKODE_ERK_NONE), "the ESDIRK table");
      check(ARKStepSVtolerances(memory, o.rtol, weights), "the tolerances");
      check(ARKStepSetUserData(memory, owner), "the user data");
      check(ARKStepSetMaxNumSteps(memory, o.max_steps), "max_steps");
      check(ARKStepSetMaxStep(memory, o.max_dt), "max_dt");
      check(ARKStepSetMaxNonlinIters(memory, o.max_nonlinear_iterations),
            "max_nonlinear_iterations");
      check(ARKStepSetLinearSolver(memory, solver, nullptr), "the linear solver");
      check(ARKStepSetPreconditioner(memory, setup, solve), "the preconditioner hooks");
    }
  }

  void reinit(double t0) {
    if (method == ErrorControlledMethod::cvode) {
      check(CVodeReInit(memory, t0, y), "CVodeReInit");
    } else {
      check(ARKStepReInit(memory, nullptr, rhs, t0, y), "ARKStepReInit");
    }
  }

  /// SUNDIALS' counters of this memory (since its last (re)initialization).
  void counters(ErrorControlledStatistics& s) const {
    long steps = 0, failures = 0, iterations = 0, nonlinear_failures = 0, setups = 0, solves = 0,
         rhs_explicit = 0, rhs_implicit = 0;
    int order = 0;
    realtype current = 0.0, last = 0.0;
    if (memory == nullptr) return;
    if (method == ErrorControlledMethod::cvode) {
      CVodeGetNumSteps(memory, &steps);
      CVodeGetNumErrTestFails(memory, &failures);
      CVodeGetNumNonlinSolvIters(memory, &iterations);
      CVodeGetNumNonlinSolvConvFails(memory, &nonlinear_failures);
      CVodeGetNumLinSolvSetups(memory, &setups);
      CVodeGetNumPrecSolves(memory, &solves);
      CVodeGetNumRhsEvals(memory, &rhs_implicit);
      CVodeGetCurrentOrder(memory, &order);
      CVodeGetCurrentStep(memory, &current);
      CVodeGetLastStep(memory, &last);
    } else {
      ARKStepGetNumSteps(memory, &steps);
      ARKStepGetNumErrTestFails(memory, &failures);
      ARKStepGetNumNonlinSolvIters(memory, &iterations);
      ARKStepGetNumNonlinSolvConvFails(memory, &nonlinear_failures);
      ARKStepGetNumLinSolvSetups(memory, &setups);
      ARKStepGetNumPrecSolves(memory, &solves);
      ARKStepGetNumRhsEvals(memory, &rhs_explicit, &rhs_implicit);
      ARKStepGetCurrentStep(memory, &current);
      ARKStepGetLastStep(memory, &last);
      order = 0;
    }
    s.internal_steps = steps;
    s.error_test_failures = failures;
    s.nonlinear_iterations = iterations;
    s.nonlinear_failures = nonlinear_failures;
    s.linear_setups = setups;
    s.linear_solves = solves;
    s.rhs_evaluations = rhs_explicit + rhs_implicit;
    s.current_order = order;
    s.current_internal_dt = current;
    s.last_internal_dt = last;
  }
};

ErrorControlledIntegrator::ErrorControlledIntegrator(const ErrorControlledOptions& options)
    : m_options((check_options(options), options)),
      m_newton(inner_options(options)),
      m_monitor(options.divergence_energy_factor, options.energy_growth_tolerance) {}

ErrorControlledIntegrator::~ErrorControlledIntegrator() = default;

const char* ErrorControlledIntegrator::name() const {
  return m_options.method == ErrorControlledMethod::cvode ? integrator_name::kCvode
                                                          : integrator_name::kArkode;
}

const SolverStatistics& ErrorControlledIntegrator::solver_statistics() const {
  return m_newton.solver_statistics();
}

namespace {

/// The counters SUNDIALS keeps per memory, added from `from` into `into`.
void add_sundials_counters(const ErrorControlledStatistics& from, ErrorControlledStatistics& into) {
  into.internal_steps += from.internal_steps;
  into.error_test_failures += from.error_test_failures;
  into.nonlinear_iterations += from.nonlinear_iterations;
  into.nonlinear_failures += from.nonlinear_failures;
  into.linear_setups += from.linear_setups;
  into.linear_solves += from.linear_solves;
  into.rhs_evaluations += from.rhs_evaluations;
}

}  // namespace

const ErrorControlledStatistics& ErrorControlledIntegrator::statistics() const {
  ErrorControlledStatistics current;
  if (m_backend) m_backend->counters(current);
  ErrorControlledStatistics& s = m_statistics;
  // this memory's SUNDIALS counters on top of those of the memories folded before
  ErrorControlledStatistics total = m_base;
  add_sundials_counters(current, total);
  s.internal_steps = total.internal_steps;
  s.error_test_failures = total.error_test_failures;
  s.nonlinear_iterations = total.nonlinear_iterations;
  s.nonlinear_failures = total.nonlinear_failures;
  s.linear_setups = total.linear_setups;
  s.linear_solves = total.linear_solves;
  s.rhs_evaluations = total.rhs_evaluations;
  s.current_order = !m_backend                                         ? 0
                    : m_options.method == ErrorControlledMethod::cvode ? current.current_order
                                                                       : m_options.order;
  s.current_internal_dt = current.current_internal_dt;
  if (current.internal_steps > 0) s.last_internal_dt = current.last_internal_dt;
  return s;
}

void ErrorControlledIntegrator::fold_counters() const {
  if (!m_backend) return;
  ErrorControlledStatistics current;
  m_backend->counters(current);
  add_sundials_counters(current, m_base);
  if (current.internal_steps > 0) m_statistics.last_internal_dt = current.last_internal_dt;
}

void ErrorControlledIntegrator::ensure_backend(const Cloth& cloth, const Vec3& gravity) {
  const bool new_topology = cloth.topology_version() != m_topology;
  const bool moved =
      cloth.edit_count() != m_edits || gravity != m_gravity || cloth.time() != m_time;
  if (!new_topology && !moved && !m_restart && m_backend) return;

  if (new_topology) {
    m_free = m_newton.prepare_structure(cloth);
    const Eigen::Index n = cloth.vertex_count();
    m_x.setZero(n, 3);
    m_v.setZero(n, 3);
    m_force.setZero(n, 3);
    m_jacobian_positions.setZero(n, 3);
    const auto dofs = static_cast<Eigen::Index>(3 * m_free.size());
    m_rhs.resize(dofs);
    m_zv.resize(dofs);
    m_rx.resize(dofs);
    m_product.resize(dofs);
  }
  m_x = cloth.positions();  // the fixed rows stay; the driven ones follow each stage's time
  m_v = cloth.velocities();
  m_gravity = gravity;
  const auto size = static_cast<sunindextype>(6 * m_free.size());
  const bool resize = !m_backend || m_backend->size != size || new_topology;
  if (resize) {
    fold_counters();
    m_backend.reset();
    auto backend = std::make_unique<Backend>();
    backend->owner = this;
    backend->method = m_options.method;
    backend->size = size;
    backend->check(SUNContext_Create(nullptr, &backend->context), "a context");
    backend->y = N_VNew_Serial(std::max<sunindextype>(size, 1), backend->context);
    backend->weights = N_VClone(backend->y);
    if (backend->y == nullptr || backend->weights == nullptr) throw std::bad_alloc();
    m_backend = std::move(backend);
  } else {
    fold_counters();
  }
  const double atol_v = m_options.atol_velocity > 0.0 ? m_options.atol_velocity : m_options.atol;
  load_state(N_VGetArrayPointer(m_backend->y), N_VGetArrayPointer(m_backend->weights), m_free, m_x,
             m_v, m_options.atol, atol_v);
  if (resize) {
    m_backend->create(m_options, cloth.time());
  } else {
    m_backend->reinit(cloth.time());
  }
  m_topology = cloth.topology_version();
  m_edits = cloth.edit_count();
  m_time = cloth.time();
  m_restart = false;
  ++m_statistics.restarts;
}

void ErrorControlledIntegrator::load(double t, const double* y) {
  const std::size_t free_count = m_free.size();
  for (std::size_t b = 0; b < free_count; ++b) {
    for (int c = 0; c < 3; ++c) {
      m_x(m_free[b], c) = y[3 * b + static_cast<std::size_t>(c)];
      m_v(m_free[b], c) = y[3 * (free_count + b) + static_cast<std::size_t>(c)];
    }
  }
  if (!m_cloth->drivers().empty()) m_cloth->driver_state(t, m_x, m_v);
}

void ErrorControlledIntegrator::right_hand_side(double t, const double* y, double* ydot) {
  poll_interrupt();
  const Stopwatch start;
  const std::size_t free_count = m_free.size();
  if (free_count == 0) {
    ydot[0] = 0.0;
    return;
  }
  load(t, y);
  const Cloth& cloth = *m_cloth;
  const SpringSet& springs = cloth.springs();
  m_force.setZero();
  // The explicit integrator's forces (explicit.cpp): elastic along the spring, damping of the
  // closing speed along the current direction.
  for (std::size_t s = 0; s < springs.size(); ++s) {
    const std::int32_t i = springs.first[s], j = springs.second[s];
    const Vec3 d = m_x.row(i) - m_x.row(j);
    const double length = d.norm();
    if (length == 0.0) continue;
    const double inverse_length = 1.0 / length;
    double scale = -springs.stiffness[s] * (length - springs.rest_length[s]) * inverse_length;
    if (springs.damping[s] > 0.0) {
      const double closing = (m_v.row(i) - m_v.row(j)).dot(d) * inverse_length;
      scale -= springs.damping[s] * closing * inverse_length;
    }
    const Vec3 f = scale * d;
    m_force.row(i) += f.transpose();
    m_force.row(j) -= f.transpose();
  }
  if (cloth.has_quadratic_bending()) {
    quadratic_bending_gradient(cloth.quadratic_bending(), cloth.bending_modulus(), m_x, m_bending);
    m_force -= m_bending;
  }
  if (cloth.has_membrane()) {
    m_bending.resize(m_x.rows(), 3);  // no allocation once sized
    m_bending.setZero();
    membrane_add_gradient(cloth.membrane_elements(), cloth.membrane(), m_x, m_bending,
                          m_membrane_work);
    m_force -= m_bending;
  }
  const double drag = cloth.drag();
  const Eigen::VectorXd& inverse_mass = cloth.inverse_masses();
  for (std::size_t b = 0; b < free_count; ++b) {
    const std::int32_t i = m_free[b];
    for (int c = 0; c < 3; ++c) {
      const double v = m_v(i, c);
      ydot[3 * b + static_cast<std::size_t>(c)] = v;
      ydot[3 * (free_count + b) + static_cast<std::size_t>(c)] =
          inverse_mass[i] * m_force(i, c) + m_gravity[c] - drag * v;
    }
  }
  m_statistics.rhs_seconds += start.seconds();
}

void ErrorControlledIntegrator::setup(double t, const double* y, bool jacobian_ok,
                                      bool& jacobian_current, double gamma) {
  poll_interrupt();
  const Stopwatch start;
  if (!jacobian_ok || m_stiffness.empty()) {
    load(t, y);
    m_jacobian_positions = m_x;
    ++m_statistics.jacobian_evaluations;
    jacobian_current = true;
  } else {
    jacobian_current = false;
  }
  m_newton.factor_iteration_matrix(*m_cloth, m_jacobian_positions, gamma, m_stiffness);
  m_setup_gamma = gamma;
  m_statistics.setup_seconds += start.seconds();
}

void ErrorControlledIntegrator::solve(const double* r, double* z, double gamma) {
  const Stopwatch start;
  const std::size_t free_count = m_free.size();
  if (free_count == 0) {
    z[0] = r[0];
    return;
  }
  const auto dofs = static_cast<Eigen::Index>(3 * free_count);
  const double g = m_setup_gamma;
  const Eigen::VectorXd& masses = m_cloth->masses();
  for (Eigen::Index k = 0; k < dofs; ++k) m_rx[k] = r[k];
  // (M + γ(C + drag M) + γ²H) z_v = M r_v − γ H r_x, i.e. V z_v = (M r_v − γ H r_x)/γ².
  symmetric_multiply(m_newton.pattern(), m_stiffness.data(), m_rx, m_product);
  for (Eigen::Index k = 0; k < dofs; ++k) {
    const double m = masses[m_free[static_cast<std::size_t>(k / 3)]];
    m_rhs[k] = (m * r[dofs + k] - g * m_product[k]) / (g * g);
  }
  m_newton.solve_iteration_matrix(m_rhs.data(), m_zv.data());
  // The factor is of γ at its setup; SUNDIALS' own direct solvers scale the correction by
  // 2/(1 + γ/γ_setup) when γ has changed since (CVODE and ARKODE's "solution scaling").
  const double scale = gamma == g ? 1.0 : 2.0 / (1.0 + gamma / g);
  for (Eigen::Index k = 0; k < dofs; ++k) {
    z[k] = scale * (r[k] + g * m_zv[k]);
    z[dofs + k] = scale * m_zv[k];
  }
  m_statistics.solve_seconds += start.seconds();
}

void ErrorControlledIntegrator::interval(Cloth& cloth, const Vec3& gravity, double dt) {
  ensure_backend(cloth, gravity);
  SimulationClock next = cloth.clock();
  if (next.dt != dt) next = SimulationClock{next.time(), 0, dt};
  ++next.steps;
  const double target = next.time();
  m_error = nullptr;
  m_message.clear();
  realtype reached = cloth.time();
  int flag = 0;
  void* memory = m_backend->memory;
  if (m_options.method == ErrorControlledMethod::cvode) {
    m_backend->check(CVodeSetStopTime(memory, target), "the stop time");
    flag = CVode(memory, target, m_backend->y, &reached, CV_NORMAL);
  } else {
    m_backend->check(ARKStepSetStopTime(memory, target), "the stop time");
    flag = ARKStepEvolve(memory, target, m_backend->y, &reached, ARK_NORMAL);
  }
  if (m_error) {
    m_restart = true;
    std::rethrow_exception(m_error);
  }
  if (flag < 0) {
    m_restart = true;
    const ErrorControlledStatistics& s = statistics();
    std::ostringstream msg;
    const bool too_much = flag == CV_TOO_MUCH_WORK;  // == ARK_TOO_MUCH_WORK (-1)
    msg << "simulation diverged at step " << m_statistics.steps << " (t = " << reached
        << " s, output interval dt = " << dt << " s, " << name() << " integrator): ";
    if (too_much) {
      msg << "more than max_steps = " << m_options.max_steps
          << " internal steps in one output interval";
    } else {
      msg << "SUNDIALS could not take a step (" << (m_message.empty() ? "flag " : m_message)
          << (m_message.empty() ? std::to_string(flag) : "") << ")";
    }
    msg << "; the last internal step was " << s.last_internal_dt
        << " s, tolerance rtol = " << m_options.rtol << ", atol = " << m_options.atol
        << ". Loosen the tolerance, raise max_steps, or check the forces.";
    throw SimulationDiverged(msg.str(), m_statistics.steps, reached, dt, s.current_internal_dt);
  }
  // y → the cloth's free vertices; the clock advances by dt exactly as the other integrators'.
  const double* y = N_VGetArrayPointer(m_backend->y);
  Positions& x = cloth.integrator_positions();
  Positions& v = cloth.integrator_velocities();
  const std::size_t free_count = m_free.size();
  for (std::size_t b = 0; b < free_count; ++b) {
    for (int c = 0; c < 3; ++c) {
      x(m_free[b], c) = y[3 * b + static_cast<std::size_t>(c)];
      v(m_free[b], c) = y[3 * (free_count + b) + static_cast<std::size_t>(c)];
    }
  }
  const double now = cloth.advance_time(dt);
  cloth.apply_drivers(now);
  m_time = now;
  if (reached != target) m_restart = true;  // SUNDIALS stopped elsewhere: start afresh there
  ++m_statistics.steps;
}

void ErrorControlledIntegrator::advance(Cloth& cloth, const Vec3& gravity, double dt,
                                        std::int64_t steps) {
  check_advance_arguments(dt, gravity, steps);
  m_cloth = &cloth;
  advance_checked(
      cloth, gravity, dt, steps, m_monitor, {name(), Remedy::tolerance}, m_checkpoint_positions,
      m_checkpoint_velocities, [&] { interval(cloth, gravity, dt); },
      [&] { return m_statistics.steps; }, [&] { m_restart = true; });
}

}  // namespace yore
