/* Test FMU: the msd physics with two exporter bugs fmuid must work around.
 *
 * - Unreliable reset: a force offset of 0.5 N per run of one instance beyond the first
 *   1 + delay runs lives in the ModelCache, which fmi2Reset does not clear (fmi2Instantiate
 *   calloc's it). A fresh instance's run is the msd model; the run after a reset is not
 *   (delay = 0) or only from the (delay + 2)-th run of the instance on (delay > 0).
 * - Instance limit: the library gives out at most LIMIT instances per process; later
 *   fmi2Instantiate calls fail ("out of memory"), as some exporters do after ~1000.
 */
#include <stdint.h>

#include "model.h"

#define LIMIT 40

struct ModelCache {
    double inv_m, stiffness, damping, offset;
    int runs;
};

static int instances = 0;

size_t model_cache_size(void) {
    instances += 1;
    return instances > LIMIT ? SIZE_MAX : sizeof(ModelCache);
}

const char *model_apply_parameters(const double *r, ModelCache *k) {
    if (!(r[VR_m] > 0.0)) return "m must be > 0";
    if (!(r[VR_k] >= 0.0)) return "k must be >= 0";
    if (!(r[VR_b] >= 0.0)) return "b must be >= 0";
    k->inv_m = 1.0 / r[VR_m];
    k->stiffness = r[VR_k];
    k->damping = r[VR_b];
    k->offset = k->runs > r[VR_delay] ? 0.5 * (k->runs - r[VR_delay]) : 0.0;
    k->runs += 1;
    return NULL;
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    dx[X_x] = x[X_v];
    dx[X_v] = (u[0] + k->offset - k->damping * x[X_v] - k->stiffness * x[X_x]) * k->inv_m;
}

void model_outputs(const double *x, double *r) {
    r[VR_x] = x[X_x];
    r[VR_v] = x[X_v];
}
