/*
 * Physics of the mass with two parallel springs and a damper (thesis eq. 2.23):
 * m x'' + b x' + (k1 + k2) x = f, states x and v = x'.
 */
#include "model.h"

struct ModelCache {
    double inv_m, stiffness, damping;
};

size_t model_cache_size(void) { return sizeof(ModelCache); }

const char *model_apply_parameters(const double *r, ModelCache *k) {
    if (!(r[VR_m] > 0.0)) return "m must be > 0";
    if (!(r[VR_k1] >= 0.0) || !(r[VR_k2] >= 0.0)) return "k1 and k2 must be >= 0";
    if (!(r[VR_b] >= 0.0)) return "b must be >= 0";
    k->inv_m = 1.0 / r[VR_m];
    k->stiffness = r[VR_k1] + r[VR_k2];
    k->damping = r[VR_b];
    return NULL;
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    dx[X_x] = x[X_v];
    dx[X_v] = (u[0] - k->damping * x[X_v] - k->stiffness * x[X_x]) * k->inv_m;
}

void model_outputs(const double *x, double *r) {
    r[VR_x] = x[X_x];
    r[VR_v] = x[X_v];
}
