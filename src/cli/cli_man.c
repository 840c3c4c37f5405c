/* The manual pages in roff (cli_man.h). Text is escaped for roff: backslashes as \e, every
 * hyphen as \- (so that options render and copy as the ASCII hyphen-minus they are), characters
 * beyond ASCII as \[uXXXX], and a line that would start with '.' or '\'' (a request) behind \&.
 * Option names are set in bold and placeholders (INPUT, N) in italics. */
#include "cli/cli_man.h"

#include <packmesh/packmesh.h>

#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli_commands.h"
#include "cli/cli_usage.h"
#include "compare/src/compare.h"

/* n bytes of s, escaped (no line-start handling: see put_text). */
static void put_escaped(FILE *f, const char *s, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    const unsigned char c = (unsigned char)s[i];
    if (c == '\\') {
      fputs("\\e", f);
    } else if (c == '-') {
      fputs("\\-", f);
    } else if (c < 0x80) {
      fputc(c, f);
    } else {
      /* UTF-8: the code point as groff names it; a stray byte as itself. */
      int extra = c >= 0xF0 ? 3 : c >= 0xE0 ? 2 : c >= 0xC0 ? 1 : 0;
      unsigned long cp = c & (0x3F >> extra);
      size_t j = 1;
      for (; (int)j <= extra && i + j < n && ((unsigned char)s[i + j] & 0xC0) == 0x80; ++j)
        cp = cp << 6 | ((unsigned char)s[i + j] & 0x3F);
      if (extra == 0 || (int)j != extra + 1) {
        fprintf(f, "\\[u%04lX]", (unsigned long)c);
        continue;
      }
      fprintf(f, "\\[u%04lX]", cp);
      i += (size_t)extra;
    }
  }
}

/* Lines of text, each escaped and started safely; empty lines are dropped (in roff an empty
 * line is a break). */
static void put_text(FILE *f, const char *text) {
  for (const char *s = text; *s;) {
    size_t n = strcspn(s, "\n");
    if (n) {
      if (s[0] == '.' || s[0] == '\'') fputs("\\&", f);
      put_escaped(f, s, n);
      fputc('\n', f);
    }
    s += n;
    if (*s) ++s;
  }
}

/* A command line or an option's term on one line, with option names ("--size", "-o") in bold
 * and placeholders (upper-case words: INPUT, KEY=VALUE, OUT.(msh|vtk)) in italics. */
static void put_marked(FILE *f, const char *s) {
  if (s[0] == '.' || s[0] == '\'') fputs("\\&", f);
  for (size_t i = 0; s[i];) {
    const char prev = i ? s[i - 1] : ' ';
    const int word_start = strchr(" [|(,=", prev) != NULL;
    size_t j = i;
    if (s[i] == '-' && word_start && (s[i + 1] == '-' || isalpha((unsigned char)s[i + 1]))) {
      while (s[j] == '-' || isalnum((unsigned char)s[j])) ++j;
      fputs("\\fB", f);
      put_escaped(f, s + i, j - i);
      fputs("\\fR", f);
    } else if (isupper((unsigned char)s[i]) && word_start) {
      while (isupper((unsigned char)s[j]) || isdigit((unsigned char)s[j]) || s[j] == '_') ++j;
      fputs("\\fI", f);
      put_escaped(f, s + i, j - i);
      fputs("\\fR", f);
    } else {
      put_escaped(f, s + i, 1);
      j = i + 1;
    }
    i = j;
  }
  fputc('\n', f);
}

/* .TH and NAME: page is "packmesh" or "packmesh-mesh". */
static void put_head(FILE *f, const char *page, const char *what, const char *made_from) {
  fprintf(f, ".\\\" %s(1), made by 'packmesh help --man' from %s:\n"
             ".\\\" edit that text in src/cli, not this file.\n", page, made_from);
  fputs(".TH \"", f);
  for (const char *c = page; *c; ++c)
    if (*c == '-')
      fputs("\\-", f);
    else
      fputc(toupper((unsigned char)*c), f);
  fprintf(f, "\" 1 \"\" \"packmesh %s\" \"packmesh manual\"\n.SH NAME\n", pm_version());
  put_escaped(f, page, strlen(page));
  fputs(" \\- ", f);
  put_escaped(f, what, strlen(what));
  fputc('\n', f);
}

/* The forms of a command line, each a .SY block: "packmesh" in bold, the rest marked. */
static void put_synopsis(FILE *f, const char *const *forms, int n) {
  fputs(".SH SYNOPSIS\n", f);
  for (int i = 0; i < n; ++i) {
    const char *rest = forms[i];
    if (strncmp(rest, "packmesh ", 9) == 0) rest += 9;
    fputs(".SY packmesh\n", f);
    /* The subcommand's name is literal, like "packmesh". */
    size_t word = strcspn(rest, " ");
    if (word && islower((unsigned char)rest[0])) {
      fputs("\\fB", f);
      put_escaped(f, rest, word);
      fputs("\\fR", f);
      rest += word;
      while (*rest == ' ') ++rest;
      if (!*rest) {
        fputc('\n', f);
        continue;
      }
      fputc(' ', f);
    }
    put_marked(f, rest);
  }
  fputs(".YS\n", f);
}

/* A table of terms as .TP entries: each term in bold, its text below. */
static void put_table(FILE *f, const pm_cli_table *t) {
  fprintf(f, ".SH %s\n", t->section);
  for (int i = 0; i < t->n; ++i) {
    fputs(".TP\n\\fB", f);
    put_escaped(f, t->entries[i].term, strlen(t->entries[i].term));
    fputs("\\fR\n", f);
    put_text(f, t->entries[i].text);
  }
}

static const pm_cli_table *table_named(const char *section) {
  for (int i = 0; i < pm_cli_table_count(); ++i)
    if (strcmp(pm_cli_table_at(i)->section, section) == 0) return pm_cli_table_at(i);
  return NULL;
}

/* SEE ALSO: every page but `self`, then gmsh(1), whose readers and meshers packmesh uses. */
static void put_see_also(FILE *f, const char *self) {
  fputs(".SH SEE ALSO\n", f);
  if (self) fputs(".BR packmesh (1),\n", f);
  for (int i = 0; i < pm_cli_command_count(); ++i) {
    const char *name = pm_cli_command_at(i)->name;
    if (self && strcmp(name, self) == 0) continue;
    fprintf(f, ".BR packmesh\\-%s (1),\n", name);
  }
  fputs(".BR gmsh (1)\n", f);
}

/* ---- what the library's tables add to a command's page -------------------------------------- */

/* Every method with its description and its parameters, as `mesh --method M --help` lists
 * them. */
static int method_parameters(FILE *f) {
  fputs(".SH METHOD PARAMETERS\n"
        "Each method's parameters, set with \\fB\\-\\-set\\fR \\fIKEY\\fR=\\fIVALUE\\fR; "
        "\\fBpackmesh mesh \\-\\-method\\fR \\fIM\\fR \\fB\\-\\-help\\fR prints the same table.\n"
        "A number NNN in a source is the paper papers/NNN, cited in full by\n"
        ".BR packmesh\\-references (1).\n",
        f);
  for (int i = 0; i < pm_method_count(); ++i) {
    const pm_method *m = pm_method_at(i);
    fputs(".SS ", f);
    put_escaped(f, pm_method_name(m), strlen(pm_method_name(m)));
    fputc('\n', f);
    put_text(f, pm_method_description(m));
    const int n = pm_method_param_count(m);
    if (n == 0) fputs(".PP\nNo parameters.\n", f);
    for (int k = 0; k < n; ++k) {
      pm_param_info p;
      pm_error e = {0};
      if (pm_method_param_info(m, k, &p, &e)) return -1;
      fputs(".TP\n\\fB", f);
      put_escaped(f, p.key, strlen(p.key));
      fputs("\\fR\n", f);
      put_text(f, p.doc);
      fputs(".br\nDefault ", f);
      put_escaped(f, p.default_value, strlen(p.default_value));
      fputs(", range ", f);
      put_escaped(f, p.range, strlen(p.range));
      if (p.unit && p.unit[0]) {
        fputs(", unit ", f);
        put_escaped(f, p.unit, strlen(p.unit));
      }
      if (p.source && p.source[0]) {
        fputs("; source: ", f);
        put_escaped(f, p.source, strlen(p.source));
      }
      fputs(".\n", f);
    }
  }
  return 0;
}

static int builtin_cases(FILE *f) {
  fputs(".SH BUILT-IN CASES\n", f);
  for (int i = 0; i < pm_case_count(); ++i) {
    fputs(".TP\n\\fBcase:", f);
    put_escaped(f, pm_case_name(i), strlen(pm_case_name(i)));
    fputs("\\fR\n", f);
    put_text(f, pm_case_description(i));
    fprintf(f, ".br\n%s; default size ", pm_case_dimension(i) == 2 ? "Planar" : "Solid");
    put_escaped(f, pm_case_default_size(i), strlen(pm_case_default_size(i)));
    fputs("; source: ", f);
    put_escaped(f, pm_case_source(i), strlen(pm_case_source(i)));
    fputs(".\n", f);
  }
  return 0;
}

static int references(FILE *f) {
  fputs(".SH REFERENCES\n", f);
  for (int i = 0; i < pm_cmp_reference_count(); ++i) {
    const pm_cmp_reference *r = pm_cmp_reference_at(i);
    fputs(".TP\n\\fBpapers/", f);
    put_escaped(f, r->key, strlen(r->key));
    fputs("\\fR\n", f);
    put_text(f, r->citation);
    fputs(".br\nUsed for ", f);
    put_escaped(f, r->used_for, strlen(r->used_for));
    fputs(".\n", f);
  }
  return 0;
}

static const struct {
  const char *command;
  int (*write)(FILE *f);
} extra_sections[] = {
    {"mesh", method_parameters},
    {"cases", builtin_cases},
    {"references", references},
};

/* ---- the pages ------------------------------------------------------------------------------ */

static int top_page(FILE *f) {
  put_head(f, "packmesh", pm_cli_tagline, "'packmesh --help'");
  int nforms = 0;
  while (pm_cli_top_forms[nforms]) ++nforms;
  put_synopsis(f, pm_cli_top_forms, nforms);
  fputs(".SH DESCRIPTION\n", f);
  put_text(f, pm_cli_top_description);
  fputs(".SH COMMANDS\n", f);
  for (int i = 0; i < pm_cli_command_count(); ++i) {
    const pm_cli_command *c = pm_cli_command_at(i);
    fputs(".TP\n\\fB", f);
    put_escaped(f, c->name, strlen(c->name));
    fputs("\\fR\n", f);
    put_text(f, c->summary);
    fprintf(f, "(\\fBpackmesh\\-%s\\fR(1))\n", c->name);
  }
  for (int i = 0; i < pm_cli_table_count(); ++i) put_table(f, pm_cli_table_at(i));
  put_see_also(f, NULL);
  return 0;
}

static int command_page(const pm_cli_command *c, FILE *f) {
  pm_usage u;
  if (pm_usage_read(c->usage, &u)) return -1;
  char page[64], from[96];
  snprintf(page, sizeof page, "packmesh-%s", c->name);
  snprintf(from, sizeof from, "'packmesh %s --help'", c->name);
  put_head(f, page, c->summary, from);
  put_synopsis(f, (const char *const *)u.forms, u.nforms);
  /* The paragraphs before the first option describe the command; the options and what follows
   * them are its OPTIONS, in the order --help gives them. */
  int in_options = 0, after_paragraph = 0;
  for (int i = 0; i < u.nblocks; ++i) {
    const pm_usage_block *b = &u.blocks[i];
    if (b->kind == PM_USAGE_OPTION) {
      if (!in_options) fputs(".SH OPTIONS\n", f);
      in_options = 1, after_paragraph = 0;
      fputs(".TP\n", f);
      put_marked(f, b->term);
      put_text(f, b->text);
      continue;
    }
    if (!in_options && !after_paragraph) fputs(".SH DESCRIPTION\n", f);
    if (after_paragraph || in_options) fputs(".PP\n", f);
    put_text(f, b->text);
    after_paragraph = 1;
  }
  pm_usage_clear(&u);
  for (size_t i = 0; i < sizeof extra_sections / sizeof extra_sections[0]; ++i)
    if (strcmp(extra_sections[i].command, c->name) == 0 && extra_sections[i].write(f)) return -1;
  put_table(f, table_named("EXIT STATUS"));
  put_see_also(f, c->name);
  return 0;
}

int pm_cli_man_page(const char *command, FILE *f) {
  if (!command) return top_page(f);
  const pm_cli_command *c = pm_cli_command_find(command);
  return c ? command_page(c, f) : -1;
}
