/*
 * Exact steps of a model whose physics is linear (variables.json "linear": true).
 *
 * The derivatives are affine in the states and inputs, dx = A x + B u + c, so they are probed
 * once per parameter set: c = f(0, 0), the columns of A and B the changes of f at unit states
 * and inputs (exact to one rounding for a linear f). With the inputs linear inside a step,
 * u(t0 + s) = u0 + du s, the state after a step h is
 *   x(h) = Phi x0 + G0 [u0; 1] + G1 du,
 * Phi = e^(A h), G0 = int_0^h e^(A (h - s)) [B c] ds, G1 = int_0^h e^(A (h - s)) B s ds,
 * the top blocks of the exponential of the augmented matrix [[A, B c, 0], [0, 0, I], [0, 0, 0]]
 * (Van Loan 1978). The exponential is taken by scaling and squaring a Taylor series summed to
 * rounding; the last LINEAR_CACHE step sizes keep their blocks, and a step within a relative
 * 1e-12 of a kept one uses its blocks (an error of 1e-12 of one step's change of the state).
 * No error control is needed: the step is exact up to that, whatever h is.
 */
#ifndef FMUID_LINEAR_STEP_H
#define FMUID_LINEAR_STEP_H

#define LIN_U (N_INPUTS + 1)                 /* the inputs and the constant term c */
#define LIN_DIM (N_STATES + LIN_U + N_INPUTS) /* states, inputs (and 1), input slopes */
#define LINEAR_CACHE 4
/* Steps this close (relative) share their blocks: grids of equal steps differ by rounding. */
#define LINEAR_SAME_STEP 1e-12

typedef struct {
    double h;
    double phi[N_STATES][N_STATES];
    double g0[N_STATES][LIN_U];
    double g1[N_STATES][N_INPUTS_ALLOC];
} LinearStep;

typedef struct {
    double a[N_STATES][N_STATES];
    double b[N_STATES][LIN_U];
    LinearStep steps[LINEAR_CACHE];
    int n_steps, next;
} LinearModel;

/* Probe A, B and c from the model's derivatives; forget the cached steps. */
static void linear_probe(const ModelCache *cache, LinearModel *lin) {
    double x[N_STATES] = {0}, u[N_INPUTS_ALLOC] = {0}, f0[N_STATES], f[N_STATES];
    model_derivatives(cache, x, u, f0);
    for (int j = 0; j < N_STATES; j++) {
        x[j] = 1.0;
        model_derivatives(cache, x, u, f);
        for (int i = 0; i < N_STATES; i++) lin->a[i][j] = f[i] - f0[i];
        x[j] = 0.0;
    }
    for (int j = 0; j < N_INPUTS; j++) {
        u[j] = 1.0;
        model_derivatives(cache, x, u, f);
        for (int i = 0; i < N_STATES; i++) lin->b[i][j] = f[i] - f0[i];
        u[j] = 0.0;
    }
    for (int i = 0; i < N_STATES; i++) lin->b[i][N_INPUTS] = f0[i];
    lin->n_steps = 0;
    lin->next = 0;
}

static void matmul(const double p[LIN_DIM][LIN_DIM], const double q[LIN_DIM][LIN_DIM],
                   double out[LIN_DIM][LIN_DIM]) {
    for (int i = 0; i < LIN_DIM; i++) {
        for (int j = 0; j < LIN_DIM; j++) {
            double sum = 0.0;
            for (int k = 0; k < LIN_DIM; k++) sum += p[i][k] * q[k][j];
            out[i][j] = sum;
        }
    }
}

/* e^m by scaling and squaring: ||m / 2^s||_1 <= 1/2, then the Taylor series to rounding. */
static void expm(double m[LIN_DIM][LIN_DIM], double out[LIN_DIM][LIN_DIM]) {
    double term[LIN_DIM][LIN_DIM], next[LIN_DIM][LIN_DIM], norm = 0.0, scale = 1.0;
    int squarings = 0;
    for (int j = 0; j < LIN_DIM; j++) {
        double column = 0.0;
        for (int i = 0; i < LIN_DIM; i++) column += fabs(m[i][j]);
        norm = fmax(norm, column);
    }
    while (norm * scale > 0.5 && squarings < 1000) {
        scale *= 0.5;
        squarings++;
    }
    for (int i = 0; i < LIN_DIM; i++) {
        for (int j = 0; j < LIN_DIM; j++) {
            m[i][j] *= scale;
            term[i][j] = (double)(i == j);
            out[i][j] = term[i][j];
        }
    }
    for (int k = 1; k < 40; k++) {
        double size = 0.0;
        matmul(term, m, next);
        for (int i = 0; i < LIN_DIM; i++) {
            for (int j = 0; j < LIN_DIM; j++) {
                term[i][j] = next[i][j] / k;
                out[i][j] += term[i][j];
                size = fmax(size, fabs(term[i][j]));
            }
        }
        if (size <= 1e-18) break;
    }
    for (int s = 0; s < squarings; s++) {
        matmul(out, out, next);
        memcpy(out, next, sizeof(next));
    }
}

/* The blocks of a step h, from the cache or computed and cached. */
static const LinearStep *linear_blocks(LinearModel *lin, double h) {
    double m[LIN_DIM][LIN_DIM] = {{0}}, e[LIN_DIM][LIN_DIM];
    LinearStep *step;
    for (int k = 0; k < lin->n_steps; k++) {
        if (fabs(lin->steps[k].h - h) <= LINEAR_SAME_STEP * h) return &lin->steps[k];
    }
    for (int i = 0; i < N_STATES; i++) {
        for (int j = 0; j < N_STATES; j++) m[i][j] = lin->a[i][j] * h;
        for (int j = 0; j < LIN_U; j++) m[i][N_STATES + j] = lin->b[i][j] * h;
    }
    for (int j = 0; j < N_INPUTS; j++) m[N_STATES + j][N_STATES + LIN_U + j] = h;
    expm(m, e);
    step = &lin->steps[lin->next];
    lin->next = (lin->next + 1) % LINEAR_CACHE;
    if (lin->n_steps < LINEAR_CACHE) lin->n_steps++;
    step->h = h;
    for (int i = 0; i < N_STATES; i++) {
        for (int j = 0; j < N_STATES; j++) step->phi[i][j] = e[i][j];
        for (int j = 0; j < LIN_U; j++) step->g0[i][j] = e[i][N_STATES + j];
        for (int j = 0; j < N_INPUTS; j++) step->g1[i][j] = e[i][N_STATES + LIN_U + j];
    }
    return step;
}

/* Advance x by h from the inputs u0 at the step's start and their slopes du, exactly. */
static void linear_advance(LinearModel *lin, double h, const double *u0, const double *du,
                           double *x) {
    const LinearStep *step = linear_blocks(lin, h);
    double x_new[N_STATES];
    for (int i = 0; i < N_STATES; i++) {
        double sum = step->g0[i][N_INPUTS];
        for (int j = 0; j < N_STATES; j++) sum += step->phi[i][j] * x[j];
        for (int j = 0; j < N_INPUTS; j++) sum += step->g0[i][j] * u0[j] + step->g1[i][j] * du[j];
        x_new[i] = sum;
    }
    memcpy(x, x_new, sizeof(x_new));
}

#endif
