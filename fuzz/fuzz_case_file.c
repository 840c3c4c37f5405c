/* libFuzzer target: the case-file reader (input.h: pm_case_file_parse) on any bytes, with the
 * checks of the domain (planar_check.c), the planar model and the size expression behind it.
 * Beyond not crashing (ASan + UBSan), each call must keep the reader's contract: on failure no
 * model and no size field, and one line naming the fault; on success a model. See README.md. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "common/geom/geom.h"
#include "common/input/input.h"
#include "common/sizing/sizing.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  pm_model *m = NULL;
  pm_sizing *s = NULL;
  pm_error e = {0};
  pm_status st = pm_case_file_parse("fuzz.json", (const char *)data, size, &m, &s, &e);
  if (st != PM_OK && (m || s || !e.msg[0] || strchr(e.msg, '\n'))) abort();
  if (st == PM_OK && !m) abort();
  pm_sizing_destroy(s);
  pm_model_destroy(m);
  return 0;
}
