/*
 * EMPS positioning axis in its PD loop (Janot, Gautier, Brunot 2019, eqs. 1-7), states qm, v:
 *   vir = clamp(kv (kp (q_ref - qm) - v), -vir_max, vir_max)
 *   M v' = gtau vir - Fv v - Fc tanh(v / v_c) - offset + f_ext,   qm' = v
 */
#include <math.h>

#include "model.h"

struct ModelCache {
    double inv_m, viscous, coulomb, inv_vc, offset, gtau, kp, kv, vir_max;
};

size_t model_cache_size(void) { return sizeof(ModelCache); }

const char *model_apply_parameters(const double *r, ModelCache *k) {
    if (!(r[VR_M] > 0.0)) return "M must be > 0";
    if (!(r[VR_Fv] >= 0.0)) return "Fv must be >= 0";
    if (!(r[VR_Fc] >= 0.0)) return "Fc must be >= 0";
    if (!(r[VR_v_c] > 0.0)) return "v_c must be > 0";
    if (!(r[VR_vir_max] > 0.0)) return "vir_max must be > 0";
    k->inv_m = 1.0 / r[VR_M];
    k->viscous = r[VR_Fv];
    k->coulomb = r[VR_Fc];
    k->inv_vc = 1.0 / r[VR_v_c];
    k->offset = r[VR_offset];
    k->gtau = r[VR_gtau];
    k->kp = r[VR_kp];
    k->kv = r[VR_kv];
    k->vir_max = r[VR_vir_max];
    return NULL;
}

static double drive_voltage(double kp, double kv, double vir_max, double q_ref, const double *x) {
    const double vir = kv * (kp * (q_ref - x[X_qm]) - x[X_v]);
    return fmin(fmax(vir, -vir_max), vir_max);
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    const double vir = drive_voltage(k->kp, k->kv, k->vir_max, u[0], x);
    const double friction = k->viscous * x[X_v] + k->coulomb * tanh(x[X_v] * k->inv_vc);
    dx[X_qm] = x[X_v];
    dx[X_v] = (k->gtau * vir - friction - k->offset + u[1]) * k->inv_m;
}

void model_outputs(const double *x, double *r) {
    r[VR_qm] = x[X_qm];
    r[VR_v] = x[X_v];
    r[VR_vir] = drive_voltage(r[VR_kp], r[VR_kv], r[VR_vir_max], r[VR_q_ref], x);
}
