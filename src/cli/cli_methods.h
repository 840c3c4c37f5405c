/* The table of meshers the packmesh command knows (method.h). */
#ifndef PM_CLI_METHODS_H
#define PM_CLI_METHODS_H

#include <stdio.h>

#include "common/method/method.h"

/* The method named `name`, or NULL. */
const pm_method *pm_cli_method_find(const char *name);

/* Number of methods and the i-th one. */
int pm_cli_method_count(void);
const pm_method *pm_cli_method_at(int i);

/* 1 when the method records its iterations for --trace and --frames. */
int pm_cli_method_traces(const pm_method *m);

/* "bubble, psys, gmsh-frontal, ..." for messages. */
void pm_cli_method_names(char *buf, size_t len);

#endif /* PM_CLI_METHODS_H */
