/* Test FMU: the msd interface whose derivatives leak 8 MiB (written, so really used) on every
 * call once the force is applied: memory grows without bound until the job's address-space
 * limit makes malloc fail, and then the FMU gives up as xmalloc-style allocators (and C++'s
 * std::bad_alloc) do: a message on stderr and abort(). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"

#define LEAK_BYTES (8u << 20)

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
    dx[X_x] = x[X_v];
    dx[X_v] = (u[0] - k->damping * x[X_v] - k->stiffness * x[X_x]) * k->inv_m;
    if (u[0] != 0.0) {
        char *leak = malloc(LEAK_BYTES);
        if (leak == NULL) {
            fprintf(stderr, "leak_step: out of memory allocating %u bytes\n", LEAK_BYTES);
            abort();
        }
        memset(leak, 1, LEAK_BYTES);
    }
}

void model_outputs(const double *x, double *r) {
    r[VR_x] = x[X_x];
    r[VR_v] = x[X_v];
}
