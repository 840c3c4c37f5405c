/* The packmesh command: dispatches to the subcommands of cli.h. */
#include <packmesh/packmesh.h>

#include <stdio.h>
#include <string.h>

#include "cli/cli.h"
#include "cli/cli_signal.h"
#include "cli/cli_util.h"

typedef struct subcommand {
  const char *name;
  int (*run)(int argc, char **argv);
  const char *summary;
} subcommand;

/* The subcommands built into this binary (cli.h declares the full set of DESIGN.md). */
static const subcommand commands[] = {
    {"quality", pm_cli_quality, "measure a mesh file: quality, validity (--json, --csv)"},
    {"mesh", pm_cli_mesh, "mesh an input with one method (--method, --size, -o, --stats)"},
    {"cases", pm_cli_cases, "list the built-in cases (INPUT case:NAME)"},
    {"compare", pm_cli_compare, "run a comparison suite into a folder: CSV, plots, report"},
    {"demo", pm_cli_demo, "run the default comparison on built-in cases (-o DIR)"},
    {"references", pm_cli_references, "the full citations of the papers cited as papers/NNN"},
};
static const int ncommands = (int)(sizeof commands / sizeof commands[0]);

static void help(void) {
  printf("packmesh %s: particle-based meshing (bubble mesh, particle systems) and mesh quality\n\n"
         "usage: packmesh COMMAND [ARGS]\n\ncommands:\n",
         pm_version());
  for (int i = 0; i < ncommands; ++i) printf("  %-10s %s\n", commands[i].name, commands[i].summary);
  printf("\n'packmesh COMMAND --help' describes a command.\n"
         "Exit codes: 0 success, 1 failure (one line on stderr), 2 usage error,\n"
         "130 / 143 interrupted by SIGINT / SIGTERM (nothing half written is left).\n");
}

int main(int argc, char **argv) {
  if (argc < 2) return pm_cli_usage(NULL, "no command given");
  const char *cmd = argv[1];
  if (strcmp(cmd, "--version") == 0) {
    printf("packmesh %s\n", pm_version());
    return PM_EXIT_OK;
  }
  if (strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 || strcmp(cmd, "help") == 0) {
    help();
    return PM_EXIT_OK;
  }
  for (int i = 0; i < ncommands; ++i)
    if (strcmp(cmd, commands[i].name) == 0) {
      pm_cli_signals_install(commands[i].name);
      int code = commands[i].run(argc - 1, argv + 1);
      fflush(stdout);
      pm_finalize();
      return code;
    }
  if (cmd[0] == '-') return pm_cli_usage(NULL, "unknown option '%s'", cmd);
  return pm_cli_usage(NULL, "unknown command '%s'", cmd);
}
