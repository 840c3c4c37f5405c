/* Library versions (versions.h). */
#include "common/backends/versions.h"

#include <cjson/cJSON.h>
#include <embree3/rtcore_config.h>
#include <gmshc.h>
#include <muParserDLL.h>
#include <stdio.h>
#include <string.h>

#include <packmesh/packmesh.h>

#include "common/backends/gmsh_session.h"

static void copy(char *dst, size_t len, const char *src) { snprintf(dst, len, "%s", src ? src : "unknown"); }

/* "... OCC version: 7.6.3; ..." -> "7.6.3". */
static void occ_from_build_info(const char *info, char *out, size_t len) {
  const char *p = info ? strstr(info, "OCC version:") : NULL;
  if (!p) {
    copy(out, len, NULL);
    return;
  }
  p += strlen("OCC version:");
  while (*p == ' ') ++p;
  size_t n = strcspn(p, "; ");
  snprintf(out, len, "%.*s", (int)(n < len ? n : len - 1), p);
}

void pm_versions_get(pm_lib_versions *v) {
  memset(v, 0, sizeof *v);
  copy(v->packmesh, sizeof v->packmesh, pm_version());
  copy(v->gmsh_api, sizeof v->gmsh_api, GMSH_API_VERSION);
  copy(v->gmsh, sizeof v->gmsh, NULL);
  copy(v->occ, sizeof v->occ, NULL);
  if (pm_gmsh_begin(NULL) == PM_OK) {
    pm_gmsh_lock();
    int ierr = 0;
    char *s = NULL;
    gmshOptionGetString("General.Version", &s, &ierr);
    if (!ierr && s) copy(v->gmsh, sizeof v->gmsh, s);
    if (s) gmshFree(s);
    s = NULL;
    gmshOptionGetString("General.BuildInfo", &s, &ierr);
    if (!ierr && s) occ_from_build_info(s, v->occ, sizeof v->occ);
    if (s) gmshFree(s);
    pm_gmsh_unlock();
  }
  copy(v->cgal, sizeof v->cgal, pm_version_cgal());
  /* tetgen.h (libtet1.5-dev) states "Version 1.5" in its banner and defines no macro for it. */
  copy(v->tetgen, sizeof v->tetgen, "1.5 (libtet, tetgen.h banner)");
  copy(v->embree, sizeof v->embree, RTC_VERSION_STRING);
  muParserHandle_t h = mupCreate(muBASETYPE_FLOAT);
  if (h) {
    copy(v->muparser, sizeof v->muparser, mupGetVersion(h));
    mupRelease(h);
  } else {
    copy(v->muparser, sizeof v->muparser, NULL);
  }
  copy(v->cjson, sizeof v->cjson, cJSON_Version());
#if defined(__clang__)
  copy(v->c_compiler, sizeof v->c_compiler, "clang " __clang_version__);
#elif defined(__GNUC__)
  copy(v->c_compiler, sizeof v->c_compiler, "gcc " __VERSION__);
#else
  copy(v->c_compiler, sizeof v->c_compiler, NULL);
#endif
  copy(v->cxx_compiler, sizeof v->cxx_compiler, pm_version_cxx_compiler());
}
