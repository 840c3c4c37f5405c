/* The meshers built into the packmesh command. */
#include "cli/cli_methods.h"

#include <string.h>

#include "bubble/bubble.h"
#include "peers/peers.h"
#include "psys/psys.h"

/* In the order `packmesh mesh --help` lists them: ours first, then the classic peers. */
static const pm_method *const methods[] = {
    &bub_method,
    &psys_method,
    &peer_gmsh_frontal,
    &peer_gmsh_delaunay,
    &peer_gmsh_meshadapt,
    &peer_cgal,
};

static int count(void) {
  int n = 0;
  for (size_t i = 0; i < sizeof methods / sizeof methods[0]; ++i) n += methods[i] != NULL;
  return n;
}

int pm_cli_method_count(void) { return count(); }

const pm_method *pm_cli_method_at(int i) {
  int k = 0;
  for (size_t j = 0; j < sizeof methods / sizeof methods[0]; ++j)
    if (methods[j] && k++ == i) return methods[j];
  return NULL;
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
