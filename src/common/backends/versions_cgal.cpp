// CGAL's version string and the C++ compiler's, for pm_versions_get (versions.h): CGAL is a C++
// header library, so its version macro is only visible from C++.
#include <CGAL/version.h>

#include "common/backends/versions.h"

extern "C" const char *pm_version_cgal(void) { return CGAL_VERSION_STR; }

extern "C" const char *pm_version_cxx_compiler(void) {
#if defined(__clang__)
  return "clang " __clang_version__;
#elif defined(__GNUC__)
  return "g++ " __VERSION__;
#else
  return "unknown";
#endif
}
