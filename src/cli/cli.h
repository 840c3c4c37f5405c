/* The packmesh command's subcommands. Each takes the arguments after `packmesh` (argv[0] is the
 * subcommand's name) and returns the process exit code:
 *   0  success
 *   1  the work failed (unreadable input, bad value, failed run): one line "packmesh: ..." on
 *      stderr, no output file left
 *   2  usage error (unknown option or parameter, missing argument or one out of its range, one
 *      file named by two options, an option that does not apply to the input or method): one
 *      line on stderr naming where the valid values are listed
 *   130, 143  interrupted by SIGINT, SIGTERM (cli_signal.h): one line, temporaries removed
 * main.c dispatches through a table of the subcommands built into this binary. */
#ifndef PM_CLI_H
#define PM_CLI_H

int pm_cli_quality(int argc, char **argv);
int pm_cli_mesh(int argc, char **argv);
int pm_cli_cases(int argc, char **argv);
int pm_cli_compare(int argc, char **argv);
int pm_cli_demo(int argc, char **argv);
int pm_cli_references(int argc, char **argv);

#endif /* PM_CLI_H */
