/* Test FMU: the msd interface whose derivatives never return once the force is applied,
 * so fmi2DoStep hangs. */
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
    volatile int spinning = u[0] != 0.0;
    while (spinning) {
    }
    dx[X_x] = x[X_v];
    dx[X_v] = (u[0] - k->damping * x[X_v] - k->stiffness * x[X_x]) * k->inv_m;
}

void model_outputs(const double *x, double *r) {
    r[VR_x] = x[X_x];
    r[VR_v] = x[X_v];
}
