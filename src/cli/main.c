/* The packmesh command: dispatches to the subcommands. */
#include <packmesh/packmesh.h>

#include <stdio.h>
#include <string.h>

int main(int argc, char **argv) {
  if (argc >= 2 && (strcmp(argv[1], "--version") == 0)) {
    printf("packmesh %s\n", pm_version());
    return 0;
  }
  fprintf(stderr, "packmesh: usage: packmesh mesh|quality|compare|cases|demo ...\n");
  return 2;
}
