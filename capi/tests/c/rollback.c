/* Rollback through the C ABI: the rows of a file (one row of readings in m per line,
 * cs_tendons_count numbers each) solved warm on one handle, and on a second handle
 * with an unreachable row (0.05 m on the first tendon, the others 0) after row K.
 * Every good row must give bit-identical status, iterations, tip and tensions.
 * Usage: rollback SCENE.toml ROWS.txt K. Prints "rows N differing D bad_status S". */
#include "cablesense.h"
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

typedef struct {
    CsTendonInfo info;
    double tip[3];
    double tension[MAXT];
    int32_t taut[MAXT];
} Row;

static int solve(CsTendons *t, const double *q, size_t p, Row *out) {
    memset(out, 0, sizeof *out);
    if (cs_tendons_solve(t, q, p, 1, &out->info) != CS_CODE_OK) return -1;
    if (cs_tendons_tip_position(t, out->tip) != CS_CODE_OK) return -1;
    if (cs_tendons_tensions(t, out->tension, out->taut, p) != CS_CODE_OK) return -1;
    return 0;
}

int main(int argc, char **argv) {
    char *scene, *rows_text, *line;
    CsTendons *a = NULL, *b = NULL;
    size_t p, n = 0, cap = 1024, i, k, differing = 0;
    double *rows, bad[MAXT] = {0};
    Row ra, rb, rbad;
    if (argc != 4) return 2;
    scene = read_file(argv[1]);
    rows_text = read_file(argv[2]);
    k = (size_t)atol(argv[3]);
    if (!scene || !rows_text) return 2;
    if (cs_tendons_new(scene, &a) != CS_CODE_OK || cs_tendons_new(scene, &b) != CS_CODE_OK) {
        fprintf(stderr, "%s\n", cs_last_error());
        return 1;
    }
    p = cs_tendons_count(a);
    if (p == 0 || p > MAXT) return 1;
    rows = malloc(cap * p * sizeof *rows);
    for (line = strtok(rows_text, "\n"); line; line = strtok(NULL, "\n")) {
        char *s = line;
        if (n == cap) rows = realloc(rows, (cap *= 2) * p * sizeof *rows);
        for (i = 0; i < p; i++) rows[n * p + i] = strtod(s, &s);
        n++;
    }
    bad[0] = 0.05;
    memset(&rbad, 0, sizeof rbad);
    for (i = 0; i < n; i++) {
        if (solve(a, rows + i * p, p, &ra) || solve(b, rows + i * p, p, &rb)) {
            fprintf(stderr, "row %lu: %s\n", (unsigned long)i, cs_last_error());
            return 1;
        }
        if (memcmp(&ra, &rb, sizeof ra) != 0) differing++;
        if (i == k && solve(b, bad, p, &rbad)) return 1;
    }
    printf("rows %lu differing %lu bad_status %d\n", (unsigned long)n, (unsigned long)differing,
           rbad.info.status);
    cs_tendons_free(a);
    cs_tendons_free(b);
    free(rows);
    free(scene);
    free(rows_text);
    return differing == 0 && rbad.info.status != 0 ? 0 : 1;
}
