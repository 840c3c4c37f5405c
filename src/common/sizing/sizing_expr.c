/* Size fields given as expressions in x, y, z and r = sqrt(x^2 + y^2 + z^2), parsed and
 * evaluated by muparser through its C API (muParserDLL.h). muparser provides the functions
 * (sin, cos, tan, asin, ..., sinh, ..., log, log2, log10, ln, exp, sqrt, sign, rint, abs, min,
 * max, sum, avg), the operators (+ - * / ^, comparisons, the ternary ?:) and the constants _pi
 * and _e.
 *
 * Thread safety. A muparser handle evaluates through its own stack and reads its variables
 * from the addresses bound to it, so one handle cannot serve two threads at once. Each thread
 * therefore gets its own handle ("slot"), made the first time that thread evaluates the field:
 *   - a slot belongs to the thread that made it (identified by the address of a thread-local
 *     token, unique among live threads; a thread that ends leaves its slot to whichever later
 *     thread reuses its storage, never to two threads at once);
 *   - the hot path looks the field up in a small thread-local cache keyed by the field's serial
 *     number (never reused, so an entry left by a destroyed field can never match) and takes no
 *     lock; only a miss takes the field's lock to find or make the thread's slot;
 *   - muparser's parser construction is serialized by one process-wide lock as a precaution:
 *     it builds its operator and function tables and touches shared locale state;
 *   - the slots are freed with the field, whichever thread destroys it.
 * Evaluation then costs one cache lookup, setting x, y, z (and r when the expression uses it)
 * and muparser's bytecode evaluation.
 */
#include "common/sizing/sizing_private.h"

#include <math.h>
#include <muParserDLL.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct sz_slot {
  muParserHandle_t h;
  double var[4];        /* x, y, z, r: bound to the handle */
  const void *owner;    /* the owning thread's token */
  struct sz_slot *next; /* all slots of the field */
} sz_slot;

struct sz_expr {
  char *text;
  uint64_t serial;
  int uses_r;
  pthread_mutex_t lock; /* guards slots */
  sz_slot *slots;
};

static pthread_mutex_t g_mup_lock = PTHREAD_MUTEX_INITIALIZER;
static atomic_uint_least64_t g_serial = 1;

/* Per-thread cache of (field serial -> this thread's slot). Eight ways: a thread rarely
 * evaluates more than a couple of expression fields in an inner loop (a field and its scaled
 * copy share one). */
#define TL_WAYS 8
static _Thread_local struct {
  uint64_t serial;
  sz_slot *slot;
} tl_cache[TL_WAYS];
static _Thread_local unsigned tl_next;
static _Thread_local char tl_token;

/* A new handle for `text` with x, y, z, r bound to slot->var, parsed and checked. On failure
 * returns non-zero and, when msg is not NULL, muparser's message. */
static int slot_init(sz_slot *slot, const char *text, char *msg, size_t len, int *pos) {
  pthread_mutex_lock(&g_mup_lock);
  slot->h = mupCreate(muBASETYPE_FLOAT);
  int bad = slot->h == NULL;
  if (!bad) {
    mupDefineVar(slot->h, "x", &slot->var[0]);
    mupDefineVar(slot->h, "y", &slot->var[1]);
    mupDefineVar(slot->h, "z", &slot->var[2]);
    mupDefineVar(slot->h, "r", &slot->var[3]);
    mupSetExpr(slot->h, text);
    /* muparser parses on the first evaluation; mupError reads and clears the error flag. */
    slot->var[0] = slot->var[1] = slot->var[2] = 0.5;
    slot->var[3] = sqrt(0.75);
    mupEval(slot->h);
    if (mupError(slot->h)) {
      bad = 1;
      if (msg) snprintf(msg, len, "%s", mupGetErrorMsg(slot->h));
      if (pos) *pos = mupGetErrorPos(slot->h);
    }
  } else if (msg) {
    snprintf(msg, len, "muparser could not make a parser");
  }
  pthread_mutex_unlock(&g_mup_lock);
  return bad;
}

static void slot_release(sz_slot *slot) {
  if (slot->h) {
    pthread_mutex_lock(&g_mup_lock);
    mupRelease(slot->h);
    pthread_mutex_unlock(&g_mup_lock);
  }
  free(slot);
}

/* Does the parsed expression read variable `name`? */
static int uses_var(muParserHandle_t h, const char *name) {
  int n = mupGetExprVarNum(h);
  for (int i = 0; i < n; ++i) {
    const muChar_t *v = NULL;
    muFloat_t *p = NULL;
    mupGetExprVar(h, (unsigned)i, &v, &p);
    if (v && strcmp(v, name) == 0) return 1;
  }
  return 0;
}

static inline double eval_slot(const sz_expr *e, sz_slot *s, const double xyz[3]) {
  s->var[0] = xyz[0], s->var[1] = xyz[1], s->var[2] = xyz[2];
  if (e->uses_r) s->var[3] = sqrt(xyz[0] * xyz[0] + xyz[1] * xyz[1] + xyz[2] * xyz[2]);
  return mupEval(s->h);
}

/* Probe points for the creation check: the corners of [-1, 1]^3 and of [0, 1]^3 other than the
 * origin, their centres and a few farther points. The origin is left out because fields such as
 * qi2's r/8 vanish there while being valid on the domain. */
static const double probes[][3] = {
    {0.5, 0.5, 0.5},  {1, 0, 0},      {0, 1, 0},   {0, 0, 1},   {1, 1, 0},    {1, 0, 1},
    {0, 1, 1},        {1, 1, 1},      {-1, -1, -1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1},
    {1, 1, -1},       {1, -1, 1},     {-1, 1, 1},  {-0.5, -0.5, -0.5}, {3, 0, 0},  {0, 3, 0},
    {0.25, 0.75, 0.1}, {10, 10, 10}, {-10, 10, 0}};
#define NPROBE ((int)(sizeof probes / sizeof probes[0]))

pm_status sz_expr_create(const char *text, sz_expr **out, char **desc, pm_error *err) {
  *out = NULL;
  *desc = NULL;
  if (!text) return pm_error_setf(err, PM_ERR_PARSE, "size expression: no text");
  while (*text == ' ' || *text == '\t') ++text;
  size_t n = strlen(text);
  while (n > 0 && (text[n - 1] == ' ' || text[n - 1] == '\t' || text[n - 1] == '\n')) --n;
  if (n == 0) return pm_error_setf(err, PM_ERR_PARSE, "size expression is empty");
  sz_expr *e = calloc(1, sizeof *e);
  sz_slot *slot = calloc(1, sizeof *slot);
  if (e) e->text = strndup(text, n);
  if (!e || !slot || !e->text) {
    if (e) free(e->text);
    free(e), free(slot);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size expression");
  }
  char msg[256] = "";
  int pos = -1;
  pm_status st = PM_OK;
  if (slot_init(slot, e->text, msg, sizeof msg, &pos)) {
    /* muparser's messages mostly name the position; add it where they do not. */
    if (pos >= 0 && !strstr(msg, "position"))
      st = pm_error_setf(err, PM_ERR_PARSE, "size expression '%s': %s at position %d", e->text,
                         msg, pos);
    else
      st = pm_error_setf(err, PM_ERR_PARSE, "size expression '%s': %s", e->text, msg);
  } else {
    int nres = 0;
    mupEvalMulti(slot->h, &nres);
    if (nres != 1)
      st = pm_error_setf(err, PM_ERR_PARSE,
                         "size expression '%s' gives %d values separated by commas; one is "
                         "expected (the decimal separator is '.')",
                         e->text, nres);
  }
  if (!st) {
    e->uses_r = uses_var(slot->h, "r");
    /* Reject an expression that is nowhere usable: no finite positive value at any probe point.
     * One that is bad only in places may still be right on the model (a field may go negative
     * outside the domain); pm_sizing_check judges it against the model. */
    int good = 0;
    double v0 = 0;
    for (int i = 0; i < NPROBE && !good; ++i) {
      double v = eval_slot(e, slot, probes[i]);
      if (i == 0) v0 = v;
      good = isfinite(v) && v > 0;
    }
    if (!good)
      st = pm_error_setf(err, PM_ERR_ARG,
                         "size expression '%s' is not a finite number > 0 anywhere it was probed "
                         "(%g at (0.5, 0.5, 0.5))",
                         e->text, v0);
  }
  if (st) {
    slot_release(slot);
    free(e->text);
    free(e);
    return st;
  }
  *desc = strdup(e->text);
  if (!*desc) {
    slot_release(slot);
    free(e->text);
    free(e);
    return pm_error_setf(err, PM_ERR_NOMEM, "out of memory for a size expression");
  }
  pthread_mutex_init(&e->lock, NULL);
  e->serial = atomic_fetch_add(&g_serial, 1);
  /* The parse-check handle becomes the creating thread's slot. */
  slot->owner = &tl_token;
  e->slots = slot;
  *out = e;
  return PM_OK;
}

/* The calling thread's slot, found or made under the field's lock; NULL when out of memory. */
static sz_slot *slot_for_thread(sz_expr *e) {
  sz_slot *s;
  pthread_mutex_lock(&e->lock);
  for (s = e->slots; s; s = s->next)
    if (s->owner == &tl_token) break;
  if (!s) {
    s = calloc(1, sizeof *s);
    if (s && slot_init(s, e->text, NULL, 0, NULL)) {
      slot_release(s);
      s = NULL;
    }
    if (s) {
      s->owner = &tl_token;
      s->next = e->slots;
      e->slots = s;
    }
  }
  pthread_mutex_unlock(&e->lock);
  return s;
}

double sz_expr_eval(sz_expr *e, const double xyz[3]) {
  for (int i = 0; i < TL_WAYS; ++i)
    if (tl_cache[i].serial == e->serial) return eval_slot(e, tl_cache[i].slot, xyz);
  sz_slot *s = slot_for_thread(e);
  if (!s) return NAN;
  unsigned w = tl_next++ % TL_WAYS;
  tl_cache[w].serial = e->serial;
  tl_cache[w].slot = s;
  return eval_slot(e, s, xyz);
}

void sz_expr_destroy(sz_expr *e) {
  if (!e) return;
  sz_slot *s = e->slots;
  while (s) {
    sz_slot *next = s->next;
    slot_release(s);
    s = next;
  }
  pthread_mutex_destroy(&e->lock);
  free(e->text);
  free(e);
}
