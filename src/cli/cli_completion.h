/* The bash completion of the packmesh command, made from the same tables as --help: the
 * commands (cli_commands.h), each command's options and operands read from its usage text
 * (cli_usage.h), and the library's methods, their parameters and the built-in cases. The
 * script holds all of it as data, so that completing never runs packmesh; the build makes it
 * again from the binary it builds (`packmesh help --bash-completion`). */
#ifndef PM_CLI_COMPLETION_H
#define PM_CLI_COMPLETION_H

#include <stdio.h>

/* Write the script to f. 0 on success; -1 when out of memory. */
int pm_cli_bash_completion(FILE *f);

#endif /* PM_CLI_COMPLETION_H */
