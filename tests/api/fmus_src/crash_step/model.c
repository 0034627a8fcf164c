/* Test FMU: the msd interface whose derivatives dereference NULL once the force is applied,
 * so fmi2DoStep segfaults. */
#include "model.h"

struct ModelCache {
    double inv_m, stiffness, damping;
};

size_t model_cache_size(void) { return sizeof(ModelCache); }

const char *model_apply_parameters(const double *r, ModelCache *k) {
    k->inv_m = 1.0 / r[VR_m];
    k->stiffness = r[VR_k];
    k->damping = r[VR_b];
    return NULL;
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    volatile double *nowhere = NULL;
    dx[X_x] = x[X_v];
    dx[X_v] = (u[0] - k->damping * x[X_v] - k->stiffness * x[X_x]) * k->inv_m;
    if (u[0] != 0.0) dx[X_v] += *nowhere;
}

void model_outputs(const double *x, double *r) {
    r[VR_x] = x[X_x];
    r[VR_v] = x[X_v];
}
