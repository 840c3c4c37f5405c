/* Helpers shared by the subcommands: error lines, option parsing, numbers, and output that is
 * written whole or not at all. */
#ifndef PM_CLI_UTIL_H
#define PM_CLI_UTIL_H

#include <packmesh/packmesh.h>

#include <stddef.h>
#include <stdio.h>

enum { PM_EXIT_OK = 0, PM_EXIT_FAIL = 1, PM_EXIT_USAGE = 2 };

/* Print "packmesh: <message>" on one line to stderr and return PM_EXIT_FAIL. */
int pm_cli_fail(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* The same for a usage error; returns PM_EXIT_USAGE. `cmd` names the subcommand for the hint
 * ("see 'packmesh quality --help'"); NULL for the top level. */
int pm_cli_usage(const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* A usage error whose hint is `see` itself, for errors whose valid values are listed elsewhere
 * than the subcommand's --help: "packmesh: <message> (<see>)"; returns PM_EXIT_USAGE. */
int pm_cli_usage_see(const char *see, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Print a library error (its one-line message) and return PM_EXIT_FAIL. */
int pm_cli_error(const pm_error *e);

/* 1 when arg is the flag --name (no value). */
int pm_cli_flag(const char *arg, const char *name);

/* The arguments of a listing command that takes --json and --help only (`cases`,
 * `references`): *json is set for --json; returns -1 to go on, or the exit code (--help
 * printed by usage() on stdout, or a usage error naming cmd). */
int pm_cli_listing_args(int argc, char **argv, const char *cmd, void (*usage)(FILE *f), int *json);

/* When argv[*i] is the option --name, written "--name VALUE" or "--name=VALUE": set *value,
 * advance *i past it and return 1; return 0 when it is another argument; return -1 when the
 * value is missing (the caller reports a usage error). */
int pm_cli_option(int argc, char **argv, int *i, const char *name, const char **value);

/* Strict number parsing: the whole text must be a number (finite for doubles, in [lo, hi] for
 * integers). Return 1 on success. */
int pm_cli_parse_double(const char *text, double *out);
int pm_cli_parse_long(const char *text, long lo, long hi, long *out);

/* Write len bytes to stdout at once; PM_EXIT_FAIL with a message when stdout fails. */
int pm_cli_emit(const char *text, size_t len);

/* Seconds on a monotonic clock. */
double pm_cli_now(void);

#endif /* PM_CLI_UTIL_H */
