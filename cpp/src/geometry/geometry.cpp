// The CGAL translation unit of yore_geometry. Stroke location and mesh surgery (later issues)
// join it here, so CGAL's flags and compile cost stay out of the physics core.
#include "yore/geometry/geometry.hpp"

#include <CGAL/version.h>

namespace yore {

std::string cgal_version() { return CGAL_VERSION_STR; }

}  // namespace yore
