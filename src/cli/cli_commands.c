/* The packmesh command's top level (cli_commands.h): its subcommands and the tables of what
 * holds for all of them. */
#include "cli/cli_commands.h"

#include <packmesh/packmesh.h>

#include <string.h>

#include "cli/cli.h"

static const pm_cli_command commands[] = {
    {"quality", pm_cli_quality, pm_cli_quality_usage,
     "measure a mesh file: quality, validity (--json, --csv)"},
    {"mesh", pm_cli_mesh, pm_cli_mesh_usage,
     "mesh an input with one method (--method, --size, -o, --stats)"},
    {"cases", pm_cli_cases, pm_cli_cases_usage, "list the built-in cases (INPUT case:NAME)"},
    {"compare", pm_cli_compare, pm_cli_compare_usage,
     "run a comparison suite into a folder: CSV, plots, report"},
    {"demo", pm_cli_demo, pm_cli_demo_usage,
     "run the default comparison on built-in cases (-o DIR)"},
    {"animate", pm_cli_animate, pm_cli_animate_usage,
     "the frames of a run (mesh --frames) as an animated GIF and an HTML player"},
    {"references", pm_cli_references, pm_cli_references_usage,
     "the full citations of the papers cited as papers/NNN"},
    {"help", pm_cli_help, pm_cli_help_usage,
     "a command's help, and the man pages and bash completion made from it"},
};
#define NCOMMANDS ((int)(sizeof commands / sizeof commands[0]))

int pm_cli_command_count(void) { return NCOMMANDS; }

const pm_cli_command *pm_cli_command_at(int i) {
  return i >= 0 && i < NCOMMANDS ? &commands[i] : NULL;
}

const pm_cli_command *pm_cli_command_find(const char *name) {
  for (int i = 0; i < NCOMMANDS; ++i)
    if (strcmp(commands[i].name, name) == 0) return &commands[i];
  return NULL;
}

static const pm_cli_entry exit_codes[] = {
    {"0", "success"},
    {"1", "the work failed (an unreadable or invalid input, a run that failed): one line "
          "'packmesh: ...' on stderr, and no output file is left"},
    {"2", "a usage error (an unknown command, option, method or parameter, a value outside its "
          "range, an option that does not apply to the input): one line naming where the valid "
          "values are listed"},
    {"130", "interrupted by SIGINT: one line; temporaries are removed, nothing half written is "
            "left"},
    {"143", "interrupted by SIGTERM: the same"},
};

static const pm_cli_entry environment[] = {
    {"OMP_NUM_THREADS", "the default of mesh --threads (without it, one thread per core)"},
    {"OMP_WAIT_POLICY", "passive: threads waiting at a barrier sleep instead of spinning (on a "
                        "loaded machine a waiting thread then takes no CPU time)"},
    {"PM_BUB_KERNEL", "c: bubble's force sum in plain C instead of AVX2 (the same results; for "
                      "tests and measurements)"},
    {"PATH", "where compare and demo find gnuplot, which draws their figures (without it the "
             "report says so)"},
};

static const pm_cli_entry files[] = {
    {PM_CLI_CAD_EXTENSIONS, "CAD models (INPUT, --geometry), read through gmsh and OpenCASCADE; "
                            "repairs are named on stderr"},
    {".json", "case files (INPUT, --geometry: a domain and a size field) and comparison suites "
              "(compare)"},
    {".msh .vtk .vtu .stl .obj .mesh", "meshes: mesh writes them (-o), quality reads them"},
};

#define TABLE(heading, section, e) {heading, section, e, (int)(sizeof e / sizeof e[0])}
static const pm_cli_table tables[] = {
    TABLE("exit codes", "EXIT STATUS", exit_codes),
    TABLE("environment", "ENVIRONMENT", environment),
    TABLE("files", "FILES", files),
};
#undef TABLE
#define NTABLES ((int)(sizeof tables / sizeof tables[0]))

int pm_cli_table_count(void) { return NTABLES; }

const pm_cli_table *pm_cli_table_at(int i) { return i >= 0 && i < NTABLES ? &tables[i] : NULL; }

const char pm_cli_tagline[] =
    "particle-based meshing (bubble mesh, particle systems) and mesh quality";

const char *const pm_cli_top_forms[] = {"packmesh COMMAND [ARGS]", "packmesh --help | --version",
                                        NULL};

const char pm_cli_top_description[] =
    "packmesh meshes CAD models, planar domains and built-in cases with two particle-based\n"
    "methods (bubble, psys) and classic peers (gmsh, CGAL) on one geometry, connection and\n"
    "quality layer, measures meshes, and runs comparison studies of the methods.\n"
    "'packmesh COMMAND --help' (or 'packmesh help COMMAND') describes a command.";

/* The widest line `packmesh --help` prints. */
#define LINE_WIDTH 96

/* One table as `packmesh --help` prints it: "heading:", then each term in a column as wide as
 * the longest and its text after it, wrapped at LINE_WIDTH under its own column. */
static void print_table(FILE *f, const char *heading, const pm_cli_entry *e, int n, int width) {
  fprintf(f, "\n%s:\n", heading);
  const int indent = 2 + width + 2;
  for (int i = 0; i < n; ++i) {
    fprintf(f, "  %-*s  ", width, e[i].term);
    int col = indent;
    for (const char *w = e[i].text; *w;) {
      size_t len = strcspn(w, " ");
      if (col > indent && col + 1 + (int)len > LINE_WIDTH) {
        fprintf(f, "\n%*s", indent, "");
        col = indent;
      } else if (col > indent) {
        fputc(' ', f);
        ++col;
      }
      fwrite(w, 1, len, f);
      col += (int)len;
      w += len;
      while (*w == ' ') ++w;
    }
    fputc('\n', f);
  }
}

void pm_cli_top_usage(FILE *f) {
  fprintf(f, "packmesh %s: %s\n\nusage: %s\n", pm_version(), pm_cli_tagline, pm_cli_top_forms[0]);
  for (int i = 1; pm_cli_top_forms[i]; ++i) fprintf(f, "       %s\n", pm_cli_top_forms[i]);
  fprintf(f, "\n%s\n", pm_cli_top_description);
  pm_cli_entry list[NCOMMANDS];
  int width = 0;
  for (int i = 0; i < NCOMMANDS; ++i) {
    list[i] = (pm_cli_entry){commands[i].name, commands[i].summary};
    if ((int)strlen(commands[i].name) > width) width = (int)strlen(commands[i].name);
  }
  print_table(f, "commands", list, NCOMMANDS, width);
  for (int t = 0; t < NTABLES; ++t) {
    width = 0;
    for (int i = 0; i < tables[t].n; ++i)
      if ((int)strlen(tables[t].entries[i].term) > width) width = (int)strlen(tables[t].entries[i].term);
    print_table(f, tables[t].heading, tables[t].entries, tables[t].n, width);
  }
}
