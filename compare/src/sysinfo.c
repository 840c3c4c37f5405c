/* What a report says about where it was made: library versions (versions.h), the machine
 * (uname, /proc/cpuinfo, /proc/meminfo), gnuplot's version and the Debian packages of the
 * libraries when dpkg-query is there. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include "compare/src/study.h"

/* The first line of a helper's stdout, "" when it cannot run. */
static void first_line(char *const argv[], int need_success, char *out, size_t len) {
  out[0] = '\0';
  char *text = NULL;
  int ws = 0, to = 0;
  if (pm_cmp_capture(argv, NULL, 10, &text, NULL, &ws, &to) != 0) return;
  if (!to && WIFEXITED(ws) && (!need_success || WEXITSTATUS(ws) == 0)) {
    text[strcspn(text, "\n")] = '\0';
    snprintf(out, len, "%s", text);
  }
  free(text);
}

void pm_cmp_sysinfo_get(pm_cmp_sysinfo *si) {
  memset(si, 0, sizeof *si);
  pm_versions_get(&si->lib);
  struct utsname u;
  if (uname(&u) == 0)
    snprintf(si->os, sizeof si->os, "%s %s %s", u.sysname, u.release, u.machine);
  FILE *f = fopen("/proc/cpuinfo", "r");
  char line[512];
  if (f) {
    while (fgets(line, sizeof line, f))
      if (strncmp(line, "model name", 10) == 0) {
        char *c = strchr(line, ':');
        if (c) {
          c += 1 + strspn(c + 1, " \t");
          c[strcspn(c, "\n")] = '\0';
          snprintf(si->cpu, sizeof si->cpu, "%s", c);
        }
        break;
      }
    fclose(f);
  }
  if (!si->cpu[0]) snprintf(si->cpu, sizeof si->cpu, "unknown");
  si->cores = (int)sysconf(_SC_NPROCESSORS_ONLN);
  f = fopen("/proc/meminfo", "r");
  if (f) {
    while (fgets(line, sizeof line, f)) {
      long kb;
      if (sscanf(line, "MemTotal: %ld kB", &kb) == 1) si->mem_gib = kb / (1024.0 * 1024.0);
    }
    fclose(f);
  }
  char *gp[] = {"gnuplot", "--version", NULL};
  first_line(gp, 1, si->gnuplot, sizeof si->gnuplot);
  /* One line: "pkg version, pkg version, ..."; a package that is not installed is left out
   * (dpkg-query then exits with 1 but lists the others). */
  char *dq[] = {"dpkg-query", "-W", "-f", "${Package} ${Version}, ", "libgmsh-dev",
                "libcgal-dev", "libtet1.5-dev", "libembree-dev", "libmuparser-dev",
                "libcjson-dev", "gnuplot-nox", NULL};
  first_line(dq, 0, si->packages, sizeof si->packages);
  size_t n = strlen(si->packages);
  if (n >= 2 && strcmp(si->packages + n - 2, ", ") == 0) si->packages[n - 2] = '\0';
}
