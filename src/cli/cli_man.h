/* The manual pages, in roff (man(7)), made from what --help prints so that the two cannot
 * differ: packmesh(1) from the top level's tables (cli_commands.h), packmesh-NAME(1) from NAME's
 * usage text (cli_usage.h), and from the library's tables the parameters of every method in
 * packmesh-mesh(1), the built-in cases in packmesh-cases(1) and the references in
 * packmesh-references(1). `packmesh help --man [NAME]` prints them; the build writes them into
 * man/man1 of the build folder and `cmake --install` installs them. */
#ifndef PM_CLI_MAN_H
#define PM_CLI_MAN_H

#include <stdio.h>

/* Write the page of the subcommand `command` (NULL: packmesh(1)) to f. 0 on success; -1 for an
 * unknown command, or when its usage text cannot be read (out of memory). */
int pm_cli_man_page(const char *command, FILE *f);

#endif /* PM_CLI_MAN_H */
