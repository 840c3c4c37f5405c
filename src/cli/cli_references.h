/* The papers packmesh implements, by the keys its help and reports cite them with: "papers/003"
 * (reports, descriptions) or "003" in a parameter's [SOURCE] (`packmesh mesh --method M --help`).
 * `packmesh references` prints them in full; a comparison report lists the ones it cites. */
#ifndef PM_CLI_REFERENCES_H
#define PM_CLI_REFERENCES_H

typedef struct pm_cli_reference {
  const char *key;      /* "003": cited as papers/003 */
  const char *citation; /* authors, title, where and when it appeared */
  const char *used_for; /* what packmesh takes from it */
} pm_cli_reference;

/* The number of papers and the i-th, in key order (NULL outside 0 .. count - 1). */
int pm_cli_reference_count(void);
const pm_cli_reference *pm_cli_reference_at(int i);

#endif /* PM_CLI_REFERENCES_H */
