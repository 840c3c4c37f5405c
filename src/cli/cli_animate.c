/* packmesh animate: the frames of a run (`packmesh mesh --frames DIR`) as an animated GIF and an
 * HTML player (the comparison engine's pm_cmp_animate, compare/src/animate.c).
 *
 *   packmesh animate FRAMES_DIR -o OUT [--delay MS]
 */
#include <stdio.h>
#include <string.h>

#include "cli/cli.h"
#include "cli/cli_util.h"
#include "compare/src/compare.h"

#define DEFAULT_DELAY_MS 120

void pm_cli_animate_usage(FILE *f) {
  fprintf(f,
          "usage: packmesh animate FRAMES_DIR -o OUT [--delay MS]\n"
          "\n"
          "Turn the frames of a run into an animation: OUT.gif, an animated GIF drawn by gnuplot,\n"
          "and OUT.html, a player of the frames' SVG pictures with a slider and a play / pause\n"
          "button that needs no other file. FRAMES_DIR is what 'packmesh mesh --frames DIR' wrote\n"
          "for a planar input (frame_NNNNNN.svg and .dat: the particles over their triangulation,\n"
          "with the phase and the step).\n"
          "  -o, --output OUT  the two files' path without extension: OUT.gif and OUT.html\n"
          "  --delay MS        the time each frame is shown, in milliseconds (10 to 60000; default\n"
          "                    %d)\n"
          "  --help            this text\n"
          "\n"
          "Both files are written together or not at all. For example, 'packmesh mesh case:qi3\n"
          "--method bubble -o qi3.msh --frames qi3-frames' and then 'packmesh animate qi3-frames\n"
          "-o qi3-bubble' write qi3-bubble.gif and qi3-bubble.html.\n",
          DEFAULT_DELAY_MS);
}

int pm_cli_animate(int argc, char **argv) {
  const char *dir = NULL, *out = NULL;
  long delay = DEFAULT_DELAY_MS;
  for (int i = 1; i < argc;) {
    const char *a = argv[i], *v = NULL;
    int r;
    if (pm_cli_flag(a, "help") || strcmp(a, "-h") == 0) {
      pm_cli_animate_usage(stdout);
      return PM_EXIT_OK;
    }
    if (strcmp(a, "-o") == 0) {
      if (i + 1 >= argc) return pm_cli_usage("animate", "-o needs a path");
      out = argv[i + 1];
      i += 2;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "output", &v)) != 0) {
      if (r < 0) return pm_cli_usage("animate", "--output needs a path");
      out = v;
      continue;
    }
    if ((r = pm_cli_option(argc, argv, &i, "delay", &v)) != 0) {
      if (r < 0 || !pm_cli_parse_long(v, 10, 60000, &delay))
        return pm_cli_usage("animate", "--delay takes a whole number of milliseconds from 10 to "
                                       "60000");
      continue;
    }
    if (a[0] == '-' && a[1]) return pm_cli_usage("animate", "unknown option '%s'", a);
    if (dir) return pm_cli_usage("animate", "one frames folder expected, got '%s' too", a);
    dir = a;
    ++i;
  }
  if (!dir) return pm_cli_usage("animate", "no frames folder given");
  if (!out || !*out) return pm_cli_usage("animate", "no output given (-o OUT)");
  pm_error e = {0};
  int n = 0;
  if (pm_cmp_animate(dir, out, (int)delay, &n, &e)) return pm_cli_error(&e);
  printf("%d frames -> %s.gif, %s.html\n", n, out, out);
  return PM_EXIT_OK;
}
