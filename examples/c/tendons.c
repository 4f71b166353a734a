/* Servo readings in, shape and tensions out, from plain C (C11): a control loop
 * over the cablesense C ABI on a tendon-driven robot. Each tick sends one row of
 * readings (m, positive = pulled in) of a slow antagonistic pull and reads the
 * tensions, taut flags and tip position into fixed buffers (no allocation per
 * tick); the time per tick is summarised as percentiles. Then a few bad calls show
 * the error messages. Build (see capi/tests/c_tendons.rs):
 *   cargo build --release -p cablesense-capi
 *   cc -O2 -std=c11 -I capi/include examples/c/tendons.c
 *      target/release/libcablesense_capi.a -lpthread -ldl -lm -o tendons   (one line)
 *   ./tendons data/scenes/tdcr_two_segment.toml 200 [AMPLITUDE_M]
 * (the pull's amplitude, default 1e-3 m; the first tick that does not converge, e.g.
 * at 0.08 m, prints why to stderr through cs_tendons_diagnosis) */
#include "cablesense.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MAX_TENDONS 16

static char *read_file(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "cannot open %s\n", path);
    exit(2);
  }
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *text = malloc((size_t)n + 1);
  if (!text || fread(text, 1, (size_t)n, f) != (size_t)n) {
    fprintf(stderr, "cannot read %s\n", path);
    exit(2);
  }
  text[n] = '\0';
  fclose(f);
  return text;
}

static double now_us(void) {
  struct timespec ts;
  timespec_get(&ts, TIME_UTC);
  return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* Print the message of a call expected to fail. */
static void expect_error(const char *what, CsCode code) {
  printf("bad call (%s): code %d: %s\n", what, (int)code, cs_last_error());
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s SCENE.toml [TICKS]\n", argv[0]);
    return 2;
  }
  int ticks = argc > 2 ? atoi(argv[2]) : 200;
  if (ticks < 1) ticks = 1;
  double amplitude = argc > 3 ? atof(argv[3]) : 1e-3;
  char *scene = read_file(argv[1]);
  CsTendons *t = NULL;
  if (cs_tendons_new(scene, &t) != CS_CODE_OK) {
    fprintf(stderr, "cs_tendons_new: %s\n", cs_last_error());
    return 1;
  }
  size_t p = cs_tendons_count(t);
  if (p < 2 || p > MAX_TENDONS) {
    fprintf(stderr, "%zu tendons: this example drives 2..%d\n", p, MAX_TENDONS);
    return 1;
  }
  double q[MAX_TENDONS] = {0}, tension[MAX_TENDONS], tip[3];
  int32_t taut[MAX_TENDONS];
  double *elapsed = malloc(sizeof(double) * (size_t)ticks);
  int converged = 0, slack_rows = 0;
  for (int k = 0; k < ticks; ++k) {
    /* tendon 0 pulled in and tendon 1 paid out, then the other way, up to the
     * amplitude */
    double x = amplitude * sin(2.0 * 3.14159265358979 * k / 100.0);
    q[0] = x > 0 ? x : 0.0;
    q[1] = x < 0 ? -x : 0.0;
    CsTendonInfo info;
    double t0 = now_us();
    CsCode code = cs_tendons_solve(t, q, p, 1, &info);
    if (code == CS_CODE_OK) code = cs_tendons_tensions(t, tension, taut, p);
    if (code == CS_CODE_OK) code = cs_tendons_tip_position(t, tip);
    elapsed[k] = now_us() - t0;
    if (code != CS_CODE_OK) {
      fprintf(stderr, "tick %d: %s\n", k, cs_last_error());
      return 1;
    }
    converged += info.status == 0;
    slack_rows += info.slack > 0;
    if (info.status != 0 && converged == k) { /* the first tick that did not converge */
      char why[2048]; /* the diagnosis allocates: only after a failed solve */
      if (cs_tendons_diagnosis(t, why, sizeof why, NULL) == CS_CODE_OK)
        fprintf(stderr, "tick %d did not converge: %s\n", k, why);
    }
    if (k == 25) { /* the peak pull of tendon 0 */
      printf("peak tip (mm): %.4f %.4f %.4f\n", tip[0] * 1e3, tip[1] * 1e3, tip[2] * 1e3);
      printf("peak tensions (N):");
      for (size_t i = 0; i < p; ++i) printf(" %.4f", tension[i]);
      printf("\npeak taut:");
      for (size_t i = 0; i < p; ++i) printf(" %d", (int)taut[i]);
      printf("\n");
    }
  }
  qsort(elapsed, (size_t)ticks, sizeof(double), cmp_double);
  printf("ticks: %d  converged: %d  rows with a slack tendon: %d\n", ticks, converged,
         slack_rows);
  printf("tick time (us): p50 %.1f  p90 %.1f  p99 %.1f  max %.1f\n", elapsed[ticks / 2],
         elapsed[(ticks * 9) / 10], elapsed[(ticks * 99) / 100], elapsed[ticks - 1]);

  /* bad calls: each is an error code and a message naming the value */
  double bad[MAX_TENDONS] = {0};
  bad[1] = NAN;
  CsCode code = cs_tendons_solve(t, bad, p, 1, NULL);
  if (code != CS_CODE_BAD_ARGUMENT) return 1;
  expect_error("NaN reading", code);
  code = cs_tendons_solve(t, q, p - 1, 1, NULL);
  if (code != CS_CODE_BAD_ARGUMENT) return 1;
  expect_error("short buffer", code);
  code = cs_tendons_solve(NULL, q, p, 1, NULL);
  if (code != CS_CODE_BAD_ARGUMENT) return 1;
  expect_error("null handle", code);
  CsTendons *none = NULL;
  code = cs_tendons_new("[[robot.sections]]\nlength_m = -0.1\n"
                        "shape = { solid = { diameter_m = 1e-3 } }\n"
                        "youngs_modulus_pa = 60e9\npoisson_ratio = 0.3\n"
                        "density_kg_m3 = 6450.0\n",
                        &none);
  if (code != CS_CODE_BAD_SCENE || none != NULL) return 1;
  expect_error("bad scene", code);

  cs_tendons_free(t);
  free(elapsed);
  free(scene);
  return 0;
}
