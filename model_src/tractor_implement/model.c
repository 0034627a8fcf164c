/*
 * Physics of the tractor and single-axle towed implement (thesis eqs. 3.3-3.18).
 *
 * States X = [v_tc, gam_t, gam_i, alp_tf, alp_tr, alp_ir, psi_t, psi_i] obey M X' = N X + P delta
 * (eqs. 3.11-3.14); x_tc, y_tc are integrated from eqs. 3.15-3.16 and x_ic, y_ic follow from
 * eqs. 3.17-3.18. Only rows 1-3 of M differ from the identity, so the parameters are applied once
 * by inverting that 3x3 block and precomputing the non-zero part of A = M^-1 N (columns gam_t,
 * alp_tf, alp_tr, alp_ir); B = M^-1 P only has the row of alp_tf.
 *
 * Beyond the thesis, off at their start values of 0:
 *   alpha_sat > 0: each lateral tire force -C alpha becomes -C alpha_sat tanh(alpha / alpha_sat);
 *   slope != 0:    gravity F_t = m_t g sin(slope) cos(psi_t), F_i = m_i g sin(slope) cos(psi_i)
 *                  adds F_t + F_i to eq. 3.3, -c F_i to eq. 3.4 and -d F_i to eq. 3.5.
 * Both enter as an extra right-hand side of rows 1-3, mapped through the inverted 3x3 block.
 */
#include <math.h>

#include "model.h"

#define GRAVITY 9.81

struct ModelCache {
    double minv[3][3];   /* inverse of the mass block, rows/columns v_tc, gam_t, gam_i */
    double a[3][4];      /* rows 1-3 of M^-1 N on the columns gam_t, alp_tf, alp_tr, alp_ir */
    double inv_sig_tf, inv_sig_tr, inv_sig_ir;
    double u, a_len, b_len, c_len, d_len, de_len;
    double c_tf, c_tr, c_ir, alpha_sat, grav_t, grav_i;
    int nonlinear;
};

size_t model_cache_size(void) { return sizeof(ModelCache); }

const char *model_apply_parameters(const double *r, ModelCache *k) {
    const double mt = r[VR_m_t], mi = r[VR_m_i], it = r[VR_I_tz], ii = r[VR_I_iz];
    const double u = r[VR_u_tc], a = r[VR_a], b = r[VR_b], c = r[VR_c], d = r[VR_d];
    const double e = r[VR_e];
    double m[3][3], n[3][4], det;

    if (!(r[VR_sig_tf] > 0.0)) return "sig_tf must be > 0";
    if (!(r[VR_sig_tr] > 0.0)) return "sig_tr must be > 0";
    if (!(r[VR_sig_ir] > 0.0)) return "sig_ir must be > 0";
    if (!(mt > 0.0) || !(mi > 0.0)) return "m_t and m_i must be > 0";
    if (!(it > 0.0) || !(ii > 0.0)) return "I_tz and I_iz must be > 0";
    if (!(r[VR_alpha_sat] >= 0.0)) return "alpha_sat must be >= 0 (0 = linear tires)";

    m[0][0] = mt + mi;    m[0][1] = -mi * c;          m[0][2] = -mi * d;
    m[1][0] = -mi * c;    m[1][1] = it + mi * c * c;  m[1][2] = mi * c * d;
    m[2][0] = -mi * d;    m[2][1] = mi * c * d;       m[2][2] = ii + mi * d * d;
    k->minv[0][0] = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    k->minv[0][1] = m[0][2] * m[2][1] - m[0][1] * m[2][2];
    k->minv[0][2] = m[0][1] * m[1][2] - m[0][2] * m[1][1];
    k->minv[1][0] = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    k->minv[1][1] = m[0][0] * m[2][2] - m[0][2] * m[2][0];
    k->minv[1][2] = m[0][2] * m[1][0] - m[0][0] * m[1][2];
    k->minv[2][0] = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    k->minv[2][1] = m[0][1] * m[2][0] - m[0][0] * m[2][1];
    k->minv[2][2] = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    det = m[0][0] * k->minv[0][0] + m[0][1] * k->minv[1][0] + m[0][2] * k->minv[2][0];
    if (!(det > 0.0)) return "the mass matrix M (eq. 3.12) is singular";
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) k->minv[i][j] /= det;
    }

    /* Rows 1-3 of N (eq. 3.13) on the columns gam_t, alp_tf, alp_tr, alp_ir. */
    n[0][0] = -(mt + mi) * u; n[0][1] = -r[VR_C_atf];     n[0][2] = -r[VR_C_atr];
    n[0][3] = -r[VR_C_air];
    n[1][0] = mi * c * u;     n[1][1] = -a * r[VR_C_atf]; n[1][2] = b * r[VR_C_atr];
    n[1][3] = c * r[VR_C_air];
    n[2][0] = mi * d * u;     n[2][1] = 0.0;              n[2][2] = 0.0;
    n[2][3] = (d + e) * r[VR_C_air];
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++) {
            k->a[i][j] = k->minv[i][0] * n[0][j] + k->minv[i][1] * n[1][j] +
                         k->minv[i][2] * n[2][j];
        }
    }

    k->inv_sig_tf = 1.0 / r[VR_sig_tf];
    k->inv_sig_tr = 1.0 / r[VR_sig_tr];
    k->inv_sig_ir = 1.0 / r[VR_sig_ir];
    k->u = u;
    k->a_len = a;
    k->b_len = b;
    k->c_len = c;
    k->d_len = d;
    k->de_len = d + e;
    k->c_tf = r[VR_C_atf];
    k->c_tr = r[VR_C_atr];
    k->c_ir = r[VR_C_air];
    k->alpha_sat = r[VR_alpha_sat];
    k->grav_t = mt * GRAVITY * sin(r[VR_slope]);
    k->grav_i = mi * GRAVITY * sin(r[VR_slope]);
    k->nonlinear = k->alpha_sat > 0.0 || r[VR_slope] != 0.0;
    return NULL;
}

/* Change of a tire force when it saturates: -C s tanh(alpha / s) - (-C alpha). */
static double saturation_excess(double stiffness, double alpha, double alpha_sat) {
    if (alpha_sat <= 0.0) return 0.0;
    return stiffness * (alpha - alpha_sat * tanh(alpha / alpha_sat));
}

void model_derivatives(const ModelCache *k, const double *x, const double *u, double *dx) {
    const double v = x[X_v_tc], gt = x[X_gam_t], gi = x[X_gam_i];
    const double af = x[X_alp_tf], ar = x[X_alp_tr], ai = x[X_alp_ir];
    const double pt = x[X_psi_t], pi = x[X_psi_i];
    const double cos_pt = cos(pt), sin_pt = sin(pt);

    for (int i = 0; i < 3; i++) {
        dx[i] = k->a[i][0] * gt + k->a[i][1] * af + k->a[i][2] * ar + k->a[i][3] * ai;
    }
    if (k->nonlinear) {
        const double df = saturation_excess(k->c_tf, af, k->alpha_sat);
        const double dr = saturation_excess(k->c_tr, ar, k->alpha_sat);
        const double di = saturation_excess(k->c_ir, ai, k->alpha_sat);
        const double ft = k->grav_t * cos_pt, fi = k->grav_i * cos(pi);
        const double extra[3] = {df + dr + di + ft + fi,
                                 k->a_len * df - k->b_len * dr - k->c_len * di - k->c_len * fi,
                                 -k->de_len * di - k->d_len * fi};
        for (int i = 0; i < 3; i++) {
            dx[i] += k->minv[i][0] * extra[0] + k->minv[i][1] * extra[1] +
                     k->minv[i][2] * extra[2];
        }
    }
    dx[X_alp_tf] = (v + k->a_len * gt - k->u * u[0] - k->u * af) * k->inv_sig_tf;
    dx[X_alp_tr] = (v - k->b_len * gt - k->u * ar) * k->inv_sig_tr;
    dx[X_alp_ir] = (v - k->c_len * gt - k->de_len * gi + k->u * (pt - pi) - k->u * ai) *
                   k->inv_sig_ir;
    dx[X_psi_t] = gt;
    dx[X_psi_i] = gi;
    dx[X_x_tc] = k->u * cos_pt - v * sin_pt;
    dx[X_y_tc] = k->u * sin_pt + v * cos_pt;
}

void model_outputs(const double *x, double *r) {
    r[VR_v_tc] = x[X_v_tc];
    r[VR_gam_t] = x[X_gam_t];
    r[VR_gam_i] = x[X_gam_i];
    r[VR_psi_t] = x[X_psi_t];
    r[VR_psi_i] = x[X_psi_i];
    r[VR_x_tc] = x[X_x_tc];
    r[VR_y_tc] = x[X_y_tc];
    r[VR_x_ic] = x[X_x_tc] - r[VR_c] * cos(x[X_psi_t]) - r[VR_d] * cos(x[X_psi_i]);
    r[VR_y_ic] = x[X_y_tc] - r[VR_c] * sin(x[X_psi_t]) - r[VR_d] * sin(x[X_psi_i]);
}
