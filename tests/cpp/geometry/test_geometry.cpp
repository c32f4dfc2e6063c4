// Tests of cpp/src/geometry/geometry.cpp (cpp/include/yore/geometry/geometry.hpp): the CGAL version
// yore_geometry was compiled with.
#include <doctest/doctest.h>

#include <cctype>
#include <string>

#include "yore/geometry/geometry.hpp"

TEST_CASE("cgal_version is a dotted version number") {
  const std::string version = yore::cgal_version();
  REQUIRE_FALSE(version.empty());
  CHECK(std::isdigit(static_cast<unsigned char>(version.front())));
  const auto dot = version.find('.');
  REQUIRE(dot != std::string::npos);
  CHECK(std::stoi(version.substr(0, dot)) >= 5);  // Debian 12 ships CGAL 5.5; yore needs 5
}
