/* Test FMU: the msd interface whose fmi2DoStep returns fmi2Error while the stiffness k lies in
 * a band inside the usual bounds (the state is made non-finite, which the shared FMI layer
 * reports as an error of fmi2DoStep). Outside the band it is the plain mass-spring-damper. */
#include <math.h>

#include "model.h"

#define K_FAIL_LOW 4.404
#define K_FAIL_HIGH 4.416

struct ModelCache {
    double inv_m, stiffness, damping;
    int fails;
};

size_t model_cache_size(void) { return sizeof(ModelCache); }

const char *model_apply_parameters(const double *r, ModelCache *k) {
    k->inv_m = 1.0 / r[VR_m];
    k->stiffness = r[VR_k];
    k->damping = r[VR_b];
    k->fails = r[VR_k] > K_FAIL_LOW && r[VR_k] < K_FAIL_HIGH;
    return NULL;
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    dx[X_x] = x[X_v];
    dx[X_v] = (u[0] - k->damping * x[X_v] - k->stiffness * x[X_x]) * k->inv_m;
    if (k->fails) dx[X_v] = NAN;
}

void model_outputs(const double *x, double *r) {
    r[VR_x] = x[X_x];
    r[VR_v] = x[X_v];
}
