/* A trial read of a CAD file by OpenCASCADE (through gmsh) in a child process, with a time
 * limit, before the file is read for real in this process: OpenCASCADE's BREP reader loops
 * forever on some damaged files (a record line repeated inside an edge: its integer reads fail
 * and it retries them without end), which no check of ours can rule out. In the child a hang or a
 * crash costs the child only, and the caller gets one line; the same way the TetGen step runs in
 * a child (tet_tetgen.cpp).
 */
#ifndef PM_CAD_PROBE_H
#define PM_CAD_PROBE_H

#include <packmesh/packmesh.h>

/* The time a trial read may take: PM_CAD_PROBE_BASE_S plus PM_CAD_PROBE_PER_MB_S per MB of the
 * file. OpenCASCADE reads BREP at several MB/s (bottle.brep, 0.4 MB, in about 0.1 s), so this is
 * 10 to 100 times the time a sound file needs, under sanitizers too. */
#define PM_CAD_PROBE_BASE_S 10.0
#define PM_CAD_PROBE_PER_MB_S 10.0

/* Read `path` in format `format` ("brep", "step", "iges") in a child process. PM_OK when the
 * child ends by itself (whether or not it could read the file: a plain failure is left to the
 * real read, whose message is better); PM_ERR_PARSE naming the file when the read did not end
 * within the limit or crashed; PM_ERR_BACKEND when no child process could be started. */
pm_status pm_cad_probe(const char *path, const char *format, pm_error *err);

#endif /* PM_CAD_PROBE_H */
