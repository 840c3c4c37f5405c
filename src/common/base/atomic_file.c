/* Output files that appear whole or not at all (see atomic_file.h). */
#include "common/base/atomic_file.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include "common/base/hash.h"

/* ---- live temporaries -----------------------------------------------------------------------
 * A fixed table, so that a signal handler can read it without allocating or locking. A record
 * is filled while its state is BUSY and published by the store of ACTIVE (release order); the
 * handler reads only ACTIVE records. Records are handed out round-robin, so a record just freed
 * is not refilled while a handler on another thread may still be reading it. */

enum { SLOT_FREE = 0, SLOT_BUSY, SLOT_ACTIVE };
#define TMP_SLOTS 128
#define TMP_PATH 4096

typedef struct tmp_slot {
  atomic_int state;
  int folder;
  uint64_t seq;
  char path[TMP_PATH];
} tmp_slot;

static tmp_slot slots[TMP_SLOTS];
static atomic_uint_fast64_t next_seq = 1;
static atomic_uint next_slot;

int pm_tmp_track(const char *path, int folder) {
  size_t n = strlen(path);
  if (n >= TMP_PATH) return -1;
  for (int tries = 0; tries < TMP_SLOTS; ++tries) {
    unsigned i = atomic_fetch_add(&next_slot, 1) % TMP_SLOTS;
    int expected = SLOT_FREE;
    if (!atomic_compare_exchange_strong(&slots[i].state, &expected, SLOT_BUSY)) continue;
    memcpy(slots[i].path, path, n + 1);
    slots[i].folder = folder;
    slots[i].seq = atomic_fetch_add(&next_seq, 1);
    atomic_store_explicit(&slots[i].state, SLOT_ACTIVE, memory_order_release);
    return (int)i;
  }
  return -1;
}

void pm_tmp_untrack(int id) {
  if (id >= 0 && id < TMP_SLOTS) atomic_store(&slots[id].state, SLOT_FREE);
}

/* getdents64's record (the kernel's layout): readdir is not async-signal-safe, this is. */
typedef struct dirent64_rec {
  uint64_t d_ino;
  int64_t d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[];
} dirent64_rec;

/* Remove a folder with the files (and empty folders) in it. Async-signal-safe. */
static void remove_folder(const char *path) {
  int fd = open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC | O_NOFOLLOW);
  if (fd >= 0) {
    _Alignas(8) char buf[4096];
    /* Removing entries while listing may skip some: list again until a pass removes none. */
    for (int pass = 0; pass < 64; ++pass) {
      int removed = 0;
      lseek(fd, 0, SEEK_SET);
      long n;
      while ((n = syscall(SYS_getdents64, fd, buf, sizeof buf)) > 0)
        for (long off = 0; off < n;) {
          const dirent64_rec *d = (const dirent64_rec *)(buf + off);
          off += d->d_reclen;
          const char *nm = d->d_name;
          if (nm[0] == '.' && (nm[1] == '\0' || (nm[1] == '.' && nm[2] == '\0'))) continue;
          if (unlinkat(fd, nm, 0) == 0 || unlinkat(fd, nm, AT_REMOVEDIR) == 0) removed = 1;
        }
      if (!removed) break;
    }
    close(fd);
  }
  rmdir(path);
}

void pm_tmp_remove_all(void) {
  unsigned char done[TMP_SLOTS] = {0};
  for (;;) {
    int best = -1;
    uint64_t best_seq = 0;
    for (int i = 0; i < TMP_SLOTS; ++i)
      if (!done[i] && atomic_load_explicit(&slots[i].state, memory_order_acquire) == SLOT_ACTIVE &&
          slots[i].seq >= best_seq)
        best = i, best_seq = slots[i].seq;
    if (best < 0) return;
    done[best] = 1;
    if (slots[best].folder)
      remove_folder(slots[best].path);
    else
      unlink(slots[best].path);
  }
}

/* ---- temporary names ------------------------------------------------------------------------ */

/* The extension of the last path component, with its dot, or "" . */
static const char *ext_of(const char *path) {
  const char *slash = strrchr(path, '/');
  const char *base = slash ? slash + 1 : path;
  const char *dot = strrchr(base, '.');
  return (dot && dot != base) ? dot : path + strlen(path);
}

/* Six characters that make a temporary's name unlikely to be taken (O_EXCL settles it). */
static void random_tag(char out[7]) {
  static atomic_uint_fast64_t counter;
  struct timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  uint64_t h = pm_mix64((uint64_t)getpid() ^ pm_mix64(atomic_fetch_add(&counter, 1)) ^
                        pm_mix64((uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec));
  static const char alphabet[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
  for (int i = 0; i < 6; ++i, h /= 62) out[i] = alphabet[h % 62];
  out[6] = '\0';
}

/* Make a temporary file "<stem>.pmtmp-XXXXXX<ext>" (folder: "<path>.pmtmp-XXXXXX") recorded
 * among the live temporaries before it exists, so that a signal at any point finds it.
 * *name is malloc'ed; *fd the open file (files only). Returns 0 or an errno value. */
static int make_temp(const char *path, int folder, char **name, int *slot, int *fd) {
  const char *ext = folder ? path + strlen(path) : ext_of(path);
  size_t n = strlen(path), stem = (size_t)(ext - path);
  char *t = malloc(n + 16);
  if (!t) return ENOMEM;
  int e = EEXIST;
  for (int tries = 0; tries < 100 && e == EEXIST; ++tries) {
    char tag[7];
    random_tag(tag);
    snprintf(t, n + 16, "%.*s.pmtmp-%s%s", (int)stem, path, tag, ext);
    *slot = pm_tmp_track(t, folder);
    /* 0666 / 0777 less the umask, as for any file a program makes. */
    int ok = folder ? mkdir(t, 0777) : (*fd = open(t, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666));
    e = ok < 0 ? errno : 0;
    if (e) pm_tmp_untrack(*slot);
  }
  if (e) {
    free(t);
    *slot = -1;
    return e;
  }
  *name = t;
  return 0;
}

/* Block SIGINT and SIGTERM in this thread while a rename and its record change go together. */
static void signals_hold(sigset_t *old) {
  sigset_t s;
  sigemptyset(&s);
  sigaddset(&s, SIGINT);
  sigaddset(&s, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &s, old);
}
static void signals_release(const sigset_t *old) { pthread_sigmask(SIG_SETMASK, old, NULL); }

/* ---- one file -------------------------------------------------------------------------------- */

pm_status pm_atomic_begin(pm_atomic_file *a, const char *path, int stream, pm_error *err) {
  memset(a, 0, sizeof *a);
  a->slot = -1;
  if (!path || !path[0]) return pm_error_setf(err, PM_ERR_ARG, "no output file name given");
  a->path = strdup(path);
  if (!a->path) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  int fd = -1;
  int e = make_temp(path, 0, &a->tmp, &a->slot, &fd);
  if (e) {
    pm_status s = pm_error_setf(err, e == ENOMEM ? PM_ERR_NOMEM : PM_ERR_IO, "cannot write %s: %s",
                                path, strerror(e));
    pm_atomic_abort(a);
    return s;
  }
  if (stream) {
    a->f = fdopen(fd, "w");
    if (!a->f) {
      pm_status s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno));
      close(fd);
      pm_atomic_abort(a);
      return s;
    }
  } else {
    close(fd);
  }
  return PM_OK;
}

pm_status pm_atomic_commit(pm_atomic_file *a, pm_error *err) {
  pm_status s = PM_OK;
  if (a->f) {
    int bad = ferror(a->f);
    int e = errno;
    if (fclose(a->f) != 0) {
      bad = 1;
      e = errno;
    }
    a->f = NULL;
    if (bad) s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", a->path, strerror(e));
  }
  if (!s) {
    sigset_t old;
    signals_hold(&old);
    if (rename(a->tmp, a->path) != 0)
      s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", a->path, strerror(errno));
    else
      pm_tmp_untrack(a->slot), a->slot = -1;
    signals_release(&old);
  }
  if (s) {
    pm_atomic_abort(a);
    return s;
  }
  free(a->tmp);
  free(a->path);
  memset(a, 0, sizeof *a);
  a->slot = -1;
  return PM_OK;
}

void pm_atomic_abort(pm_atomic_file *a) {
  if (!a) return;
  if (a->f) fclose(a->f);
  if (a->tmp) unlink(a->tmp);
  if (a->tmp || a->slot >= 0) pm_tmp_untrack(a->slot);
  free(a->tmp);
  free(a->path);
  memset(a, 0, sizeof *a);
  a->slot = -1;
}

pm_status pm_atomic_write(const char *path, const void *data, size_t len, pm_error *err) {
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  if (len && fwrite(data, 1, len, a.f) != len) {
    s = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", path, strerror(errno));
    pm_atomic_abort(&a);
    return s;
  }
  return pm_atomic_commit(&a, err);
}

/* ---- paths ----------------------------------------------------------------------------------- */

/* path without trailing slashes (malloc'ed; "/" stays "/"). */
static char *trimmed(const char *path) {
  char *p = strdup(path);
  if (!p) return NULL;
  size_t n = strlen(p);
  while (n > 1 && p[n - 1] == '/') p[--n] = '\0';
  return p;
}

/* Split a trimmed path into its folder ("." when none) and its last component. */
static void split(const char *p, char *dir, size_t dlen, const char **base) {
  const char *slash = strrchr(p, '/');
  if (!slash) {
    snprintf(dir, dlen, ".");
    *base = p;
  } else if (slash == p) {
    snprintf(dir, dlen, "/");
    *base = slash + 1;
  } else {
    snprintf(dir, dlen, "%.*s", (int)(slash - p), p);
    *base = slash + 1;
  }
}

int pm_path_same(const char *a, const char *b) {
  char *x = trimmed(a), *y = trimmed(b);
  int same = 0;
  if (x && y) {
    struct stat sa, sb;
    if (stat(x, &sa) == 0 && stat(y, &sb) == 0) {
      same = sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    } else {
      char da[4096], db[4096];
      const char *ba, *bb;
      split(x, da, sizeof da, &ba);
      split(y, db, sizeof db, &bb);
      if (strcmp(ba, bb) == 0) {
        if (stat(da, &sa) == 0 && stat(db, &sb) == 0)
          same = sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
        else
          same = strcmp(da, db) == 0;
      }
    }
  }
  free(x);
  free(y);
  return same;
}

/* ---- a set of outputs ------------------------------------------------------------------------ */

typedef struct out_item {
  char *path, *tmp;
  int folder;
  int slot;        /* the temporary's record */
  char **moved;    /* folder merged into an existing one: the files moved there */
  int nmoved;
  int renamed;     /* the destination is ours: renamed into place */
} out_item;

struct pm_outputs {
  out_item *it;
  int n, cap;
  char **made;     /* parent folders made for folder outputs, in the order made */
  int *made_slot;
  int nmade, capmade;
};

pm_outputs *pm_outputs_create(void) { return calloc(1, sizeof(pm_outputs)); }

static pm_status make_parents(pm_outputs *s, const char *path, pm_error *err) {
  char buf[4096];
  if (snprintf(buf, sizeof buf, "%s", path) >= (int)sizeof buf)
    return pm_error_setf(err, PM_ERR_ARG, "path too long: %s", path);
  char *last = strrchr(buf, '/');
  if (!last || last == buf) return PM_OK;
  *last = '\0';
  for (char *p = buf + 1;; ++p) {
    if (*p != '/' && *p != '\0') continue;
    char c = *p;
    *p = '\0';
    struct stat st;
    if (stat(buf, &st) != 0) {
      if (s->nmade == s->capmade) {
        int cap = s->capmade ? 2 * s->capmade : 8;
        char **m = realloc(s->made, (size_t)cap * sizeof *m);
        int *ms = m ? realloc(s->made_slot, (size_t)cap * sizeof *ms) : NULL;
        if (m) s->made = m;
        if (!ms) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        s->made_slot = ms, s->capmade = cap;
      }
      int slot = pm_tmp_track(buf, 1);
      if (mkdir(buf, 0777) != 0) {
        int e = errno;
        pm_tmp_untrack(slot);
        return pm_error_setf(err, PM_ERR_IO, "cannot create folder '%s': %s", buf, strerror(e));
      }
      s->made[s->nmade] = strdup(buf);
      s->made_slot[s->nmade++] = slot;
    } else if (!S_ISDIR(st.st_mode)) {
      return pm_error_setf(err, PM_ERR_IO, "cannot write %s: '%s' is not a folder", path, buf);
    }
    *p = c;
    if (c == '\0') break;
  }
  return PM_OK;
}

pm_status pm_outputs_add(pm_outputs *s, const char *path, int folder, const char **tmp,
                         pm_error *err) {
  *tmp = NULL;
  if (!path || !path[0]) return pm_error_setf(err, PM_ERR_ARG, "no output name given");
  for (int i = 0; i < s->n; ++i)
    if (pm_path_same(s->it[i].path, path))
      return pm_error_setf(err, PM_ERR_ARG, "'%s' names the same file as '%s'", path, s->it[i].path);
  if (s->n == s->cap) {
    int cap = s->cap ? 2 * s->cap : 8;
    out_item *it = realloc(s->it, (size_t)cap * sizeof *it);
    if (!it) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    s->it = it, s->cap = cap;
  }
  out_item *o = &s->it[s->n];
  memset(o, 0, sizeof *o);
  o->slot = -1;
  o->folder = folder;
  o->path = trimmed(path);
  if (!o->path) return pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
  struct stat st;
  pm_status r = PM_OK;
  if (stat(o->path, &st) == 0 && !folder && S_ISDIR(st.st_mode))
    r = pm_error_setf(err, PM_ERR_IO, "cannot write %s: it is a folder", path);
  else if (stat(o->path, &st) == 0 && folder && !S_ISDIR(st.st_mode))
    r = pm_error_setf(err, PM_ERR_IO, "cannot make folder %s: a file of that name exists", path);
  else if (folder)
    r = make_parents(s, o->path, err);
  if (!r) {
    int fd = -1;
    int e = make_temp(o->path, folder, &o->tmp, &o->slot, &fd);
    if (fd >= 0) close(fd);
    if (e)
      r = pm_error_setf(err, e == ENOMEM ? PM_ERR_NOMEM : PM_ERR_IO, "cannot write %s: %s", path,
                        strerror(e));
  }
  if (r) {
    free(o->path);
    return r;
  }
  ++s->n;
  *tmp = o->tmp;
  return PM_OK;
}

/* Move the files of o's temporary folder into its existing destination, recording them in
 * o->moved; returns 0 or an errno value. */
static int merge_folder(out_item *o) {
  int fd = open(o->tmp, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return errno;
  _Alignas(8) char buf[4096];
  long n;
  int e = 0;
  while (!e && (n = syscall(SYS_getdents64, fd, buf, sizeof buf)) > 0)
    for (long off = 0; off < n && !e;) {
      const dirent64_rec *d = (const dirent64_rec *)(buf + off);
      off += d->d_reclen;
      const char *nm = d->d_name;
      if (nm[0] == '.' && (nm[1] == '\0' || (nm[1] == '.' && nm[2] == '\0'))) continue;
      size_t lf = strlen(o->tmp) + strlen(nm) + 2, lt = strlen(o->path) + strlen(nm) + 2;
      char *from = malloc(lf), *to = malloc(lt);
      char **mv = realloc(o->moved, (size_t)(o->nmoved + 1) * sizeof *mv);
      if (mv) o->moved = mv;
      if (!from || !to || !mv) {
        free(from), free(to);
        e = ENOMEM;
        break;
      }
      snprintf(from, lf, "%s/%s", o->tmp, nm);
      snprintf(to, lt, "%s/%s", o->path, nm);
      if (rename(from, to) != 0) {
        e = errno;
        free(to);
      } else {
        o->moved[o->nmoved++] = to;
      }
      free(from);
    }
  close(fd);
  return e;
}

/* Undo a committed output: its destination is removed (what it replaced is gone already). */
static void undo(out_item *o) {
  if (o->renamed) {
    if (o->folder)
      remove_folder(o->path);
    else
      unlink(o->path);
  }
  for (int k = 0; k < o->nmoved; ++k) unlink(o->moved[k]);
  o->renamed = 0;
}

pm_status pm_outputs_commit(pm_outputs *s, pm_error *err) {
  sigset_t old;
  signals_hold(&old);
  pm_status r = PM_OK;
  int i = 0;
  for (; i < s->n && !r; ++i) {
    out_item *o = &s->it[i];
    struct stat st;
    int e = 0;
    if (o->folder && stat(o->path, &st) == 0) {
      /* An existing folder: replaced when empty, else its files are moved in. */
      if (rename(o->tmp, o->path) == 0) {
        o->renamed = 1;
      } else if (errno == ENOTEMPTY || errno == EEXIST) {
        e = merge_folder(o);
        if (!e && rmdir(o->tmp) != 0) e = errno;
      } else {
        e = errno;
      }
    } else if (rename(o->tmp, o->path) == 0) {
      o->renamed = 1;
    } else {
      e = errno;
    }
    if (e) r = pm_error_setf(err, PM_ERR_IO, "cannot write %s: %s", o->path, strerror(e));
  }
  /* A signal that came while the outputs were being put in place wins: nothing is left. */
  sigset_t pending;
  if (!r && sigpending(&pending) == 0 &&
      (sigismember(&pending, SIGINT) == 1 || sigismember(&pending, SIGTERM) == 1))
    r = pm_error_setf(err, PM_ERR_IO, "interrupted while writing the outputs");
  if (r) {
    for (int k = 0; k < s->n; ++k) undo(&s->it[k]);
  } else {
    for (int k = 0; k < s->n; ++k) {
      out_item *o = &s->it[k];
      free(o->tmp), o->tmp = NULL;
      pm_tmp_untrack(o->slot), o->slot = -1;
    }
    /* The parent folders made are kept. */
    for (int k = 0; k < s->nmade; ++k) pm_tmp_untrack(s->made_slot[k]), free(s->made[k]);
    s->nmade = 0;
  }
  signals_release(&old);
  return r;
}

void pm_outputs_destroy(pm_outputs *s) {
  if (!s) return;
  for (int i = 0; i < s->n; ++i) {
    out_item *o = &s->it[i];
    if (o->tmp) {
      if (o->folder)
        remove_folder(o->tmp);
      else
        unlink(o->tmp);
    }
    pm_tmp_untrack(o->slot);
    free(o->tmp);
    free(o->path);
    for (int k = 0; k < o->nmoved; ++k) free(o->moved[k]);
    free(o->moved);
  }
  for (int k = s->nmade - 1; k >= 0; --k) {
    rmdir(s->made[k]);
    pm_tmp_untrack(s->made_slot[k]);
    free(s->made[k]);
  }
  free(s->made);
  free(s->made_slot);
  free(s->it);
  free(s);
}
