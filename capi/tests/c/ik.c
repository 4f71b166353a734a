/* Inverse kinematics through the C ABI, as a C control loop sees it: for each row of
 * readings (m, one row per line, cs_tendons_count numbers each) the model's tip is
 * solved forward (cs_tendons_solve), then cs_tendons_ik finds readings for that tip,
 * warm from the previous row, and those readings are solved forward again. Then a
 * target 10 cm beyond the straight tip (outside the workspace) and bad calls.
 * Usage: ik SCENE.toml ROWS.txt. Prints
 *   "ik tensions (N): ..." (cs_tendons_ik_tensions at the last row's readings),
 *   "rows N reached R within_50um W resolved_50um V max_um M",
 *   "unreachable status S distance_mm D", and "bad call (what): message" lines. */
#include "cablesense.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAXT 16

static char *read_file(const char *path) {
    FILE *f = fopen(path, "rb");
    long n;
    char *s;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    s = malloc((size_t)n + 1);
    if (s && fread(s, 1, (size_t)n, f) != (size_t)n) { free(s); s = NULL; }
    if (s) s[n] = 0;
    fclose(f);
    return s;
}

static double dist(const double *a, const double *b) {
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

static void bad_call(const char *what, CsCode code) {
    printf("bad call (%s): code %d: %s\n", what, (int)code, cs_last_error());
}

int main(int argc, char **argv) {
    char *scene, *rows_text, *line;
    CsTendons *t = NULL;
    CsIkSettings settings, wrong;
    CsIkInfo info;
    CsTendonInfo fwd;
    size_t p, i, n = 0, reached = 0, within = 0, resolved = 0;
    double q[MAXT], out[MAXT], lo[MAXT], hi[MAXT], tip[3], again[3], zero[MAXT] = {0};
    double max_d = 0.0, nan_target[3], zero_dir[3] = {0.0, 0.0, 0.0};
    if (argc != 3) return 2;
    scene = read_file(argv[1]);
    rows_text = read_file(argv[2]);
    if (!scene || !rows_text) return 2;
    if (cs_tendons_new(scene, &t) != CS_CODE_OK) {
        fprintf(stderr, "%s\n", cs_last_error());
        return 1;
    }
    p = cs_tendons_count(t);
    if (p == 0 || p > MAXT) return 1;
    if (cs_tendons_limits(t, lo, hi, p) != CS_CODE_OK) return 1;
    printf("limits (mm) of %s: [%g, %g]\n", cs_tendons_column_name(t, 0), lo[0] * 1e3, hi[0] * 1e3);
    if (cs_ik_settings_default(&settings) != CS_CODE_OK) return 1;
    if (cs_tendons_ik_configure(t, &settings) != CS_CODE_OK) return 1;
    for (line = strtok(rows_text, "\n"); line; line = strtok(NULL, "\n")) {
        char *s = line;
        for (i = 0; i < p; i++) q[i] = strtod(s, &s);
        if (cs_tendons_solve(t, q, p, 1, &fwd) != CS_CODE_OK || fwd.status != 0) continue;
        if (cs_tendons_tip_position(t, tip) != CS_CODE_OK) return 1;
        if (cs_tendons_ik(t, tip, NULL, out, p, &info) != CS_CODE_OK) {
            fprintf(stderr, "row %lu: %s\n", (unsigned long)n, cs_last_error());
            return 1;
        }
        n++;
        if (info.status == 0) reached++;
        if (info.distance_m <= 5e-5) within++;
        if (info.distance_m > max_d) max_d = info.distance_m;
        for (i = 0; i < p; i++) {
            if (out[i] < lo[i] || out[i] > hi[i]) {
                fprintf(stderr, "row %lu: reading %lu outside its limits\n", (unsigned long)n,
                        (unsigned long)i);
                return 1;
            }
        }
        /* the readings found, solved forward again, reproduce the target */
        if (cs_tendons_solve(t, out, p, 1, &fwd) == CS_CODE_OK && fwd.status == 0
            && cs_tendons_tip_position(t, again) == CS_CODE_OK && dist(again, tip) <= 5e-5)
            resolved++;
    }
    /* the tensions at the last readings found, and how many are slack */
    {
        double tension[MAXT];
        int32_t taut[MAXT];
        size_t slack = 0;
        if (cs_tendons_ik_tensions(t, tension, taut, p) != CS_CODE_OK) return 1;
        for (i = 0; i < p; i++) slack += taut[i] == 0;
        printf("ik tensions (N): first %.3f slack %lu of %lu (info %u)\n", tension[0],
               (unsigned long)slack, (unsigned long)p, info.slack);
        if (slack != info.slack) return 1;
    }
    printf("rows %lu reached %lu within_50um %lu resolved_50um %lu max_um %.3f\n",
           (unsigned long)n, (unsigned long)reached, (unsigned long)within,
           (unsigned long)resolved, max_d * 1e6);
    /* outside the workspace: 10 cm beyond the straight tip, from zero readings */
    if (cs_tendons_ik_start(t, zero, p) != CS_CODE_OK) return 1;
    if (cs_tendons_solve(t, zero, p, 0, &fwd) != CS_CODE_OK) return 1;
    if (cs_tendons_tip_position(t, tip) != CS_CODE_OK) return 1;
    tip[2] += 0.1;
    if (cs_tendons_ik(t, tip, NULL, out, p, &info) != CS_CODE_OK) return 1;
    printf("unreachable status %d distance_mm %.3f\n", info.status, info.distance_m * 1e3);
    /* bad calls: each an error code with a message naming the value */
    nan_target[0] = 0.0;
    nan_target[1] = 0.0;
    nan_target[2] = nan("");
    bad_call("nan target", cs_tendons_ik(t, nan_target, NULL, out, p, &info));
    bad_call("zero direction", cs_tendons_ik(t, tip, zero_dir, out, p, &info));
    bad_call("short buffer", cs_tendons_ik(t, tip, NULL, out, p - 1, &info));
    bad_call("null handle", cs_tendons_ik(NULL, tip, NULL, out, p, &info));
    wrong = settings;
    wrong.tolerance_m = 0.0;
    bad_call("bad settings", cs_tendons_ik_configure(t, &wrong));
    wrong = settings;
    wrong.objective = 7;
    bad_call("bad objective", cs_tendons_ik_configure(t, &wrong));
    q[0] = 1.0;
    bad_call("start outside the limits", cs_tendons_ik_start(t, q, p));
    cs_tendons_free(t);
    free(scene);
    free(rows_text);
    return 0;
}
