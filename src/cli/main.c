/* The packmesh command: dispatches to the subcommands of cli_commands.c. */
#include <packmesh/packmesh.h>

#include <stdio.h>
#include <string.h>

#include "cli/cli_commands.h"
#include "cli/cli_signal.h"
#include "cli/cli_util.h"

int main(int argc, char **argv) {
  if (argc < 2) return pm_cli_usage(NULL, "no command given");
  const char *cmd = argv[1];
  if (strcmp(cmd, "--version") == 0) {
    printf("packmesh %s\n", pm_version());
    return PM_EXIT_OK;
  }
  if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0) {
    pm_cli_top_usage(stdout);
    return PM_EXIT_OK;
  }
  const pm_cli_command *c = pm_cli_command_find(cmd);
  if (c) {
    pm_cli_signals_install(c->name);
    int code = c->run(argc - 1, argv + 1);
    fflush(stdout);
    pm_finalize();
    return code;
  }
  if (cmd[0] == '-') return pm_cli_usage(NULL, "unknown option '%s'", cmd);
  return pm_cli_usage(NULL, "unknown command '%s'", cmd);
}
