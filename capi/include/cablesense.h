/* cablesense C ABI: forward statics and load/shape estimation for cable-driven
 * continuum robots, for control loops. Written by hand from capi/src/lib.rs (the
 * documentation there is the reference); capi/tests/header.rs checks it against
 * cbindgen's output when cbindgen is installed.
 *
 * Every call returns a CsCode (0 = OK). On failure, cs_last_error() gives the
 * message (per thread, valid until the next failing call on that thread). No panic
 * crosses the boundary. Numerical outcomes (non-convergence, a stalled estimate)
 * are status codes in the info structs, not failures.
 *
 * Units: SI (m, N, N m, kg). Rotations: 9 doubles, column-major.
 * Per tick, cs_estimator_tick, cs_estimator_values, cs_estimator_tip_position and
 * cs_estimator_cable_lengths do not allocate after the first tick;
 * cs_model_tip_pose and cs_model_section_poses recompute the shape and allocate. */
#ifndef CABLESENSE_H
#define CABLESENSE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Result code of every call. */
typedef enum CsCode {
  CS_OK = 0,           /* success */
  CS_BAD_ARGUMENT = 1, /* null pointer or wrong buffer length */
  CS_BAD_SCENE = 2,    /* scene text not UTF-8, not parsed, invalid, or no [estimate] */
  CS_PANIC = 3,        /* a caught panic (a bug: report cs_last_error()) */
} CsCode;

/* Forward solve outcome. status: 0 converged, 1 max_iterations, 2 stalled,
 * 3 ill_conditioned, 4 non_finite, 5 unstable (only 0 is a usable shape). */
typedef struct CsSolveInfo {
  int32_t status;
  uint32_t iterations;
  double residual; /* scaled boundary residual (-) */
} CsSolveInfo;

/* Estimator tick outcome. status: 0 converged, 1 unobservable, 2 max_iterations,
 * 3 time_budget, 4 stalled, 5 forward_failed, 6 no_data. */
typedef struct CsEstimateInfo {
  int32_t status;
  int32_t poor_fit; /* 1 when rms_sigma > the scene's poor_fit_rms_sigma */
  double rms_sigma; /* RMS over measured cables of residual / sigma (-) */
} CsEstimateInfo;

typedef struct CsModel CsModel;         /* forward model of a scene */
typedef struct CsEstimator CsEstimator; /* the scene's [estimate] problem */

const char *cs_last_error(void);

/* Forward model: the scene's loads and [numerics]. */
CsCode cs_model_new(const char *scene_toml, CsModel **out);
void cs_model_free(CsModel *m);
size_t cs_model_section_count(const CsModel *m);
size_t cs_model_cable_count(const CsModel *m);
CsCode cs_model_solve(CsModel *m, int32_t warm, CsSolveInfo *info);
CsCode cs_model_tip_pose(CsModel *m, double *position /*[3]*/, double *rotation /*[9]*/);
CsCode cs_model_section_poses(CsModel *m, double *positions /*[3n]*/, double *rotations /*[9n]*/,
                              size_t n);
CsCode cs_model_cable_lengths(const CsModel *m, double *out /*[n]*/, size_t n);

/* Estimator: cable length changes (m, NaN = missing) in, loads and shape out. */
CsCode cs_estimator_new(const char *scene_toml, CsEstimator **out);
void cs_estimator_free(CsEstimator *e);
size_t cs_estimator_unknown_count(const CsEstimator *e);
size_t cs_estimator_cable_count(const CsEstimator *e);
CsCode cs_estimator_tick(CsEstimator *e, const double *changes /*[n]*/,
                         const double *sigma /*[n] or NULL*/, size_t n, CsEstimateInfo *info);
CsCode cs_estimator_values(const CsEstimator *e, double *values /*[p]*/,
                           double *cov /*[p*p] or NULL*/, size_t p);
CsCode cs_estimator_tip_position(const CsEstimator *e, double *position /*[3]*/);
CsCode cs_estimator_cable_lengths(CsEstimator *e, double *out /*[n]*/, size_t n);

#ifdef __cplusplus
}
#endif

#endif /* CABLESENSE_H */
