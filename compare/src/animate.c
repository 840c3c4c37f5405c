/* `packmesh animate`: a folder of frames (`packmesh mesh --frames DIR` on a planar input) made
 * into an animated GIF and a self-contained HTML player.
 *
 * The GIF is drawn by gnuplot's gif terminal (`animate`, libgd), one plot per frame from the
 * frame's numbers (frame_NNNNNN.dat, written beside its SVG by report/frames.c): the boundary,
 * the faint triangulation, the particles as circles in their colours, the phase and step as the
 * title. The player is one HTML file holding every SVG picture inline, a slider, a play / pause
 * button and the frame's number, with no file or script from elsewhere, so it can be mailed or
 * put beside a report. Both are written under temporary names and renamed into place together,
 * or neither exists.
 */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "common/base/atomic_file.h"
#include "compare/src/study.h"

#define GIF_TIMEOUT_S 300

static int by_name(const void *a, const void *b) {
  return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The frame_NNNNNN.svg names of dir, sorted (the frames' order); *n of them. */
static pm_status list_frames(const char *dir, char ***out, int *n, pm_error *err) {
  *out = NULL, *n = 0;
  DIR *d = opendir(dir);
  if (!d) return pm_error_setf(err, PM_ERR_IO, "cannot read the frames folder '%s'", dir);
  char **v = NULL;
  int cap = 0;
  struct dirent *e;
  pm_status s = PM_OK;
  while ((e = readdir(d)) && !s) {
    int k = -1, len = 0;
    if (sscanf(e->d_name, "frame_%6d.svg%n", &k, &len) != 1 || k < 0 ||
        len != (int)strlen(e->d_name) || strlen(e->d_name) != 16)
      continue;
    if (*n == cap) {
      cap = cap ? 2 * cap : 64;
      char **g = realloc(v, (size_t)cap * sizeof *g);
      if (!g) {
        s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
        break;
      }
      v = g;
    }
    if (!(v[*n] = strdup(e->d_name))) s = pm_error_setf(err, PM_ERR_NOMEM, "out of memory");
    else ++*n;
  }
  closedir(d);
  if (!s && *n == 0)
    s = pm_error_setf(err, PM_ERR_ARG,
                      "'%s' holds no frame_NNNNNN.svg pictures ('packmesh mesh --frames DIR' "
                      "draws them for planar inputs)",
                      dir);
  if (s) {
    for (int i = 0; i < *n; ++i) free(v[i]);
    free(v);
    *n = 0;
    return s;
  }
  qsort(v, (size_t)*n, sizeof *v, by_name);
  *out = v;
  return PM_OK;
}

/* The player: the SVGs inline, one shown at a time. */
static pm_status write_player(const char *dir, char **names, int n, int delay_ms,
                              const char *path, pm_error *err) {
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, path, 1, err);
  if (s) return s;
  FILE *o = a.f;
  fprintf(o, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
             "<title>packmesh animation (%d frames)</title>\n<style>\n"
             "body{font-family:sans-serif;margin:1em}\n.frame{display:none}\n"
             ".frame.on{display:block}\n.frame svg{max-width:100%%;height:auto;border:1px solid #ccc}\n"
             "#bar{display:flex;gap:1em;align-items:center;margin:.5em 0}\n"
             "#slider{flex:1;max-width:640px}\n</style></head><body>\n"
             "<div id=\"bar\"><button id=\"play\" type=\"button\">play</button>\n"
             "<input id=\"slider\" type=\"range\" min=\"0\" max=\"%d\" value=\"0\" step=\"1\" "
             "aria-label=\"frame\">\n<span id=\"label\">frame 1 of %d</span></div>\n",
          n, n - 1, n);
  for (int i = 0; i < n && !s; ++i) {
    char p[4400];
    snprintf(p, sizeof p, "%s/%s", dir, names[i]);
    char *svg = pm_cmp_read_file(p, NULL);
    if (!svg) {
      s = pm_error_setf(err, PM_ERR_IO, "cannot read '%s'", p);
      break;
    }
    fprintf(o, "<div class=\"frame%s\" id=\"f%d\">%s</div>\n", i ? "" : " on", i, svg);
    free(svg);
  }
  fprintf(o,
          "<script>\n(function(){\n"
          "var n=%d, delay=%d, cur=0, timer=null;\n"
          "var slider=document.getElementById('slider'), label=document.getElementById('label'),\n"
          "    play=document.getElementById('play');\n"
          "function show(i){document.getElementById('f'+cur).classList.remove('on');\n"
          "  cur=i; document.getElementById('f'+cur).classList.add('on');\n"
          "  slider.value=cur; label.textContent='frame '+(cur+1)+' of '+n;}\n"
          "function stop(){if(timer){clearInterval(timer);timer=null;} play.textContent='play';}\n"
          "slider.addEventListener('input',function(){stop(); show(parseInt(slider.value,10));});\n"
          "play.addEventListener('click',function(){\n"
          "  if(timer){stop();return;}\n"
          "  play.textContent='pause';\n"
          "  timer=setInterval(function(){show((cur+1)%%n);},delay);});\n"
          "window.pmShow=show;\n"
          "})();\n</script>\n</body></html>\n",
          n, delay_ms);
  if (s) {
    pm_atomic_abort(&a);
    return s;
  }
  return pm_atomic_commit(&a, err);
}

/* The value after "# KEY: " in a frame's .dat header, copied into out; 0 when absent. */
static int dat_header(const char *text, const char *key, char *out, size_t len) {
  char pat[64];
  snprintf(pat, sizeof pat, "# %s: ", key);
  const char *p = strstr(text, pat);
  if (!p) return 0;
  p += strlen(pat);
  size_t k = strcspn(p, "\n");
  if (k >= len) k = len - 1;
  memcpy(out, p, k);
  out[k] = '\0';
  return 1;
}

/* The gnuplot script of the GIF, into script_path; the GIF goes to gif_path. */
static pm_status write_gif_script(const char *dir, char **names, int n, int delay_ms,
                                  const char *gif_path, const char *script_path, pm_error *err) {
  pm_atomic_file a;
  pm_status s = pm_atomic_begin(&a, script_path, 1, err);
  if (s) return s;
  FILE *o = a.f;
  double box[4] = {0, 0, 1, 1};
  for (int i = 0; i < n && !s; ++i) {
    char p[4400], dat[4400];
    snprintf(p, sizeof p, "%s/%s", dir, names[i]);
    snprintf(dat, sizeof dat, "%.*s.dat", (int)(strlen(p) - 4), p);
    char *text = pm_cmp_read_file(dat, NULL);
    char title[256], boxt[256], ntri[32], filled[32];
    if (!text || !dat_header(text, "title", title, sizeof title) ||
        !dat_header(text, "box", boxt, sizeof boxt) ||
        !dat_header(text, "triangles", ntri, sizeof ntri) ||
        !dat_header(text, "filled", filled, sizeof filled) ||
        (i == 0 && sscanf(boxt, "%lf %lf %lf %lf", &box[0], &box[1], &box[2], &box[3]) != 4)) {
      free(text);
      s = pm_error_setf(err, PM_ERR_IO,
                        "'%s' is missing or not a frame's numbers (frames from an older "
                        "packmesh have none: run 'packmesh mesh --frames' again)",
                        dat);
      break;
    }
    free(text);
    if (i == 0) {
      double w = box[2] - box[0], h = box[3] - box[1], k = 640 / (w > h ? w : h);
      fprintf(o, "set terminal gif animate delay %d loop 0 size %d,%d font \"DejaVuSans,10\"\n",
              delay_ms / 10 > 0 ? delay_ms / 10 : 1, (int)(w * k) + 20, (int)(h * k) + 50);
      fprintf(o, "set output \"%s\"\nunset key\nunset border\nunset tics\nset size ratio -1\n"
                 "set xrange [%.9g:%.9g]\nset yrange [%.9g:%.9g]\n",
              gif_path, box[0], box[2], box[1], box[3]);
    }
    for (char *q = title; *q; ++q)
      if (*q == '"' || *q == '\\') *q = '\'';
    /* The triangulation under the boundary, the particles on top. */
    fprintf(o, "set title \"%s\"\nplot ", title);
    if (atoi(ntri) > 0) fprintf(o, "\"%s\" index 1 with lines lc rgb \"#c0c0c0\" lw 0.6, ", dat);
    fprintf(o, "\"%s\" index 0 with lines lc rgb \"black\" lw 1.5", dat);
    /* As the SVG: filled by energy when the frame is, else outlined by cell dimension. */
    fprintf(o, ", \"%s\" index 2 using 1:2:3:4 with circles lc rgb variable %s\n", dat,
            atoi(filled) ? "fs transparent solid 0.55 border" : "fs empty border");
  }
  fprintf(o, "set output\n");
  if (s) {
    pm_atomic_abort(&a);
    return s;
  }
  return pm_atomic_commit(&a, err);
}

pm_status pm_cmp_animate(const char *frames_dir, const char *out, int delay_ms, int *nframes,
                         pm_error *err) {
  char **names = NULL;
  int n = 0;
  if (nframes) *nframes = 0;
  pm_status s = list_frames(frames_dir, &names, &n, err);
  if (s) return s;
  char html[4400], gif[4400], html_tmp[4400], gif_tmp[4400], gp[4400], logp[4400];
  snprintf(html, sizeof html, "%s.html", out);
  snprintf(gif, sizeof gif, "%s.gif", out);
  snprintf(html_tmp, sizeof html_tmp, "%s.pmtmp-%d.html", out, (int)getpid());
  snprintf(gif_tmp, sizeof gif_tmp, "%s.pmtmp-%d.gif", out, (int)getpid());
  snprintf(gp, sizeof gp, "%s.pmtmp-%d.gp", out, (int)getpid());
  snprintf(logp, sizeof logp, "%s.pmtmp-%d.log", out, (int)getpid());
  int track[4] = {pm_tmp_track(html_tmp, 0), pm_tmp_track(gif_tmp, 0), pm_tmp_track(gp, 0),
                  pm_tmp_track(logp, 0)};
  s = write_player(frames_dir, names, n, delay_ms, html_tmp, err);
  if (!s) s = write_gif_script(frames_dir, names, n, delay_ms, gif_tmp, gp, err);
  if (!s) {
    char *argv[] = {"gnuplot", gp, NULL};
    int ws = 0, to = 0;
    int rc = pm_cmp_run_program(argv, NULL, NULL, logp, GIF_TIMEOUT_S, &ws, &to);
    struct stat sb;
    if (rc != 0)
      s = pm_error_setf(err, PM_ERR_IO, "cannot run gnuplot, which draws the GIF (is it installed?)");
    else if (to)
      s = pm_error_setf(err, PM_ERR_IO, "gnuplot took more than %d s drawing the GIF", GIF_TIMEOUT_S);
    else if (!WIFEXITED(ws) || WEXITSTATUS(ws) != 0 || stat(gif_tmp, &sb) != 0 || sb.st_size == 0)
      s = pm_error_setf(err, PM_ERR_IO, "gnuplot could not draw the GIF (its gif terminal is "
                                        "needed: Debian's gnuplot-nox has it)");
  }
  if (!s && (rename(gif_tmp, gif) != 0 || rename(html_tmp, html) != 0)) {
    s = pm_error_setf(err, PM_ERR_IO, "cannot write '%s' and '%s'", gif, html);
    unlink(gif);
  }
  unlink(html_tmp), unlink(gif_tmp), unlink(gp), unlink(logp);
  for (int k = 0; k < 4; ++k) pm_tmp_untrack(track[k]);
  for (int i = 0; i < n; ++i) free(names[i]);
  free(names);
  if (!s && nframes) *nframes = n;
  return s;
}
