/* A command's usage text (the text of `packmesh NAME --help`, laid out as cli.h describes) read
 * into its parts: the forms of its command line, and its body as paragraphs and options in
 * their order. The man pages (cli_man.c) and the bash completion (cli_completion.c) are made
 * from these parts, so that neither holds a second copy of what --help says. */
#ifndef PM_CLI_USAGE_H
#define PM_CLI_USAGE_H

#include <stdio.h>

typedef enum pm_usage_kind {
  PM_USAGE_PROSE,  /* a paragraph */
  PM_USAGE_OPTION, /* an option: its term ("-o, --output DIR") and what it does */
} pm_usage_kind;

typedef struct pm_usage_block {
  pm_usage_kind kind;
  char *term; /* PM_USAGE_OPTION: the names and the value, as written; NULL for prose */
  char *text; /* the lines of the paragraph or of the option's meaning, each trimmed, joined by
                 '\n' ("" for an option that says nothing more) */
} pm_usage_block;

typedef struct pm_usage {
  char **forms; /* each form of the command line on one line, "packmesh mesh INPUT ..." */
  int nforms;
  pm_usage_block *blocks;
  int nblocks;
} pm_usage;

/* Read the text usage() writes. 0 on success; -1 when out of memory or when the text does not
 * start with "usage: " (*u is then empty). */
int pm_usage_read(void (*usage)(FILE *f), pm_usage *u);

void pm_usage_clear(pm_usage *u);

#endif /* PM_CLI_USAGE_H */
