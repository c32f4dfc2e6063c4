#pragma once
// Constants shared by the parts of ImplicitIntegrator (implicit.cpp: structure, objective, line
// search, state; newton.cpp: Newton's directions and projections; quasi_newton.cpp: L-BFGS).
// Private to cpp/src.

namespace yore::implicit_detail {

// Most steps the exact projection waits, projected, after repeated rejections.
constexpr int kMaxExactBackoff = 32;
// Most Newton iterations a lagged factorization refactors without trying its kept factor,
// after repeated failed CG runs on it.
constexpr int kMaxLagBackoff = 32;

// Backtracking line search: Armijo constant, halvings before giving up.
constexpr double kArmijo = 1e-4;
constexpr int kMaxBacktracks = 40;
// Relative size, against the sum of the objective's terms' magnitudes (gravity's is large and
// of the other sign), of the energy changes that round-off can hide.
constexpr double kRoundoff = 1e-12;

// Projection shifted (Levenberg–Marquardt on the exact Hessian, μ in units of M/h̃²): the
// smallest μ > 0, the factor μ grows by on an indefinite matrix or a poor model fit, the factor
// it shrinks by on a good fit, and the largest μ tried before giving up. Measured on the 32²
// gathered hanging cloth (120 steps at 1/60 s): from (1e-3, ×4, /4) to (1, ×10, /2) the
// thrown-away factorizations fell from 7.2 to 2.4 per step, the iterations rose from 11.8 to
// 12.7 per step (median 10 both): 15.1 factorizations per step instead of 18.9. A μ below the
// inertia itself hardly changes an indefinite matrix, so climbing from 1e-3 wasted tries.
constexpr double kMinShift = 1.0;
constexpr double kShiftGrowth = 10.0;
constexpr double kShiftShrink = 2.0;
constexpr double kMaxShift = 1e12;

// Projection steihaug: most CG iterations per subproblem; the loosest relative residual CG
// stops at; the trust-region ratio ρ (actual over predicted decrease) above which a trial step
// is taken; below which the radius shrinks to kSteihaugShrink × the step's length; above which
// a step that reached the edge grows it by kSteihaugGrowth. The usual values (Nocedal &
// Wright, ch. 4); on the 32² stiff sheet and gathered cloth forcing 0.01–0.5, acceptance
// 1e-4–0.2, shrink 0.1–0.5 and growth 2–4 were tried: none fewer iterations than these.
constexpr int kMaxSteihaugIterations = 200;
constexpr double kSteihaugForcing = 0.1;
constexpr double kSteihaugAccept = 0.05;
constexpr double kSteihaugShrinkBelow = 0.25;
constexpr double kSteihaugShrink = 0.25;
constexpr double kSteihaugGrowAbove = 0.75;
constexpr double kSteihaugGrowth = 2.0;

}  // namespace yore::implicit_detail
