#pragma once
/// @file geometry.hpp
/// The CGAL side of yore (target yore_geometry): stroke location and mesh surgery live here, so
/// CGAL's headers and its -frounding-math flag stay out of the physics core.

#include <string>

namespace yore {

/// Version of the CGAL headers yore_geometry was compiled with.
std::string cgal_version();

}  // namespace yore
