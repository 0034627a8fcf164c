/*
 * Native co-simulation master loop of fmuid (FMI 2.0 and 3.0, Real/Float64 inputs and outputs).
 *
 * The same loop as fmuid.model.cosim.run_cosimulation (the reference it is tested against),
 * calling the FMU's own fmi2SetReal / fmi2SetRealInputDerivatives / fmi2DoStep / fmi2GetReal
 * (or fmi3SetFloat64 / fmi3DoStep / fmi3GetFloat64) through the function pointers of the library
 * fmpy loaded. The arithmetic is written in the order of the Python loop (compiled without
 * contraction into fused multiply-adds), so both give the same numbers.
 *
 * fmuid_feedback is the closed loop of fmuid.model.feedback.run_feedback in the same way.
 *
 * On a status above Warning the loop stops and says where (FmuidLoop.fail_*); Python builds the
 * error or, for a request to terminate, reads the stop time.
 */
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

typedef int (*SetReal2)(void *, const unsigned *, size_t, const double *);
typedef int (*GetReal2)(void *, const unsigned *, size_t, double *);
typedef int (*SetDer2)(void *, const unsigned *, size_t, const int *, const double *);
typedef int (*DoStep2)(void *, double, double, int);
typedef int (*SetFloat3)(void *, const unsigned *, size_t, const double *, size_t);
typedef int (*GetFloat3)(void *, const unsigned *, size_t, double *, size_t);
typedef int (*DoStep3)(void *, double, double, bool, bool *, bool *, bool *, double *);

enum {
    CALL_SET = 0,
    CALL_DERIVATIVES = 1,
    CALL_GET = 2,
    CALL_STEP = 3,
    CALL_SUB_SET = 4,
    CALL_GET_SOURCES = 5,
    DIVERGED = 6
};
#define STATUS_DIVERGED 100

/* Mirrored by fmuid.model.native.loop.Loop (ctypes): keep the two in the same order. */
typedef struct {
    void *component;
    void *set_real, *set_derivatives, *do_step, *get_real;
    int fmi3;
    long n_times;
    const double *times;          /* grid [s], n_times */
    const double *value;          /* inputs at each grid point, n_times x n_in */
    const double *slope;          /* input slopes over each interval, n_times x n_in */
    const unsigned char *moving;  /* sub-step this interval (NULL: never) */
    const double *segment;        /* length [s] of the input sample interval it lies in */
    long n_in;
    const unsigned *in_refs;
    long n_cont;                  /* continuous inputs: sub-stepped or given derivatives */
    const long *cont_index;
    const unsigned *cont_refs;
    const int *orders;            /* n_cont ones, for fmi2SetRealInputDerivatives */
    int use_derivatives;
    double sub_step;              /* longest sub-step [s] of a moving interval */
    long max_sub_steps;           /* most sub-steps per input sample interval */
    long n_out;
    const unsigned *out_refs;
    const long *row_start;        /* rows read at grid point k: rows[row_start[k]:row_start[k+1]] */
    const long *rows;
    double *result;               /* n_rows x n_out, rows not read are left alone */
    double *work;                 /* n_in + n_out scratch values */
    long fail_k;                  /* grid point of the failed call */
    int fail_call;                /* CALL_* */
    double fail_time;             /* time quoted: sub-step start (step) or the values' time */
    bool terminate;               /* FMI 3.0: terminateSimulation of the failed step */
    double last_time;             /* FMI 3.0: lastSuccessfulTime of the failed step */
} FmuidLoop;

/* Mirrored by fmuid.model.native.feedback.Terms (ctypes): keep the two in the same order. */
typedef struct {
    long n_src;
    const unsigned *src_refs;     /* outputs the terms read */
    long n_terms;
    const long *input;            /* index of the input each term is added to */
    const long *source;           /* index of the source it reads */
    const int *derivative;        /* 1: the finite-difference rate of the source */
    const int *kind;              /* 0 power, 1 tanh, 2 dead band */
    const double *coefficient;
    const double *shape;          /* whole exponent, width or band */
    double *level, *previous;     /* n_src each */
    double *g, *g_prev;           /* n_in each */
    double *rate, *trend;         /* n_src, n_in: the last differences, held between updates */
    double min_gap;               /* shortest baseline [s] of a difference (half the step) */
} FmuidTerms;

static int set_values(FmuidLoop *L, const unsigned *refs, long n, const double *v) {
    if (L->fmi3) return ((SetFloat3)L->set_real)(L->component, refs, (size_t)n, v, (size_t)n);
    return ((SetReal2)L->set_real)(L->component, refs, (size_t)n, v);
}

static int get_values(FmuidLoop *L, double *v) {
    size_t n = (size_t)L->n_out;
    if (L->fmi3) return ((GetFloat3)L->get_real)(L->component, L->out_refs, n, v, n);
    return ((GetReal2)L->get_real)(L->component, L->out_refs, n, v);
}

static int step(FmuidLoop *L, double t, double h) {
    bool event = false, early = false;
    int status;
    if (!L->fmi3) return ((DoStep2)L->do_step)(L->component, t, h, 1);
    L->terminate = false;
    status = ((DoStep3)L->do_step)(L->component, t, h, true, &event, &L->terminate, &early,
                                   &L->last_time);
    return (status <= 1 && L->terminate) ? 2 : status;
}

/* Read the outputs into y and copy them to every result row read at point k (none: no call). */
static int store_rows(FmuidLoop *L, long k, double *y) {
    if (L->row_start[k + 1] == L->row_start[k]) return 0;
    int status = get_values(L, y);
    if (status > 1) return status;
    for (long r = L->row_start[k]; r < L->row_start[k + 1]; r++) {
        double *row = L->result + L->rows[r] * L->n_out;
        for (long o = 0; o < L->n_out; o++) row[o] = y[o];
    }
    return status;
}

static int failed(FmuidLoop *L, int status, long k, int call, double t) {
    L->fail_k = k;
    L->fail_call = call;
    L->fail_time = t;
    return status;
}

/*
 * Cross the moving interval [t, t + h] in n equal sub-steps, each holding the continuous
 * inputs' linear value at the sub-step's midpoint: sub-steps of at most sub_step seconds, or
 * of the input sample interval over max_sub_steps where that is longer.
 */
static int sub_steps(FmuidLoop *L, long k, double t, double h) {
    const double *v = L->value + k * L->n_in, *s = L->slope + k * L->n_in;
    double *u = L->work;
    double longest = fmax(L->sub_step, L->segment[k] / (double)L->max_sub_steps);
    long n = (long)ceil(h / longest - 1e-9);
    int status;
    if (n < 1) n = 1;
    for (long j = 0; j < n; j++) {
        double t_j = t + h * (double)j / (double)n;
        double t_mid = t + h * ((double)j + 0.5) / (double)n;
        for (long i = 0; i < L->n_cont; i++) {
            long c = L->cont_index[i];
            u[i] = v[c] + s[c] * (t_mid - t);
        }
        status = set_values(L, L->cont_refs, L->n_cont, u);
        if (status > 1) return failed(L, status, k, CALL_SUB_SET, t_mid);
        status = step(L, t_j, t + h * ((double)j + 1.0) / (double)n - t_j);
        if (status > 1) return failed(L, status, k, CALL_STEP, t_j);
    }
    return 0;
}

/* Run the grid; 0 when it ran to the end, else the status of the call at fault (see fail_*). */
int fmuid_cosimulation(FmuidLoop *L) {
    double *u = L->work, *y = L->work + L->n_in;
    long last = L->n_times - 1;
    int status;
    for (long k = 0; k <= last; k++) {
        double t = L->times[k];
        if (k && L->n_in) {
            status = set_values(L, L->in_refs, L->n_in, L->value + k * L->n_in);
            if (status > 1) return failed(L, status, k, CALL_SET, t);
        }
        if (L->use_derivatives && L->n_cont) {
            const double *s = L->slope + k * L->n_in;
            for (long i = 0; i < L->n_cont; i++) u[i] = s[L->cont_index[i]];
            status = ((SetDer2)L->set_derivatives)(L->component, L->cont_refs, (size_t)L->n_cont,
                                                   L->orders, u);
            if (status > 1) return failed(L, status, k, CALL_DERIVATIVES, t);
        }
        status = store_rows(L, k, y);
        if (status > 1) return failed(L, status, k, CALL_GET, t);
        if (k == last) break;
        if (L->moving != NULL && L->moving[k]) {
            status = sub_steps(L, k, t, L->times[k + 1] - t);
            if (status > 1) return status;
        } else {
            status = step(L, t, L->times[k + 1] - t);
            if (status > 1) return failed(L, status, k, CALL_STEP, t);
        }
    }
    return 0;
}

/* One term at x, as fmuid.model.feedback.FeedbackTerm.value computes it. */
static double term_value(int kind, double coefficient, double shape, double x) {
    double low, clipped;
    if (kind == 0) return coefficient * pow(x, shape);
    if (kind == 1) return coefficient * tanh(x / shape);
    low = (-shape > x) ? -shape : x;      /* Python's max(x, -band) */
    clipped = (shape < low) ? shape : low; /* min(.., band) */
    return coefficient * (x - clipped);
}

static int get_sources(FmuidLoop *L, FmuidTerms *F) {
    size_t n = (size_t)F->n_src;
    if (L->fmi3) return ((GetFloat3)L->get_real)(L->component, F->src_refs, n, F->level, n);
    return ((GetReal2)L->get_real)(L->component, F->src_refs, n, F->level);
}

/*
 * The closed loop: at every grid point read the sources, add the terms to the measured inputs,
 * set them (and their slopes plus the terms' trend over the previous step), read the outputs,
 * step; an FMU without input derivatives holds the line's midpoint value over the step instead.
 * 0 when it ran to the end, else a status (STATUS_DIVERGED for a non-finite term).
 */
int fmuid_feedback(FmuidLoop *L, FmuidTerms *F) {
    double *u = L->work, *y = L->work + L->n_in;
    long last = L->n_times - 1;
    double t_prev = L->times[0];
    int status;
    for (long j = 0; j < F->n_src; j++) F->rate[j] = 0.0;
    for (long i = 0; i < L->n_in; i++) F->trend[i] = 0.0;
    for (long k = 0; k <= last; k++) {
        double t = L->times[k];
        const double *v = L->value + k * L->n_in, *s = L->slope + k * L->n_in;
        status = get_sources(L, F);
        if (status > 1) return failed(L, status, k, CALL_GET_SOURCES, t);
        int update = k > 0 && t - t_prev >= F->min_gap;
        if (update)
            for (long j = 0; j < F->n_src; j++)
                F->rate[j] = (F->level[j] - F->previous[j]) / (t - t_prev);
        for (long i = 0; i < L->n_in; i++) F->g[i] = 0.0;
        for (long m = 0; m < F->n_terms; m++) {
            long j = F->source[m];
            double x = F->derivative[m] ? F->rate[j] : F->level[j];
            F->g[F->input[m]] += term_value(F->kind[m], F->coefficient[m], F->shape[m], x);
        }
        for (long i = 0; i < L->n_in; i++) {
            if (!isfinite(F->g[i])) return failed(L, STATUS_DIVERGED, k, DIVERGED, t);
            u[i] = v[i] + F->g[i];
            if (update) F->trend[i] = (F->g[i] - F->g_prev[i]) / (t - t_prev);
        }
        status = set_values(L, L->in_refs, L->n_in, u);
        if (status > 1) return failed(L, status, k, CALL_SET, t);
        if (L->use_derivatives && L->n_cont) {
            for (long i = 0; i < L->n_cont; i++) {
                long c = L->cont_index[i];
                u[i] = s[c] + F->trend[c];
            }
            status = ((SetDer2)L->set_derivatives)(L->component, L->cont_refs, (size_t)L->n_cont,
                                                   L->orders, u);
            if (status > 1) return failed(L, status, k, CALL_DERIVATIVES, t);
        }
        status = store_rows(L, k, y);
        if (status > 1) return failed(L, status, k, CALL_GET, t);
        if (k == last) break;
        double h = L->times[k + 1] - t;
        if (!L->use_derivatives) {
            for (long i = 0; i < L->n_in; i++)
                u[i] = v[i] + F->g[i] + 0.5 * h * (s[i] + F->trend[i]);
            status = set_values(L, L->in_refs, L->n_in, u);
            if (status > 1) return failed(L, status, k, CALL_SUB_SET, t + h / 2);
        }
        if (k == 0 || update) {
            for (long j = 0; j < F->n_src; j++) F->previous[j] = F->level[j];
            for (long i = 0; i < L->n_in; i++) F->g_prev[i] = F->g[i];
            t_prev = t;
        }
        status = step(L, t, h);
        if (status > 1) return failed(L, status, k, CALL_STEP, t);
    }
    return 0;
}
