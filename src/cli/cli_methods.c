/* The meshers built into the packmesh command. */
#include "cli/cli_methods.h"

#include <string.h>

#include "bubble/bubble.h"
#include "peers/peers.h"
#include "psys/psys.h"

/* In the order `packmesh mesh --help` lists them: ours first, then the classic peers. `traces`:
 * the method fills in->trace and in->frames (method.h) with its iterations; the peers run to
 * completion inside their libraries and record none, so --trace and --frames are refused for
 * them rather than written empty. */
static const struct {
  const pm_method *method;
  int traces;
} methods[] = {
    {&bub_method, 1},
    {&psys_method, 1},
    {&peer_gmsh_frontal, 0},
    {&peer_gmsh_delaunay, 0},
    {&peer_gmsh_meshadapt, 0},
    {&peer_cgal, 0},
};

static int count(void) { return (int)(sizeof methods / sizeof methods[0]); }

int pm_cli_method_count(void) { return count(); }

const pm_method *pm_cli_method_at(int i) { return i >= 0 && i < count() ? methods[i].method : NULL; }

int pm_cli_method_traces(const pm_method *m) {
  for (int i = 0; i < count(); ++i)
    if (methods[i].method == m) return methods[i].traces;
  return 0;
}

const pm_method *pm_cli_method_find(const char *name) {
  for (int i = 0; i < count(); ++i)
    if (strcmp(pm_cli_method_at(i)->name, name) == 0) return pm_cli_method_at(i);
  return NULL;
}

void pm_cli_method_names(char *buf, size_t len) {
  buf[0] = '\0';
  for (int i = 0; i < count(); ++i) {
    strncat(buf, i ? ", " : "", len - strlen(buf) - 1);
    strncat(buf, pm_cli_method_at(i)->name, len - strlen(buf) - 1);
  }
}
