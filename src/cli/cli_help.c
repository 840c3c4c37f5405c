/* packmesh help: the overview of `packmesh --help`, a command's --help, and what is made from
 * them: the manual pages (cli_man.h) and the bash completion (cli_completion.h).
 *
 *   packmesh help [COMMAND]
 *   packmesh help --man [COMMAND] [-o FILE]
 *   packmesh help --bash-completion [-o FILE]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <packmesh/packmesh.h>
#include <packmesh/packmesh_extended.h>

#include "cli/cli.h"
#include "cli/cli_commands.h"
#include "cli/cli_completion.h"
#include "cli/cli_man.h"
#include "cli/cli_util.h"

void pm_cli_help_usage(FILE *f) {
  fputs("usage: packmesh help [COMMAND]\n"
        "       packmesh help --man [COMMAND] [-o FILE]\n"
        "       packmesh help --bash-completion [-o FILE]\n"
        "\n"
        "Prints the overview of 'packmesh --help', or COMMAND's help as 'packmesh COMMAND --help'\n"
        "does. The manual pages and the bash completion are made from these texts and from the\n"
        "tables behind them (the methods and their parameters, the built-in cases, the\n"
        "references), so that they say what --help says.\n"
        "  --man              the manual page packmesh(1), or packmesh-COMMAND(1), in roff ('man -l\n"
        "                     FILE' shows it)\n"
        "  --bash-completion  the bash completion: commands, options, methods, the --set keys of\n"
        "                     the method given, built-in cases, and files by their extensions\n"
        "  -o, --output FILE  write FILE, whole or not at all, instead of standard output\n"
        "  --help             this text\n"
        "cmake --install puts the pages into share/man/man1 and the completion into\n"
        "share/bash-completion/completions under its prefix. Without installing, 'packmesh help\n"
        "--bash-completion -o ~/.local/share/bash-completion/completions/packmesh' gives the\n"
        "completion to one user.\n",
        f);
}

/* text (len bytes) to stdout, or to `out` through an output set: whole or not at all. */
static int deliver(const char *text, size_t len, const char *out) {
  if (!out) return pm_cli_emit(text, len);
  pm_error e = {0};
  const char *tmp = NULL;
  pm_outputs *set = pm_outputs_create();
  if (!set) return pm_cli_fail("out of memory");
  int rc = PM_EXIT_OK;
  if (pm_outputs_add(set, out, 0, &tmp, &e)) {
    rc = pm_cli_error(&e);
  } else {
    FILE *f = fopen(tmp, "w");
    int bad = !f || fwrite(text, 1, len, f) != len;
    if (f && fclose(f) != 0) bad = 1;
    if (bad)
      rc = pm_cli_fail("cannot write '%s'", out);
    else if (pm_outputs_commit(set, &e))
      rc = pm_cli_error(&e);
  }
  pm_outputs_destroy(set);
  return rc;
}

int pm_cli_help(int argc, char **argv) {
  enum { TEXT, MAN, COMPLETION } what = TEXT;
  const char *command = NULL, *out = NULL;
  for (int i = 1; i < argc;) {
    const char *a = argv[i], *v = NULL;
    int r;
    if (pm_cli_flag(a, "help") || strcmp(a, "-h") == 0) {
      pm_cli_help_usage(stdout);
      return PM_EXIT_OK;
    }
    if (pm_cli_flag(a, "man") || pm_cli_flag(a, "bash-completion")) {
      if (what != TEXT) return pm_cli_usage("help", "--man and --bash-completion exclude each other");
      what = pm_cli_flag(a, "man") ? MAN : COMPLETION;
      ++i;
      continue;
    }
    if (strcmp(a, "-o") == 0) {
      if (i + 1 >= argc) return pm_cli_usage("help", "-o needs a file name");
      out = argv[i + 1];
      i += 2;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "output", &v)) != 0) {
      if (r < 0) return pm_cli_usage("help", "--output needs a file name");
      out = v;
      continue;
    }
    if (a[0] == '-' && a[1]) return pm_cli_usage("help", "unknown option '%s'", a);
    if (command) return pm_cli_usage("help", "one COMMAND expected, got '%s' too", a);
    command = a;
    ++i;
  }
  const pm_cli_command *c = command ? pm_cli_command_find(command) : NULL;
  if (command && !c) {
    char names[256] = "";
    for (int i = 0; i < pm_cli_command_count(); ++i)
      snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s", i ? ", " : "",
               pm_cli_command_at(i)->name);
    return pm_cli_usage("help", "unknown command '%s' (known: %s)", command, names);
  }
  if (what == COMPLETION && command)
    return pm_cli_usage("help", "--bash-completion takes no COMMAND ('%s')", command);
  if (what == TEXT) {
    if (out) return pm_cli_usage("help", "-o applies to --man and --bash-completion");
    if (c)
      c->usage(stdout);
    else
      pm_cli_top_usage(stdout);
    return ferror(stdout) ? pm_cli_fail("cannot write to standard output") : PM_EXIT_OK;
  }
  /* Made in memory first: a file or a pipe gets all of it or nothing. */
  char *text = NULL;
  size_t len = 0;
  FILE *f = open_memstream(&text, &len);
  if (!f) return pm_cli_fail("out of memory");
  int bad = what == MAN ? pm_cli_man_page(command, f) : pm_cli_bash_completion(f);
  if (fclose(f) != 0) bad = 1;
  int rc = bad ? pm_cli_fail("out of memory") : deliver(text, len, out);
  free(text);
  return rc;
}
