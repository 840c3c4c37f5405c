/* SIGINT and SIGTERM in the packmesh command: whatever the command is doing, the temporary files
 * and folders it made are removed (atomic_file.h: pm_tmp_remove_all), the helper processes it
 * started are ended, one line "packmesh: <command> interrupted by SIGINT<detail>" goes to stderr,
 * and the process exits with 128 + the signal's number (130 for SIGINT, 143 for SIGTERM), as a
 * shell reports a process ended by that signal.
 *
 * The handler runs on the thread that installed it (a signal another thread receives, an
 * OpenMP worker's, is passed on to it), so that it interrupts the thread that makes and renames
 * files, never runs beside it. In a child process forked without exec (TetGen's helper) the
 * signal ends the child as if no handler were installed, without a message.
 */
#ifndef PM_CLI_SIGNAL_H
#define PM_CLI_SIGNAL_H

/* Install the handler for `command` (its name, for the message). */
void pm_cli_signals_install(const char *command);

/* What the message adds after "interrupted by SIGINT" (for instance "; nothing was written");
 * copied. */
void pm_cli_signals_detail(const char *detail);

#endif /* PM_CLI_SIGNAL_H */
