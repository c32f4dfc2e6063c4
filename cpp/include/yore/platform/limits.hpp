/// @file limits.hpp
/// yore's input limits, one table: the C++ core checks its own against these constants, and
/// the Python package reads the whole table (`_core.limits`, `yore.limits.LIMITS`) instead of
/// keeping numbers of its own. Each limit is checked before anything is allocated; the reasons
/// are in docs/limitations.md ("Input limits").
#pragma once

#include <cstdint>

namespace yore {

// -- limits the core checks ---------------------------------------------------------------------
/// Material constants (stiffnesses N/m, damping N·s/m, drag 1/s, bending modulus N·m) and masses
/// (kg) are at most this: far beyond any cloth (a steel wire 1 mm² × 1 cm is 2e7 N/m), and far
/// enough below overflow that energies, forces and k/m stay finite.
inline constexpr double kMaxMaterialValue = 1e12;
/// Most samples one stroke may take (its parts near the cloth, after clipping; ~1 s and ~100 MB).
inline constexpr std::int64_t kMaxStrokeSamples = 1'000'000;
/// Most refinement passes one stroke may ask for: each pass quadruples the band's faces.
inline constexpr int kMaxRefine = 4;
/// Most vertices a mesh may have, generated, read or refined (a stroke's refinement and the
/// pattern mesher's stop here; the Python package keeps refining strokes to fewer).
inline constexpr std::int64_t kMaxMeshVertices = 1'000'000;

/// One row of the table: its name in Python (``yore.limits.LIMITS.<name>``), its value, and
/// whether it is a count (an integer) rather than a quantity.
struct Limit {
  const char* name;
  double value;
  bool integral;
};

/// Every input limit of the library, the core's and the Python package's. Sizes in bytes,
/// lengths in m, times in s.
inline constexpr Limit kLimits[] = {
    // the core's
    {"max_material_value", kMaxMaterialValue, false},
    {"max_stroke_samples", static_cast<double>(kMaxStrokeSamples), true},
    {"max_refine", kMaxRefine, true},
    // meshes: generated or read, and after a stroke's refinement (estimated before it)
    {"max_mesh_vertices", static_cast<double>(kMaxMeshVertices), true},
    {"max_refined_vertices", 250'000, true},
    {"max_state_vertices", 4.0 * kMaxMeshVertices, true},  // a state's cloth: 4 × a mesh
    {"max_pattern_coordinate", 1e6, false},
    // stepping
    {"max_threads", 256, true},
    {"max_steps", 100'000'000, true},
    {"min_dt", 1e-12, false},
    {"max_time", 1e9, false},
    {"max_settle_seconds", 10'000.0, false},
    {"max_smoothing_iterations", 100'000, true},
    // strokes
    {"max_expansion", 10.0, false},
    {"max_mass_scale", 10.0, false},
    {"max_stroke_coordinate", 1e12, false},
    // cameras, pictures and the viewer
    {"max_camera_coordinate", 1e12, false},
    {"max_frame_coordinate", 1e12, false},
    {"max_image_side", 16'384, true},
    {"min_picture_side", 16, true},  // a scene's [camera], yore view --panel
    {"max_image_pixels", 8'388'608, true},
    {"max_animation_frames", 300, true},
    {"max_view_stroke_samples", 100'000, true},
    // files
    {"max_scene_file_bytes", 16.0 * 1024 * 1024, true},
    {"max_mesh_file_bytes", 512.0 * 1024 * 1024, true},
    {"max_state_file_bytes", 2.0 * 1024 * 1024 * 1024, true},
    {"max_integer", 2'147'483'647, true},
    // sweeps
    {"max_cells", 100'000, true},
    {"max_repeats", 1'000, true},
    {"max_sweep_file_bytes", 1024.0 * 1024, true},
    {"max_record_bytes", 1024.0 * 1024, true},
    {"max_meta_bytes", 64.0 * 1024, true},
};

}  // namespace yore
