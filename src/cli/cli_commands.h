/* The packmesh command's top level: the table of its subcommands and what holds for all of them
 * (exit codes, environment, files). `packmesh --help` prints these tables; packmesh(1) and the
 * bash completion are made from the same ones (cli_man.c, cli_completion.c), so that the three
 * cannot say different things. */
#ifndef PM_CLI_COMMANDS_H
#define PM_CLI_COMMANDS_H

#include <stdio.h>

typedef struct pm_cli_command {
  const char *name;
  int (*run)(int argc, char **argv);
  void (*usage)(FILE *f); /* the text of `packmesh NAME --help` (cli.h: its layout) */
  const char *summary;    /* one line: `packmesh --help`, and the NAME line of its man page */
} pm_cli_command;

/* The subcommands, in the order `packmesh --help` lists them; NULL out of range or unknown. */
int pm_cli_command_count(void);
const pm_cli_command *pm_cli_command_at(int i);
const pm_cli_command *pm_cli_command_find(const char *name);

/* A term and what it means: an exit code, an environment variable, a kind of file. */
typedef struct pm_cli_entry {
  const char *term, *text;
} pm_cli_entry;

/* A table of the top level: its heading in --help ("exit codes"), its section in packmesh(1)
 * ("EXIT STATUS") and its entries. */
typedef struct pm_cli_table {
  const char *heading, *section;
  const pm_cli_entry *entries;
  int n;
} pm_cli_table;

/* The tables `packmesh --help` prints after the commands: exit codes, environment, files. */
int pm_cli_table_count(void);
const pm_cli_table *pm_cli_table_at(int i);

/* What packmesh is, in a few words (the NAME line of packmesh(1)); the forms of the top-level
 * command line (NULL-terminated); and the paragraph that introduces the commands. */
extern const char pm_cli_tagline[];
extern const char *const pm_cli_top_forms[];
extern const char pm_cli_top_description[];

/* The extensions the library reads as CAD files (src/common/input/input.c), which INPUT and
 * --geometry take besides case files (.json) and case:NAME: the usage texts and the
 * completion's file filter both use this one list. */
#define PM_CLI_CAD_EXTENSIONS ".step .stp .iges .igs .brep"

/* `packmesh --help`. */
void pm_cli_top_usage(FILE *f);

#endif /* PM_CLI_COMMANDS_H */
