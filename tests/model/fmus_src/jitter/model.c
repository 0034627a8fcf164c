/* Test FMU: y' = (K u - y) / tau_eff with tau_eff = tau (1 + jitter h(floor(tau / cell))), h a
 * hash of the cell index in [-1, 1). The output is a smooth function of tau inside each cell of
 * width `cell` and jumps between cells, as a variable-step solver's output jumps when its step
 * sequence changes: chi2 along tau is a parabola with steps.
 */
#include <math.h>
#include <stdint.h>

#include "model.h"

struct ModelCache {
    double gain, tau_eff;
};

size_t model_cache_size(void) { return sizeof(ModelCache); }

static double hash_unit(double tau, double cell) {
    uint64_t x = (uint64_t)(int64_t)floor(tau / cell) * 0x9E3779B97F4A7C15ULL;
    x ^= x >> 29;
    x *= 0xBF58476D1CE4E5B9ULL;
    x ^= x >> 32;
    return (double)(x >> 11) / 4503599627370496.0 - 1.0;
}

const char *model_apply_parameters(const double *r, ModelCache *k) {
    if (!(r[VR_tau] > 0.0)) return "tau must be > 0";
    if (!(r[VR_cell] > 0.0)) return "cell must be > 0";
    if (!(fabs(r[VR_jitter]) < 0.5)) return "jitter must be below 0.5";
    k->gain = r[VR_K];
    k->tau_eff = r[VR_tau] * (1.0 + r[VR_jitter] * hash_unit(r[VR_tau], r[VR_cell]));
    return NULL;
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    dx[X_y] = (k->gain * u[0] - x[X_y]) / k->tau_eff;
}

void model_outputs(const double *x, double *r) { r[VR_y] = x[X_y]; }
