/* The bash completion script (cli_completion.h): data made from the tables, then the functions
 * that complete from it.
 *
 * Each command's options and operands come from its usage text: the forms of its command line
 * ("-o OUT.(msh|vtk)", "[--method M]", "INPUT") and its option lines ("-o, --output OUT", whose
 * names are aliases). The kind of an option's value follows from the option or its placeholder:
 *   --method       methods     a method's name
 *   --set          params      KEY= of the method given, then the values of a choice
 *   COMMAND        commands    a command
 *   INPUT          input       case:NAME, CAD files and case files
 *   NAME.(a|b)     files:a b   files ending .a or .b (NAME.ext: files ending .ext)
 *   DIR            dirs        folders
 *   FILE           files:      any file
 *   A|b|c, a|b     words:b c   the lower-case alternatives
 *   anything else  none        nothing to offer (a number, an expression)
 * and a flag has no value (""). */
#include "cli/cli_completion.h"

#include <packmesh/packmesh.h>

#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cli_commands.h"
#include "cli/cli_usage.h"

#define MAX_OPTIONS 64
#define MAX_OPERANDS 8

typedef struct option_doc {
  char name[48];
  char value[96];   /* the placeholder, "" for a flag */
  int from_form;    /* the placeholder is the one a form gives (more precise: OUT.(msh|vtk)) */
} option_doc;

typedef struct command_doc {
  option_doc opt[MAX_OPTIONS];
  int nopt;
  char operand[MAX_OPERANDS][96];
  int noperand;
} command_doc;

static option_doc *find_option(command_doc *d, const char *name) {
  for (int i = 0; i < d->nopt; ++i)
    if (strcmp(d->opt[i].name, name) == 0) return &d->opt[i];
  return NULL;
}

/* Record an option; a placeholder fills one still missing, a form's replaces an option line's. */
static void add_option(command_doc *d, const char *name, const char *value, int from_form) {
  option_doc *o = find_option(d, name);
  if (!o) {
    if (d->nopt == MAX_OPTIONS) return;
    o = &d->opt[d->nopt++];
    snprintf(o->name, sizeof o->name, "%s", name);
    o->value[0] = '\0';
    o->from_form = 0;
  }
  if (value[0] && (!o->value[0] || (from_form && !o->from_form))) {
    snprintf(o->value, sizeof o->value, "%s", value);
    o->from_form = from_form;
  }
}

/* A placeholder: an upper-case word ("INPUT", "EXPR|NUMBER|inferred"), or literal choices
 * ("local|slurm"). */
static int is_placeholder(const char *word) {
  return isupper((unsigned char)word[0]) || (islower((unsigned char)word[0]) && strchr(word, '|'));
}

/* The words of a form after "packmesh NAME": an option followed, inside the same brackets, by a
 * placeholder takes it as its value ("[--size EXPR]", "-o OUT"); a placeholder of its own is an
 * operand ("INPUT", "[COMMAND]"). */
static void read_form(command_doc *d, const char *form) {
  char raw[64][96];
  int n = 0;
  for (const char *s = form; *s && n < 64;) {
    while (*s == ' ') ++s;
    size_t len = strcspn(s, " ");
    if (!len) break;
    snprintf(raw[n++], sizeof raw[0], "%.*s", (int)len, s);
    s += len;
  }
  char bare[64][96];
  for (int i = 0; i < n; ++i) {
    const char *b = raw[i];
    while (*b == '[') ++b;
    size_t len = strlen(b);
    while (len && b[len - 1] == ']') --len;
    snprintf(bare[i], sizeof bare[0], "%.*s", (int)len, b);
  }
  for (int i = 2; i < n; ++i) {
    if (bare[i][0] == '-') {
      const char *name = bare[i], *value = "";
      const size_t len = strlen(raw[i]);
      if (i + 1 < n && raw[i][len - 1] != ']' && raw[i + 1][0] != '[' && is_placeholder(bare[i + 1]))
        value = bare[++i];
      add_option(d, name, value, 1);
    } else if (is_placeholder(bare[i]) && d->noperand < MAX_OPERANDS) {
      int have = 0;
      for (int k = 0; k < d->noperand; ++k) have |= strcmp(d->operand[k], bare[i]) == 0;
      if (!have) snprintf(d->operand[d->noperand++], sizeof d->operand[0], "%s", bare[i]);
    }
  }
}

/* An option line's term: its names ("-o," "--output") and the placeholder after them. */
static void read_term(command_doc *d, const char *term) {
  char names[8][48], value[96] = "";
  int n = 0;
  for (const char *s = term; *s;) {
    while (*s == ' ' || *s == ',') ++s;
    size_t len = strcspn(s, " ,");
    if (!len) break;
    if (s[0] == '-' && n < 8)
      snprintf(names[n++], sizeof names[0], "%.*s", (int)len, s);
    else if (!value[0]) {
      char word[96];
      snprintf(word, sizeof word, "%.*s", (int)len, s);
      if (is_placeholder(word)) snprintf(value, sizeof value, "%s", word);
    }
    s += len;
  }
  for (int i = 0; i < n; ++i) add_option(d, names[i], value, 0);
  /* Aliases share the most precise placeholder any of them has. */
  const option_doc *best = NULL;
  for (int i = 0; i < n; ++i) {
    const option_doc *o = find_option(d, names[i]);
    if (o && o->value[0] && (!best || (o->from_form && !best->from_form))) best = o;
  }
  if (best)
    for (int i = 0; i < n; ++i) add_option(d, names[i], best->value, best->from_form);
}

/* The kind of value (the table at the top of this file) of option `name` (NULL: an operand)
 * with placeholder `value`, into out. */
static void kind_of(const char *name, const char *value, char *out, size_t len) {
  const char *paren = strchr(value, '('), *dot = strrchr(value, '.');
  if (!value[0])
    snprintf(out, len, "%s", "");
  else if (name && strcmp(name, "--method") == 0)
    snprintf(out, len, "methods");
  else if (name && strcmp(name, "--set") == 0)
    snprintf(out, len, "params");
  else if (strcmp(value, "COMMAND") == 0)
    snprintf(out, len, "commands");
  else if (strcmp(value, "INPUT") == 0)
    snprintf(out, len, "input");
  else if (strcmp(value, "DIR") == 0)
    snprintf(out, len, "dirs");
  else if (strcmp(value, "FILE") == 0)
    snprintf(out, len, "files:");
  else if (paren) {
    /* NAME.(a|b|c) */
    snprintf(out, len, "files:");
    for (const char *c = paren + 1; *c && *c != ')' && strlen(out) + 1 < len; ++c) {
      size_t at = strlen(out);
      out[at] = *c == '|' ? ' ' : *c;
      out[at + 1] = '\0';
    }
  } else if (dot && dot[1] && islower((unsigned char)dot[1])) {
    snprintf(out, len, "files:%s", dot + 1);
  } else if (strchr(value, '|')) {
    /* EXPR|NUMBER|inferred: the literal (lower-case) alternatives. */
    snprintf(out, len, "words:");
    const char *s = value;
    while (*s) {
      size_t n = strcspn(s, "|");
      if (n && islower((unsigned char)s[0]) && strlen(out) + n + 2 < len)
        snprintf(out + strlen(out), len - strlen(out), "%s%.*s",
                 strcmp(out, "words:") ? " " : "", (int)n, s);
      s += n;
      if (*s) ++s;
    }
    if (strcmp(out, "words:") == 0) snprintf(out, len, "none");
  } else {
    snprintf(out, len, "none");
  }
}

/* A list of words in single quotes for bash: the words the tables hold are names and values
 * ("k0", "on", "eigen"); a quote among them is written '\''. */
static void put_quoted(FILE *f, const char *s) {
  fputc('\'', f);
  for (; *s; ++s)
    if (*s == '\'')
      fputs("'\\''", f);
    else
      fputc(*s, f);
  fputc('\'', f);
}

static int put_commands(FILE *f) {
  fputs("_packmesh_commands=", f);
  char list[512] = "";
  for (int i = 0; i < pm_cli_command_count(); ++i)
    snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? " " : "",
             pm_cli_command_at(i)->name);
  put_quoted(f, list);
  fputc('\n', f);

  /* Each command's options, operand and values, read from its usage text. */
  command_doc *docs = calloc((size_t)pm_cli_command_count(), sizeof *docs);
  if (!docs) return -1;
  for (int i = 0; i < pm_cli_command_count(); ++i) {
    pm_usage u;
    if (pm_usage_read(pm_cli_command_at(i)->usage, &u)) {
      free(docs);
      return -1;
    }
    for (int k = 0; k < u.nforms; ++k) read_form(&docs[i], u.forms[k]);
    for (int k = 0; k < u.nblocks; ++k)
      if (u.blocks[k].kind == PM_USAGE_OPTION) read_term(&docs[i], u.blocks[k].term);
    pm_usage_clear(&u);
  }
  char kind[256];
  fputs("\n# The options of command $1, in REPLY.\n_packmesh_options() {\n  case $1 in\n", f);
  for (int i = 0; i < pm_cli_command_count(); ++i) {
    fprintf(f, "    %s) REPLY=", pm_cli_command_at(i)->name);
    list[0] = '\0';
    for (int k = 0; k < docs[i].nopt; ++k)
      snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", k ? " " : "",
               docs[i].opt[k].name);
    put_quoted(f, list);
    fputs(" ;;\n", f);
  }
  fputs("    *) REPLY='' ;;\n  esac\n}\n", f);
  fputs("\n# The kind of the operand of command $1 ('' when it takes none), in REPLY.\n"
        "_packmesh_operand() {\n  case $1 in\n", f);
  for (int i = 0; i < pm_cli_command_count(); ++i) {
    if (!docs[i].noperand) continue;
    kind_of(NULL, docs[i].operand[0], kind, sizeof kind);
    fprintf(f, "    %s) REPLY=", pm_cli_command_at(i)->name);
    put_quoted(f, kind);
    fputs(" ;;\n", f);
  }
  fputs("    *) REPLY='' ;;\n  esac\n}\n", f);
  fputs("\n# The kind of the value of option COMMAND:OPTION ('' for a flag), in REPLY.\n"
        "_packmesh_value() {\n  case $1 in\n", f);
  for (int i = 0; i < pm_cli_command_count(); ++i)
    for (int k = 0; k < docs[i].nopt; ++k) {
      if (!docs[i].opt[k].value[0]) continue;
      kind_of(docs[i].opt[k].name, docs[i].opt[k].value, kind, sizeof kind);
      fprintf(f, "    %s:%s) REPLY=", pm_cli_command_at(i)->name, docs[i].opt[k].name);
      put_quoted(f, kind);
      fputs(" ;;\n", f);
    }
  fputs("    *) REPLY='' ;;\n  esac\n}\n", f);
  free(docs);
  return 0;
}

/* The methods, each one's parameter keys, and the values of its choices ("a|b|c" ranges). */
static int put_methods(FILE *f) {
  char list[1024] = "";
  for (int i = 0; i < pm_method_count(); ++i)
    snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? " " : "",
             pm_method_name(pm_method_at(i)));
  fputs("_packmesh_methods=", f);
  put_quoted(f, list);
  fputs("\n\n# The parameter keys of method $1, in REPLY.\n_packmesh_params() {\n  case $1 in\n", f);
  for (int i = 0; i < pm_method_count(); ++i) {
    const pm_method *m = pm_method_at(i);
    char *keys = NULL;
    size_t len = 0;
    FILE *k = open_memstream(&keys, &len);
    if (!k) return -1;
    for (int p = 0; p < pm_method_param_count(m); ++p) {
      pm_param_info info;
      pm_error e = {0};
      if (pm_method_param_info(m, p, &info, &e) == PM_OK) fprintf(k, "%s%s", p ? " " : "", info.key);
    }
    if (fclose(k) != 0) return -1;
    fprintf(f, "    %s) REPLY=", pm_method_name(m));
    put_quoted(f, keys);
    fputs(" ;;\n", f);
    free(keys);
  }
  fputs("    *) REPLY='' ;;\n  esac\n}\n", f);
  fputs("\n# The values of parameter METHOD:KEY when it is a choice ('' otherwise), in REPLY.\n"
        "_packmesh_param_values() {\n  case $1 in\n", f);
  for (int i = 0; i < pm_method_count(); ++i) {
    const pm_method *m = pm_method_at(i);
    for (int p = 0; p < pm_method_param_count(m); ++p) {
      pm_param_info info;
      pm_error e = {0};
      if (pm_method_param_info(m, p, &info, &e) != PM_OK || !strchr(info.range, '|') ||
          strpbrk(info.range, "[]() ,"))
        continue;
      char words[sizeof info.range];
      snprintf(words, sizeof words, "%s", info.range);
      for (char *c = words; *c; ++c)
        if (*c == '|') *c = ' ';
      fprintf(f, "    %s:%s) REPLY=", pm_method_name(m), info.key);
      put_quoted(f, words);
      fputs(" ;;\n", f);
    }
  }
  fputs("    *) REPLY='' ;;\n  esac\n}\n", f);
  return 0;
}

static void put_inputs(FILE *f) {
  char list[512] = "";
  for (int i = 0; i < pm_case_count(); ++i)
    snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? " " : "", pm_case_name(i));
  fputs("_packmesh_cases=", f);
  put_quoted(f, list);
  /* INPUT's files: the CAD extensions and case files. */
  char exts[256] = "";
  for (const char *s = PM_CLI_CAD_EXTENSIONS " .json"; *s;) {
    while (*s == ' ' || *s == '.') ++s;
    size_t n = strcspn(s, " ");
    if (n)
      snprintf(exts + strlen(exts), sizeof exts - strlen(exts), "%s%.*s", exts[0] ? " " : "",
               (int)n, s);
    s += n;
  }
  fputs("\n_packmesh_input_exts=", f);
  put_quoted(f, exts);
  fputc('\n', f);
}

/* The functions that complete from the data above; the same in every script. */
static const char logic[] =
    "# Adds to COMPREPLY each word of the list $2 that starts with $1, written $3WORD$4.\n"
    "_packmesh_words() {\n"
    "  local w list\n"
    "  read -ra list <<< \"$2\"\n"
    "  for w in \"${list[@]}\"; do\n"
    "    [[ $w == \"$1\"* ]] && COMPREPLY+=(\"$3$w$4\")\n"
    "  done\n"
    "}\n"
    "\n"
    "# Adds the folders and files that start with $1, written $3NAME: files with the extensions $2\n"
    "# (any file when it is empty; no file when it is /).\n"
    "_packmesh_files() {\n"
    "  local names=() exts ext name\n"
    "  mapfile -t names < <(compgen -d -- \"$1\")\n"
    "  if [[ -z $2 ]]; then\n"
    "    mapfile -t -O \"${#names[@]}\" names < <(compgen -f -- \"$1\")\n"
    "  elif [[ $2 != / ]]; then\n"
    "    read -ra exts <<< \"$2\"\n"
    "    for ext in \"${exts[@]}\"; do\n"
    "      mapfile -t -O \"${#names[@]}\" names < <(compgen -f -X \"!*.$ext\" -- \"$1\"\n"
    "                                               compgen -f -X \"!*.${ext^^}\" -- \"$1\")\n"
    "    done\n"
    "  fi\n"
    "  # Quoted and completed as file names (a folder gets its /), which case: must not be.\n"
    "  ((${#names[@]})) && compopt -o filenames 2>/dev/null\n"
    "  for name in \"${names[@]}\"; do COMPREPLY+=(\"$3$name\"); done\n"
    "}\n"
    "\n"
    "# Adds the values of kind $1 that start with $2, written $3VALUE; $4 is the method (--set).\n"
    "_packmesh_values() {\n"
    "  local kind=$1 cur=$2 pre=$3 method=$4 key\n"
    "  case $kind in\n"
    "    methods) _packmesh_words \"$cur\" \"$_packmesh_methods\" \"$pre\" ;;\n"
    "    commands) _packmesh_words \"$cur\" \"$_packmesh_commands\" \"$pre\" ;;\n"
    "    params)\n"
    "      if [[ $cur == *=* ]]; then\n"
    "        key=${cur%%=*}\n"
    "        _packmesh_param_values \"$method:$key\"\n"
    "        _packmesh_words \"${cur#*=}\" \"$REPLY\" \"$pre$key=\"\n"
    "      else\n"
    "        _packmesh_params \"$method\"\n"
    "        _packmesh_words \"$cur\" \"$REPLY\" \"$pre\" \"=\"\n"
    "      fi ;;\n"
    "    input)\n"
    "      if [[ $cur == case:* ]]; then\n"
    "        _packmesh_words \"${cur#case:}\" \"$_packmesh_cases\" \"${pre}case:\"\n"
    "      else\n"
    "        [[ case: == \"$cur\"* ]] && COMPREPLY+=(\"${pre}case:\")\n"
    "        _packmesh_files \"$cur\" \"$_packmesh_input_exts\" \"$pre\"\n"
    "      fi ;;\n"
    "    dirs) _packmesh_files \"$cur\" / \"$pre\" ;;\n"
    "    files:*) _packmesh_files \"$cur\" \"${kind#files:}\" \"$pre\" ;;\n"
    "    words:*) _packmesh_words \"$cur\" \"${kind#words:}\" \"$pre\" ;;\n"
    "  esac\n"
    "}\n"
    "\n"
    "_packmesh() {\n"
    "  local IFS=$' \\t\\n' words=(\"${COMP_WORDS[@]}\") cword=$COMP_CWORD i w\n"
    "  COMPREPLY=()\n"
    "  # bash splits 'case:qi3' and '--set=k0' at ':' and '=' (COMP_WORDBREAKS): the word under the\n"
    "  # cursor is joined again from its pieces, and keep is the part of it that bash will not\n"
    "  # replace (the replies are given without it).\n"
    "  local start=$cword\n"
    "  while ((start > 1)) && [[ ${words[start]} == [:=] || ${words[start - 1]} == [:=] ]]; do\n"
    "    ((start--))\n"
    "  done\n"
    "  local cur=\"\" keep\n"
    "  for ((i = start; i <= cword; i++)); do cur+=${words[i]}; done\n"
    "  keep=${cur%\"${words[cword]}\"}\n"
    "  [[ ${words[cword]} == [:=] ]] && keep=$cur\n"
    "\n"
    "  if ((start <= 1)); then\n"
    "    _packmesh_words \"$cur\" \"$_packmesh_commands --help --version\"\n"
    "  else\n"
    "    local cmd=${words[1]} args=() n method=bubble operands=0 waiting=\"\" name\n"
    "    # The words before the current one, joined the same way.\n"
    "    for ((i = 2; i < start; i++)); do\n"
    "      w=${words[i]}\n"
    "      n=${#args[@]}\n"
    "      if ((n > 0)) && [[ $w == [:=] || ${args[n - 1]} == *[:=] ]]; then\n"
    "        args[n - 1]+=$w\n"
    "      else\n"
    "        args+=(\"$w\")\n"
    "      fi\n"
    "    done\n"
    "    # What they say: the method (for --set), how many operands are given, and the option that\n"
    "    # waits for its value.\n"
    "    n=${#args[@]}\n"
    "    for ((i = 0; i < n; i++)); do\n"
    "      w=${args[i]}\n"
    "      if [[ $w != -* ]]; then\n"
    "        ((operands++))\n"
    "        continue\n"
    "      fi\n"
    "      name=${w%%=*}\n"
    "      _packmesh_value \"$cmd:$name\"\n"
    "      [[ -z $REPLY ]] && continue\n"
    "      if [[ $w == *=* ]]; then\n"
    "        [[ $name == --method ]] && method=${w#*=}\n"
    "      elif ((i + 1 < n)); then\n"
    "        ((i++))\n"
    "        [[ $name == --method ]] && method=${args[i]}\n"
    "      else\n"
    "        waiting=$name\n"
    "      fi\n"
    "    done\n"
    "    _packmesh_operand \"$cmd\"\n"
    "    local operand=$REPLY\n"
    "    if [[ -n $waiting ]]; then\n"
    "      _packmesh_value \"$cmd:$waiting\"\n"
    "      _packmesh_values \"$REPLY\" \"$cur\" \"\" \"$method\"\n"
    "    elif [[ $cur == -*=* ]]; then\n"
    "      name=${cur%%=*}\n"
    "      _packmesh_value \"$cmd:$name\"\n"
    "      _packmesh_values \"$REPLY\" \"${cur#*=}\" \"$name=\" \"$method\"\n"
    "    elif [[ $cur == -* || -z $operand || ( -z $cur && operands -gt 0 ) ]]; then\n"
    "      _packmesh_options \"$cmd\"\n"
    "      _packmesh_words \"$cur\" \"$REPLY\"\n"
    "    else\n"
    "      _packmesh_values \"$operand\" \"$cur\" \"\" \"$method\"\n"
    "    fi\n"
    "  fi\n"
    "  # A lone reply that asks for more (case:, KEY=) gets no space after it.\n"
    "  if ((${#COMPREPLY[@]} == 1)) && [[ ${COMPREPLY[0]} == *[:=] ]]; then\n"
    "    compopt -o nospace 2>/dev/null\n"
    "  fi\n"
    "  if [[ -n $keep ]]; then\n"
    "    for i in \"${!COMPREPLY[@]}\"; do COMPREPLY[i]=${COMPREPLY[i]#\"$keep\"}; done\n"
    "  fi\n"
    "  return 0\n"
    "}\n"
    "\n"
    "complete -F _packmesh packmesh\n";

int pm_cli_bash_completion(FILE *f) {
  fprintf(f,
          "# bash completion for packmesh %s, made by 'packmesh help --bash-completion' from the\n"
          "# tables its --help texts print (commands, options, methods and their parameters,\n"
          "# built-in cases): make it again with that command rather than edit it.\n\n",
          pm_version());
  if (put_commands(f)) return -1;
  fputc('\n', f);
  if (put_methods(f)) return -1;
  fputc('\n', f);
  put_inputs(f);
  fputc('\n', f);
  fputs(logic, f);
  return 0;
}
