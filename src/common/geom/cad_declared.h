/* What a CAD file declares about its own content, checked against what it holds before it is
 * imported: a truncated or damaged file is then refused with a message naming what is missing,
 * instead of importing as a smaller model (OpenCASCADE imports an IGES file cut in half as 43
 * of its 213 faces, with no error).
 *
 * IGES (fixed 80-column records, ANSI Y14.26M / IGES 5.3 section 2): the Terminate record gives
 * the number of records of each section (Start, Global, Directory, Parameter); each must match
 * the file, the records must come in section order, the Directory must hold whole two-record
 * entries, and each entry's parameter data (its pointer and record count) must lie inside the
 * Parameter section. Compressed and binary IGES are not checked.
 *
 * STEP (ISO 10303-21): the file must begin with "ISO-10303-21;" and end with
 * "END-ISO-10303-21;", each DATA section be closed by ENDSEC;, and every entity instance a
 * record refers to (#n) be defined in the file.
 *
 * OpenCASCADE BREP (BRepTools_ShapeSet's text form): the TShapes section must be there, hold the
 * number of shape records it declares (each a type line, Ve Ed Wi Fa Sh So CS Co, and a
 * sub-shape list ended by '*'), and be followed by the root shape. OpenCASCADE's reader never
 * ends on some damaged records that keep these counts, so a BREP file is then read once in a
 * child process with a time limit (cad_probe.h) before it is read for real.
 */
#ifndef PM_CAD_DECLARED_H
#define PM_CAD_DECLARED_H

#include <packmesh/packmesh.h>

typedef enum pm_cad_kind { PM_CAD_STEP, PM_CAD_IGES, PM_CAD_BREP } pm_cad_kind;

/* PM_OK for a file whose declarations hold (and for any extension but .step .stp .iges .igs
 * .brep); PM_ERR_PARSE naming the file and the first mismatch (or the trial read's failure);
 * PM_ERR_IO when it cannot be read; PM_ERR_NOMEM. */
pm_status pm_cad_check_declared(const char *path, pm_error *err);

/* The counts alone (no trial read) for `len` bytes of text (need not end with '\0') of format
 * `kind`; `path` names the file in messages. */
pm_status pm_cad_check_declared_text(const char *path, pm_cad_kind kind, const char *text,
                                     size_t len, pm_error *err);

#endif /* PM_CAD_DECLARED_H */
