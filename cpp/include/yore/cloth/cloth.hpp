#pragma once
/// @file cloth.hpp
/// The cloth: topology, springs, masses, state, constraints — the one source of truth that every
/// integrator reads and that strokes change.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "yore/cloth/membrane.hpp"
#include "yore/cloth/mesh.hpp"
#include "yore/cloth/quadratic_bending.hpp"
#include "yore/cloth/springs.hpp"
#include "yore/stroke/subdivision.hpp"

namespace yore {

/// How a vertex moves.
enum class VertexState : std::uint8_t {
  free = 0,    ///< integrated by the dynamics
  fixed = 1,   ///< never moves
  driven = 2,  ///< position prescribed over time (kinematic)
};

/// Kinematic rotation of a set of vertices about an axis at a constant angular speed.
struct RotationDriver {
  std::vector<std::int32_t> vertices;  ///< k driven vertices
  Positions reference;                 ///< k×3, their positions at start_time, metres
  Vec3 center;                         ///< a point on the axis, metres
  Vec3 axis;                           ///< unit axis direction
  double omega = 0.0;                  ///< angular speed, rad/s (right-handed about axis)
  double start_time = 0.0;             ///< simulated time when the driver was attached, s
};

/// How a cloth resists bending.
enum class BendingModel : std::uint8_t {
  springs = 0,  ///< the paper's bending springs across interior edges (bend_stiffness, N/m)
  quadratic = 1,  ///< ½ κ ∫ |∇∇x|² with fitted vertex Hessians (bending_modulus, N·m); no springs
  hinge = 2,  ///< Bergou et al. 2006's hinge energy (bending_modulus, N·m); no springs
};

/// What a cloth on a mesh is made of. The defaults are a bare Cloth's (a physics object: no
/// dissipation unless asked; Python's `Cloth.defaults`); the scenes' material is
/// yore.options.SCENE_MATERIAL.
struct ClothMaterial {
  double stretch_stiffness = 100.0;  ///< N/m per structural spring (0 with a membrane)
  double bend_stiffness = 100.0;     ///< N/m per bending spring (0: none, and with quadratic)
  double damping = 0.0;              ///< N·s/m along each spring
  double drag = 0.0;                 ///< 1/s: a force −drag·m·v on each vertex (still air)
  BendingModel bending = BendingModel::springs;
  double bending_modulus = 0.0;  ///< N·m, with quadratic or hinge bending
  MembraneMaterial membrane;     ///< young_modulus > 0: a membrane resists stretching
};

/// A bare cloth's mass per vertex when none is given, kg.
constexpr double kDefaultVertexMass = 1e-3;
/// A membrane's Poisson's ratio when none is given.
constexpr double kDefaultPoissonRatio = 0.3;

/// Whether `model` is a constant-matrix energy ½ κ Σ_c x_cᵀ Q x_c (quadratic or hinge).
constexpr bool is_quadratic(BendingModel model) {
  return model == BendingModel::quadratic || model == BendingModel::hinge;
}

/// Energy of the cloth, joules.
struct EnergyTerms {
  double kinetic = 0.0;   ///< ½ Σ m |v|²
  double spring = 0.0;    ///< Σ ½ k (ℓ − L)²
  double gravity = 0.0;   ///< −Σ m g·x (zero at the origin)
  double bending = 0.0;   ///< ½ κ Σ_c x_cᵀ Q x_c (quadratic bending; 0 with bending springs)
  double membrane = 0.0;  ///< Σ_faces A W of the membrane (0 without one)
  double total() const { return kinetic + spring + gravity + bending + membrane; }
};

/// Simulated time kept as origin + steps × dt: it neither drifts with round-off nor depends on
/// how a run is split into calls (so a resumed run reproduces a straight one bit for bit).
struct SimulationClock {
  double origin = 0.0;     ///< s, the time when the step size last changed or time was set
  std::int64_t steps = 0;  ///< steps of dt taken since origin
  double dt = 0.0;         ///< s, the step size since origin (0 before the first step)
  /// The current time, s.
  double time() const { return origin + static_cast<double>(steps) * dt; }
};

/// Everything that defines a cloth, for saving and restoring it exactly (Cloth::state /
/// Cloth::from_state). Arrays are as the Cloth's accessors describe them.
struct ClothState {
  Positions positions;     ///< n×3, m
  Positions velocities;    ///< n×3, m/s
  Eigen::VectorXd masses;  ///< n, kg
  Faces faces;             ///< f×3 (empty for a spring network)
  SpringSet springs;       ///< in the cloth's order (summation order, hence round-off, follows it)
  double drag = 0.0;       ///< 1/s
  double stretch_stiffness = 0.0;  ///< N/m, given to structural springs a stroke adds
  double bend_stiffness = 0.0;     ///< N/m, given to bending springs a stroke adds
  double spring_damping = 0.0;     ///< N·s/m, given to springs a stroke adds
  Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> material;  ///< n×2 or empty, m
  std::vector<VertexState> vertex_states;                              ///< n
  std::vector<RotationDriver> drivers;
  SimulationClock clock;
  BendingModel bending = BendingModel::springs;
  double bending_modulus = 0.0;  ///< N·m (quadratic bending only)
  Positions bending_rest;        ///< n×3 rest positions of quadratic bending (m), else empty
  MembraneMaterial membrane;     ///< young_modulus 0: no membrane
  /// the membrane reads the smoothed strain (needs a membrane and the rest state of bending
  /// "quadratic" or "hinge"); false: the faces' constant strain (states saved before it)
  bool membrane_smoothed = false;
};

/// How faces are split (the paper's partial area expansion).
struct SplitOptions {
  /// Rest length of a new spring = expansion × its current length (eq. (1) of the paper: 1.1).
  double expansion = 1.1;
  /// Mass of a new vertex = mass_scale × the mean mass of the face's corners (paper: 0.95).
  double mass_scale = 0.95;
  /// Instead of mass_scale: the new vertex takes its mass from the split face's corners so that
  /// the total mass is unchanged (see Cloth::split_faces).
  bool conserve_mass = false;
  /// A split point with a barycentric weight below this is moved towards the centroid until the
  /// smallest weight equals it, so no child triangle has less than this fraction of the area.
  double min_barycentric = 0.1;
  /// A split whose children would have an angle below this (degrees) is tried at the centroid;
  /// if the centroid too gives such a sliver, the face is skipped and reported.
  double min_angle_degrees = 5.0;
};

/// What split_faces did.
struct SplitReport {
  std::vector<std::int32_t> split_faces;    ///< original indices of the faces split
  std::vector<std::int32_t> faces_skipped;  ///< faces left whole (their children would be slivers)
  std::vector<std::int32_t> new_vertices;
  std::vector<std::int32_t> region_faces;  ///< the 3 children of every split face
  std::int64_t springs_added = 0;
  std::int64_t springs_removed = 0;  ///< bending springs across edges that changed neighbours
  double rest_area_before = 0.0;     ///< m², of the split faces, from their edges' rest lengths
  double rest_area_after = 0.0;      ///< m², of their children, likewise
  std::int64_t moved_inward = 0;     ///< split points moved inward by the min_barycentric rule
  double mass_added = 0.0;           ///< kg, total mass after minus before
};

/// What refine_faces did.
struct RefineReport {
  std::vector<std::int32_t> refined_faces;   ///< original indices of the faces split 1→4
  std::vector<std::int32_t> bisected_faces;  ///< faces split 1→2 by the conforming closure
  std::vector<std::int32_t> new_vertices;    ///< the edge midpoints
  std::vector<std::int32_t> region_faces;    ///< every child of a refined or bisected face
  std::int64_t springs_added = 0;
  std::int64_t springs_removed = 0;  ///< springs whose pair is no longer wired
  double rest_area_before = 0.0;     ///< m², of the changed faces, from their rest lengths
  double rest_area_after = 0.0;      ///< m², of their children, likewise
  double mass_added = 0.0;           ///< kg, total mass after minus before (0 up to round-off)
};

/// A mass-spring cloth (or a plain spring network when built by from_springs).
class Cloth {
 public:
  /// Builds a cloth on a triangle mesh: structural springs on every unique edge, bending springs
  /// across every interior edge between the two opposite vertices (none when bend_stiffness is 0),
  /// rest lengths from `positions`.
  /// positions n×3 (m), faces f×3, masses n (kg; lumped_masses gives them from a density), the
  /// material as ClothMaterial says.
  /// bending: BendingModel::springs (bend_stiffness), or BendingModel::quadratic or ::hinge
  /// (bending_modulus, N·m, rest geometry = `positions`; no bending springs, so bend_stiffness
  /// must be 0; quadratic_bending.hpp says how the two differ).
  /// membrane: with young_modulus > 0, a continuum membrane (membrane.hpp) resists stretching
  /// instead of the structural springs, which are still wired on every edge but with 0 N/m:
  /// they carry the rest edge lengths the membrane's rest triangles are laid out from, and the
  /// damping. stretch_stiffness must then be 0.
  /// Throws std::invalid_argument on a bad mesh, non-positive masses or stretch stiffness
  /// (without a membrane), negative/non-finite bend stiffness, bending modulus, damping or
  /// drag, a bending modulus with bending springs / a bend stiffness with quadratic bending, or
  /// a membrane with a stretch stiffness, a Young's modulus that is not a normal number or a
  /// Poisson's ratio outside (−1, 1).
  Cloth(const Positions& positions, const Faces& faces, const Eigen::VectorXd& masses,
        const ClothMaterial& material = ClothMaterial{});

  /// Builds a plain spring network with no faces. edges s×2; rest_lengths s (m) or empty for the
  /// distances in `positions`. Throws std::invalid_argument on bad indices, repeated pairs,
  /// zero rest lengths and bad material values.
  static Cloth from_springs(const Positions& positions, const Edges& edges,
                            const Eigen::VectorXd& rest_lengths, const Eigen::VectorXd& masses,
                            double stiffness, double damping, double drag);

  /// Number of vertices (mass points).
  std::int64_t vertex_count() const { return m_positions.rows(); }
  /// Number of triangles (0 for a spring network).
  std::int64_t face_count() const { return m_faces.rows(); }

  /// n×3 positions, metres.
  const Positions& positions() const { return m_positions; }
  /// n×3 velocities, m/s.
  const Positions& velocities() const { return m_velocities; }
  /// Replaces all positions (n×3, finite). Throws std::invalid_argument on a bad shape or value.
  void set_positions(const Positions& positions);
  /// Replaces all velocities (n×3, finite); constrained vertices keep their prescribed velocity.
  void set_velocities(const Positions& velocities);
  /// Mutable state for integrators; does not count as an outside edit.
  Positions& integrator_positions() { return m_positions; }
  /// Mutable state for integrators; does not count as an outside edit.
  Positions& integrator_velocities() { return m_velocities; }

  /// n masses, kg.
  const Eigen::VectorXd& masses() const { return m_masses; }
  /// n inverse masses, 1/kg; zero for fixed and driven vertices (they do not respond to forces).
  const Eigen::VectorXd& inverse_masses() const { return m_inverse_masses; }
  /// f×3 vertex indices of the triangles.
  const Faces& faces() const { return m_faces; }
  /// All springs, structure of arrays.
  const SpringSet& springs() const { return m_springs; }
  /// Replaces all rest lengths (s, metres, finite and positive).
  void set_rest_lengths(const Eigen::VectorXd& rest_lengths);
  /// Air drag coefficient, 1/s.
  double drag() const { return m_drag; }

  /// Makes vertices fixed (they never move). Throws std::invalid_argument on an index out of
  /// range or a vertex that is already driven.
  void fix(const std::vector<std::int32_t>& vertices);
  /// Makes vertices kinematic: from now on they rotate about the axis through `center` at omega
  /// rad/s. Throws std::invalid_argument on bad indices, an already constrained vertex, a zero or
  /// non-finite axis, or non-finite values.
  void drive_rotation(const std::vector<std::int32_t>& vertices, const Vec3& center,
                      const Vec3& axis, double omega);
  /// n states: free, fixed or driven.
  const std::vector<VertexState>& vertex_states() const { return m_vertex_states; }
  /// The kinematic drivers, in the order they were attached.
  const std::vector<RotationDriver>& drivers() const { return m_drivers; }
  /// Moves driven vertices to their prescribed positions and velocities at time t (s).
  void apply_drivers(double time);
  /// Writes the driven vertices' prescribed positions and velocities at time t (s) into their
  /// rows of x and v (n×3 each); the other rows are left as they are.
  void driver_state(double time, Positions& x, Positions& v) const;

  /// Simulated time, s.
  double time() const { return m_clock.time(); }
  /// Sets the simulated time (s) without moving anything; see apply_drivers.
  void set_time(double time) { m_clock = SimulationClock{time, 0, 0.0}; }
  /// Advances the clock by one step of dt (s) and returns the new time. Integrators call this
  /// once per step; the time is origin + steps × dt while dt stays the same.
  double advance_time(double dt);
  /// The clock behind time(): for checkpoints that must restore time exactly.
  const SimulationClock& clock() const { return m_clock; }
  /// Restores a clock taken by clock().
  void set_clock(const SimulationClock& clock) { m_clock = clock; }

  /// A copy of everything that defines this cloth (see ClothState).
  ClothState state() const;
  /// Rebuilds a cloth from a state, exactly (same spring order, same clock). Gives a new
  /// topology_version. Throws std::invalid_argument naming the first inconsistency (shapes,
  /// indices out of range, non-finite or non-positive values, constraints and drivers that
  /// disagree).
  static Cloth from_state(const ClothState& state);

  /// Changes whenever the structure of the system changes: vertices, springs or the set of
  /// constrained vertices. Unique across all cloths of the process, so caches derived from the
  /// topology (sparsity patterns, factors) key on it alone.
  std::uint64_t topology_version() const { return m_topology_version; }
  /// Changes on every outside edit of the state or the model (positions, velocities, rest
  /// lengths, constraints); integrators use it to re-baseline their divergence checks.
  std::uint64_t edit_count() const { return m_edit_count; }

  /// CSR incidence: the springs touching vertex i are incident_springs()[k] for k in
  /// [incidence_offsets()[i], incidence_offsets()[i+1]); incident_signs()[k] is +1 where i is
  /// the spring's first end and −1 where it is the second.
  const std::vector<std::int32_t>& incidence_offsets() const { return m_incidence_offsets; }
  const std::vector<std::int32_t>& incident_springs() const { return m_incident_springs; }
  const std::vector<double>& incident_signs() const { return m_incident_signs; }

  /// Splits faces 1→3 (the paper's subdivision): per face, a new vertex at the given point of its
  /// current triangle (moved inward by the documented rules), velocity interpolated, mass
  /// mass_scale × its corners' mean; structural springs to the three corners and bending springs
  /// across the changed edges get rest length expansion × current length (eq. (1)); bending
  /// springs across edges whose neighbours changed are removed. Faces keep their orientation.
  /// Gives a new topology_version. Throws std::invalid_argument on a spring network (no faces),
  /// bad options, out-of-range or repeated faces, or non-finite weights.
  /// With options.conserve_mass the new vertex's mass comes from the corners instead (see
  /// refine_faces for the rule), so the total mass is unchanged.
  /// Mesh surgery by split_faces_1to3 (subdivision.hpp); this rewires springs and masses.
  SplitReport split_faces(const std::vector<FaceSplit>& splits, const SplitOptions& options);

  /// Refines faces 1→4 at edge midpoints with the conforming closure of refine_faces_1to4.
  /// New vertices get the midpoint of their edge's positions, velocities and material
  /// coordinates. Springs keep the rest metric: a new spring's rest (and reference) length is
  /// the distance between its ends in the parent triangle laid out with its structural rest
  /// (reference) lengths as sides; a new bending spring's, across the two rest triangles hinged
  /// at the current dihedral angle. Masses are redistributed so the total is unchanged: each
  /// corner's share of a changed face (its mass × face area / its faces' area, current areas)
  /// moves to the face, which gives it to its children by area, each child a third to each
  /// corner.
  /// Gives a new topology_version (unless nothing is refined). Throws std::invalid_argument on
  /// a spring network or faces out of range.
  RefineReport refine_faces(const std::vector<std::int32_t>& faces);

  /// Rest-pattern (material) coordinates, n×2 (m), or empty when the cloth has none.
  const Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>& material_coordinates() const {
    return m_material;
  }
  /// Sets rest-pattern coordinates (n×2, finite); they are interpolated into split faces.
  void set_material_coordinates(
      const Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>& uv);

  /// Kinetic, spring, gravitational and bending energy for gravity g (m/s²).
  EnergyTerms energy(const Vec3& gravity) const;

  /// The bending model chosen at construction.
  BendingModel bending_model() const { return m_bending; }
  /// Modulus κ of quadratic bending, N·m (0 with bending springs).
  double bending_modulus() const { return m_bending_modulus; }
  /// Whether the quadratic bending term exists (quadratic model and κ > 0): integrators add
  /// κ Q ⊗ I₃ only then.
  bool has_quadratic_bending() const { return is_quadratic(m_bending) && m_bending_modulus > 0.0; }
  /// Q of quadratic bending for the current faces (see quadratic_bending.hpp), rebuilt when the
  /// topology version changed since it was last built; empty (size 0) with bending springs.
  const QuadraticBendingMatrix& quadratic_bending() const;
  /// n×3 rest positions (m) Q is built from (quadratic bending only, else empty): the positions
  /// at construction; a vertex added later gets the point of the rest state that corresponds
  /// to where it was added (see update_quadratic_bending in cloth.cpp).
  const Positions& bending_rest_positions() const {
    quadratic_bending();
    return m_bending_rest;
  }

  /// Whether a membrane resists stretching (see the constructor).
  bool has_membrane() const { return m_membrane.young_modulus > 0.0; }
  /// The membrane's material (young_modulus 0 without one).
  const MembraneMaterial& membrane() const { return m_membrane; }
  /// Per face, the structural springs on its edges (empty without a membrane), rebuilt when the
  /// topology version changed since it was last built.
  const MembraneFaces& membrane_faces() const;
  /// Whether the membrane reads the smoothed strain (membrane.hpp): chosen by
  /// set_membrane_smoothed (it needs bending "quadratic" or "hinge", which keep the rest state)
  /// or restored from a state; a new cloth reads the faces' constant strain.
  bool has_smoothed_membrane() const { return has_membrane() && m_membrane_smoothed; }
  /// Chooses the membrane's strain: smoothed (needs a membrane and bending "quadratic" or
  /// "hinge") or the faces' constant strain (needs a membrane). A change counts as a change of
  /// topology (the elements, and every integrator's matrix pattern, are rebuilt). Throws
  /// std::invalid_argument otherwise.
  void set_membrane_smoothed(bool smoothed);
  /// The membrane's elements at the current rest lengths (empty without a membrane): rebuilt
  /// when the topology or a rest length changed since the last call.
  const MembraneElements& membrane_elements() const;
  /// Clamped rest triangles, collapsed faces and areas of the membrane at the current
  /// positions (all zero without a membrane).
  MembraneStatus membrane_status() const;

  /// Largest time step (s) for which symplectic Euler is linearly stable at the current state:
  /// λ_max of M^{-1/2} H M^{-1/2} (H the PSD-projected spring Hessian at the current positions,
  /// fixed and driven vertices eliminated) by Lanczos (at most 60 iterations, stopped when the
  /// top Ritz value changes by < 1e-6 relative over 5), damping γ of that mode (Rayleigh
  /// quotient of the damping matrix, plus drag), h = (√(γ² + 4λ) − γ) / λ. Tight (within ~5 % of
  /// the limit found by trying on the scenes); Lanczos approaches λ from below, so it is an
  /// estimate from above at this state, and stretching or a stroke can lower the limit later:
  /// use stable_time_step_bound for a step that must stay stable. Returns 0 when k/m overflows,
  /// 2/γ or +inf when nothing elastic moves. O(springs) per iteration; computed on each call.
  double stable_time_step() const;

  /// A state-independent stable time step (s): as stable_time_step but on the graph Laplacian
  /// of the spring stiffnesses (⊗ I₃) and of the damping, which bound every spring's Hessian and
  /// damping whatever the cloth's shape (ℓ >= 0). Lower than stable_time_step (~0.72-0.92 of
  /// the limit found by trying on the scenes), and stays valid as the cloth stretches.
  double stable_time_step_bound() const;

  /// The cheapest and most conservative stable time step (s): Gershgorin bounds on the
  /// Laplacian of M^{-1/2} K M^{-1/2} (ω²) and of the damping plus drag (γ), h = (√(γ² + 4ω²) −
  /// γ) / ω². Never above stable_time_step_bound; exact for one spring, up to ~1.8× low on cloth.
  double gershgorin_time_step() const;

  /// Whether any spring has non-zero damping.
  bool has_spring_damping() const;

 private:
  Cloth() = default;
  void initialise_state(const Positions& positions, const Eigen::VectorXd& masses, double drag);
  void rebuild_incidence();
  void update_inverse_masses();
  // stable_step.cpp: the Lanczos estimate behind stable_time_step and stable_time_step_bound.
  double lanczos_time_step(bool every_state) const;
  static constexpr int kLanczosMaxIterations = 60;
  static constexpr double kLanczosRelativeTolerance = 1e-6;
  void check_constrainable(const std::vector<std::int32_t>& vertices, const char* what) const;
  void update_quadratic_bending() const;
  // Builds the membrane's face→spring map (throws when an edge has no structural spring).
  void check_membrane_rest() const;
  // Takes over a subdivision's vertices (interpolating velocities and material coordinates)
  // and faces; masses and springs are left to the caller.
  void adopt_subdivision(const Subdivision& mesh);
  // Masses of a subdivided mesh with the same total: the mass-conserving rule of refine_faces.
  Eigen::VectorXd conserving_masses(const Subdivision& mesh) const;
  // split_faces without conserve_mass: throws unless every split face's new vertex gets a
  // normal mass up to the material limit (mass_scale × its corners' mean); then appends them.
  void check_split_masses(const std::vector<std::int32_t>& faces,
                          const SplitOptions& options) const;
  void append_split_masses(const std::vector<std::int32_t>& faces, double mass_scale);
  // refine_faces' rest metric (cloth_rewiring.cpp), and its springs: the kept ones and the new
  // pairs in that metric (which gains the new structural springs), built aside from m_springs;
  // fills the report's spring counts.
  struct RestMetric;
  SpringSet refined_springs(const Refinement& surgery, RestMetric& rest_metric,
                            RefineReport& report) const;
  // The end of every change of the mesh (split_faces, refine_faces): incidence, a new topology
  // version, and for quadratic bending the rest positions of the new vertices (at this time).
  void finish_topology_change();

  Positions m_positions;
  Positions m_velocities;
  Eigen::VectorXd m_masses;
  Eigen::VectorXd m_inverse_masses;
  Faces m_faces;
  SpringSet m_springs;
  double m_drag = 0.0;
  // The material new springs get when faces are split.
  double m_stretch_stiffness = 0.0, m_bend_stiffness = 0.0, m_spring_damping = 0.0;
  Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> m_material;
  std::vector<VertexState> m_vertex_states;
  std::vector<RotationDriver> m_drivers;
  std::vector<std::int32_t> m_incidence_offsets;
  std::vector<std::int32_t> m_incident_springs;
  std::vector<double> m_incident_signs;
  SimulationClock m_clock;
  std::uint64_t m_topology_version = 0;
  std::uint64_t m_edit_count = 0;
  BendingModel m_bending = BendingModel::springs;
  double m_bending_modulus = 0.0;
  // Derived from the faces and the rest state, rebuilt lazily per topology version (const
  // accessors extend and rebuild them).
  mutable Positions m_bending_rest;
  mutable QuadraticBendingMatrix m_quadratic;
  mutable std::uint64_t m_quadratic_topology = 0;
  MembraneMaterial m_membrane;
  bool m_membrane_smoothed = false;
  mutable MembraneFaces m_membrane_faces;
  mutable std::uint64_t m_membrane_topology = 0;
  mutable MembraneReference m_membrane_reference;
  mutable std::uint64_t m_membrane_reference_topology = 0;
  mutable MembraneElements m_membrane_elements;
  mutable std::uint64_t m_membrane_elements_topology = 0;
  mutable std::vector<double> m_membrane_elements_rest;  // the rest lengths they were built at
};

/// Largest step h (s) for which symplectic Euler keeps the damped mode x'' = −ω² x − γ x'
/// bounded: (√(γ² + 4ω²) − γ) / ω²; 2/γ (or +inf) at ω² = 0; 0 if either is non-finite.
double symplectic_euler_step_limit(double omega_squared, double gamma);

}  // namespace yore
