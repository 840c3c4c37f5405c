/* Reading a usage text into its forms, paragraphs and options (cli_usage.h; the layout is
 * cli.h's). */
#include "cli/cli_usage.h"

#include <stdlib.h>
#include <string.h>

static int indent_of(const char *line) {
  int n = 0;
  while (line[n] == ' ') ++n;
  return n;
}

/* A copy of [s, s + n) without its trailing spaces. */
static char *copy_trimmed(const char *s, size_t n) {
  while (n > 0 && s[n - 1] == ' ') --n;
  char *c = malloc(n + 1);
  if (c) {
    memcpy(c, s, n);
    c[n] = '\0';
  }
  return c;
}

/* *text + sep + more, reallocated; 0 on success. */
static int append(char **text, const char *sep, const char *more) {
  size_t a = strlen(*text), b = strlen(sep), c = strlen(more);
  char *t = realloc(*text, a + b + c + 1);
  if (!t) return -1;
  memcpy(t + a, sep, b);
  memcpy(t + a + b, more, c + 1);
  *text = t;
  return 0;
}

static int add_form(pm_usage *u, const char *line) {
  char **f = realloc(u->forms, (size_t)(u->nforms + 1) * sizeof *f);
  if (!f) return -1;
  u->forms = f;
  return (f[u->nforms] = copy_trimmed(line, strlen(line))) ? (++u->nforms, 0) : -1;
}

static int add_block(pm_usage *u, pm_usage_kind kind, const char *term, size_t term_len,
                     const char *text) {
  pm_usage_block *b = realloc(u->blocks, (size_t)(u->nblocks + 1) * sizeof *b);
  if (!b) return -1;
  u->blocks = b;
  b += u->nblocks;
  b->kind = kind;
  b->term = term ? copy_trimmed(term, term_len) : NULL;
  b->text = copy_trimmed(text, strlen(text));
  if (!b->text || (term && !b->term)) {
    free(b->term);
    free(b->text);
    return -1;
  }
  ++u->nblocks;
  return 0;
}

/* The body, line by line: a blank line ends a paragraph; an option line starts an option, and
 * the lines indented further than it continue it; any other line is prose. */
static int read_body(pm_usage *u, char **lines, int n) {
  int open = 0;           /* the last block may take more lines */
  int option_indent = -1; /* the indent of the open option's line; -1: prose is open */
  for (int i = 0; i < n; ++i) {
    const char *line = lines[i];
    const int ind = indent_of(line);
    const char *rest = line + ind;
    if (!*rest) {
      open = 0;
      continue;
    }
    pm_usage_block *last = u->nblocks ? &u->blocks[u->nblocks - 1] : NULL;
    if (open && option_indent >= 0 && ind > option_indent) {
      if (append(&last->text, last->text[0] ? "\n" : "", rest)) return -1;
      continue;
    }
    if (ind >= 2 && rest[0] == '-') {
      const char *gap = strstr(rest, "  ");
      size_t term_len = gap ? (size_t)(gap - rest) : strlen(rest);
      const char *text = rest + term_len;
      while (*text == ' ') ++text;
      if (add_block(u, PM_USAGE_OPTION, rest, term_len, text)) return -1;
      open = 1, option_indent = ind;
      continue;
    }
    if (open && option_indent < 0) {
      if (append(&last->text, "\n", rest)) return -1;
      continue;
    }
    if (add_block(u, PM_USAGE_PROSE, NULL, 0, rest)) return -1;
    open = 1, option_indent = -1;
  }
  return 0;
}

int pm_usage_read(void (*usage)(FILE *f), pm_usage *u) {
  memset(u, 0, sizeof *u);
  char *text = NULL;
  size_t len = 0;
  FILE *f = open_memstream(&text, &len);
  if (!f) return -1;
  usage(f);
  if (fclose(f) != 0) {
    free(text);
    return -1;
  }
  /* The lines, in place. */
  int n = 0, cap = 0, rc = -1;
  char **lines = NULL;
  for (char *s = text; *s;) {
    char *end = strchr(s, '\n');
    if (n == cap) {
      char **l = realloc(lines, (size_t)(cap = 2 * cap + 16) * sizeof *l);
      if (!l) goto done;
      lines = l;
    }
    lines[n++] = s;
    if (!end) break;
    *end = '\0';
    s = end + 1;
  }
  static const char head[] = "usage: ";
  if (n == 0 || strncmp(lines[0], head, sizeof head - 1) != 0) goto done;
  if (add_form(u, lines[0] + sizeof head - 1)) goto done;
  /* The synopsis: the indented lines after the first; "packmesh ..." starts another form. */
  int i = 1;
  for (; i < n && lines[i][0] == ' '; ++i) {
    const char *rest = lines[i] + indent_of(lines[i]);
    if (!*rest) break;
    if (strncmp(rest, "packmesh ", 9) == 0) {
      if (add_form(u, rest)) goto done;
    } else {
      char **form = &u->forms[u->nforms - 1];
      if (append(form, " ", rest)) goto done;
      char *trimmed = copy_trimmed(*form, strlen(*form));
      if (!trimmed) goto done;
      free(*form);
      *form = trimmed;
    }
  }
  rc = read_body(u, lines + i, n - i);
done:
  free(lines);
  free(text);
  if (rc) pm_usage_clear(u);
  return rc;
}

void pm_usage_clear(pm_usage *u) {
  for (int i = 0; i < u->nforms; ++i) free(u->forms[i]);
  for (int i = 0; i < u->nblocks; ++i) {
    free(u->blocks[i].term);
    free(u->blocks[i].text);
  }
  free(u->forms);
  free(u->blocks);
  memset(u, 0, sizeof *u);
}
