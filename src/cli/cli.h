/* The packmesh command's subcommands. Each takes the arguments after `packmesh` (argv[0] is the
 * subcommand's name) and returns the process exit code:
 *   0  success
 *   1  the work failed (unreadable input, bad value, failed run): one line "packmesh: ..." on
 *      stderr, no output file left
 *   2  usage error (unknown option or parameter, missing argument or one out of its range, one
 *      file named by two options, an option that does not apply to the input or method): one
 *      line on stderr naming where the valid values are listed
 *   130, 143  interrupted by SIGINT, SIGTERM (cli_signal.h): one line, temporaries removed
 * main.c dispatches through the table of cli_commands.c.
 *
 * Each subcommand's usage function writes the text `packmesh NAME --help` prints. That text is
 * the one description of the command: its man page and the bash completion are made from it
 * (cli_usage.h reads it), so it follows a layout they rely on:
 *   - it starts with "usage: packmesh NAME ..." and its continuation lines (indented); a line
 *     that starts, after its indent, with "packmesh " is another form of the command;
 *   - an option is a line indented by two or more spaces whose text starts with '-': its names
 *     and value ("-o, --output DIR"), two or more spaces, and what it does, continued on lines
 *     indented further;
 *   - everything else is prose; a blank line separates paragraphs. */
#ifndef PM_CLI_H
#define PM_CLI_H

#include <stdio.h>

int pm_cli_quality(int argc, char **argv);
int pm_cli_mesh(int argc, char **argv);
int pm_cli_cases(int argc, char **argv);
int pm_cli_compare(int argc, char **argv);
int pm_cli_demo(int argc, char **argv);
int pm_cli_references(int argc, char **argv);
int pm_cli_animate(int argc, char **argv);
int pm_cli_help(int argc, char **argv);

void pm_cli_quality_usage(FILE *f);
void pm_cli_mesh_usage(FILE *f);
void pm_cli_cases_usage(FILE *f);
void pm_cli_compare_usage(FILE *f);
void pm_cli_demo_usage(FILE *f);
void pm_cli_references_usage(FILE *f);
void pm_cli_animate_usage(FILE *f);
void pm_cli_help_usage(FILE *f);

#endif /* PM_CLI_H */
