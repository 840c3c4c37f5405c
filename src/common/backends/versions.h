/* The versions of packmesh and of every library it is built with, as the running program sees
 * them, for reports that must say exactly what produced their figures. */
#ifndef PM_VERSIONS_H
#define PM_VERSIONS_H

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pm_lib_versions {
  char packmesh[32];
  char gmsh[64];        /* the gmsh library's run-time version (General.Version) */
  char gmsh_api[32];    /* the gmshc.h it was compiled against (GMSH_API_VERSION) */
  char occ[64];         /* OpenCASCADE, as gmsh reports it in General.BuildInfo */
  char cgal[32];        /* CGAL_VERSION_STR */
  char tetgen[64];      /* TetGen has no version macro: the release of the tetgen.h used */
  char embree[32];      /* RTC_VERSION_STRING */
  char muparser[96];    /* mupGetVersion */
  char cjson[32];       /* cJSON_Version */
  char c_compiler[128]; /* __VERSION__ of the C compiler */
  char cxx_compiler[128]; /* __VERSION__ of the C++ compiler */
} pm_lib_versions;

/* Fill v. Starts gmsh (gmsh_session.h) to ask it its version; a field that cannot be had is
 * "unknown". */
void pm_versions_get(pm_lib_versions *v);

/* CGAL's version and the C++ compiler's (versions_cgal.cpp). */
const char *pm_version_cgal(void);
const char *pm_version_cxx_compiler(void);

#ifdef __cplusplus
}
#endif

#endif /* PM_VERSIONS_H */
