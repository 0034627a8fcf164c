/* Test FMU: two linear tanks in series, h1' = (q - h1 / R1) / C1, h2' = (h1 / R1 - h2 / R2) / C2.
 * Built with setup_experiment_resets.c as its FMI layer, whose fmi2SetupExperiment re-applies
 * the start values: a parameter set before fmi2SetupExperiment is lost (20-sim's behaviour).
 */
#include "model.h"

struct ModelCache {
    double r1, r2, c1, c2;
};

size_t model_cache_size(void) { return sizeof(ModelCache); }

const char *model_apply_parameters(const double *r, ModelCache *k) {
    if (!(r[VR_R1] > 0.0)) return "R1 must be > 0";
    if (!(r[VR_R2] > 0.0)) return "R2 must be > 0";
    if (!(r[VR_C1] > 0.0)) return "C1 must be > 0";
    if (!(r[VR_C2] > 0.0)) return "C2 must be > 0";
    k->r1 = r[VR_R1];
    k->r2 = r[VR_R2];
    k->c1 = r[VR_C1];
    k->c2 = r[VR_C2];
    return NULL;
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    const double flow = x[X_h1] / k->r1;
    dx[X_h1] = (u[0] - flow) / k->c1;
    dx[X_h2] = (flow - x[X_h2] / k->r2) / k->c2;
}

void model_outputs(const double *x, double *r) {
    r[VR_h1] = x[X_h1];
    r[VR_h2] = x[X_h2];
}
