// The doctest runner of yore_tests: the test cases live in test_<unit>.cpp, one per source unit.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>
