/*
 * Shared FMI 2.0 co-simulation layer used by every fmuid model.
 *
 * The model's physics (model.h) is integrated by the Dormand-Prince 5(4) embedded Runge-Kutta
 * pair with error control: each step's local error estimate is kept within RTOL times the
 * state's size plus ATOL (an RMS norm over the states), so the step follows the dynamics (a
 * slow process takes steps of seconds, a stiff tire transient milliseconds) and the results
 * stay within about 1e-9 of tight independent solutions. Steps end exactly at communication
 * points; the step size proposed at the end of one fmi2DoStep starts the next. Everything is
 * deterministic: the same parameters, inputs and communication points give the same numbers
 * (fmi2SetupExperiment's tolerance is ignored, as masters pass their own defaults there).
 * A model whose physics is linear (variables.json "linear": true) is stepped exactly instead,
 * by the matrix exponential of its probed A and B (linear_step.h): one step per fmi2DoStep.
 * Inputs are linear inside a step when the master sets first-order input derivatives
 * (fmi2SetRealInputDerivatives): u(t) = u + du/dt * (t - t_set), with t_set the communication
 * point at which the value was set; each stage sees the input at its own time. Every error returns fmi2Error, logs a message
 * under the category "logStatusError" and puts the instance into the error state, from which
 * only fmi2Reset, fmi2FreeInstance and the get functions are allowed.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "model.h"

#define RTOL 1e-10
#define ATOL 1e-12
/* Smallest step [s] before giving up: faster dynamics are taken as a stiff or unstable model. */
#define MIN_STEP 1e-7
#define N_INPUTS_ALLOC (N_INPUTS > 0 ? N_INPUTS : 1)
#if MODEL_LINEAR
#include "linear_step.h"
#endif

typedef enum {
    MODE_INSTANTIATED = 1,
    MODE_INITIALIZATION = 2,
    MODE_STEP = 4,
    MODE_TERMINATED = 8,
    MODE_ERROR = 16
} Mode;

#define ANY_MODE 31
#define SETTABLE_MODES (MODE_INSTANTIATED | MODE_INITIALIZATION | MODE_STEP)
#define GETTABLE_MODES (MODE_INITIALIZATION | MODE_STEP | MODE_TERMINATED | MODE_ERROR)

/* Everything that fmi2GetFMUstate saves: plain values, copied with memcpy. */
typedef struct {
    double r[N_REALS];
    double x[N_STATES];
    double input_der[N_INPUTS_ALLOC];
    double input_time[N_INPUTS_ALLOC];
    double time;
    double h_next; /* step size to try next; 0 before the first step */
    Mode mode;
} Snapshot;

typedef struct {
    Snapshot s;
    ModelCache *cache;
    int cache_valid;
#if MODEL_LINEAR
    LinearModel linear; /* A, B, c and the exact steps of the current parameters */
#endif
    const fmi2CallbackFunctions *functions;
    char *name;
} Instance;

/*
 * Log an error. The message is formatted here and passed as the logger's format string (with
 * any '%' doubled), so that loggers which cannot format variadic arguments (e.g. Python ctypes
 * callbacks) show it as well.
 */
static void log_error(Instance *c, const char *fmt, ...) {
    char message[512], escaped[1024];
    size_t j = 0;
    va_list args;
    va_start(args, fmt);
    vsnprintf(message, sizeof(message), fmt, args);
    va_end(args);
    for (size_t i = 0; message[i] != '\0' && j + 2 < sizeof(escaped); i++) {
        if (message[i] == '%') escaped[j++] = '%';
        escaped[j++] = message[i];
    }
    escaped[j] = '\0';
    if (c->functions != NULL && c->functions->logger != NULL) {
        c->functions->logger(c->functions->componentEnvironment, c->name, fmi2Error,
                             "logStatusError", escaped);
    }
}

static fmi2Status fail(Instance *c, const char *fmt, ...) {
    char message[512];
    va_list args;
    va_start(args, fmt);
    vsnprintf(message, sizeof(message), fmt, args);
    va_end(args);
    log_error(c, "%s", message);
    c->s.mode = MODE_ERROR;
    return fmi2Error;
}

static int allowed(Instance *c, const char *function, int modes) {
    if (c->s.mode & modes) {
        return 1;
    }
    fail(c, "%s is not allowed in the current state (%d) of instance %s", function, c->s.mode,
         c->name);
    return 0;
}

static void restore_start_values(Instance *c) {
    memcpy(c->s.r, START_VALUES, sizeof(c->s.r));
    memset(c->s.x, 0, sizeof(c->s.x));
    memset(c->s.input_der, 0, sizeof(c->s.input_der));
    memset(c->s.input_time, 0, sizeof(c->s.input_time));
    c->s.time = 0.0;
    c->s.h_next = 0.0;
    c->s.mode = MODE_INSTANTIATED;
    c->cache_valid = 0;
}

static fmi2Status apply_parameters(Instance *c) {
    const char *problem;
    if (c->cache_valid) {
        return fmi2OK;
    }
    problem = model_apply_parameters(c->s.r, c->cache);
    if (problem != NULL) {
        return fail(c, "invalid parameters: %s", problem);
    }
#if MODEL_LINEAR
    linear_probe(c->cache, &c->linear);
#endif
    c->cache_valid = 1;
    return fmi2OK;
}

static void inputs_at(const Instance *c, double t, double *u) {
    for (int i = 0; i < N_INPUTS; i++) {
        u[i] = c->s.r[INPUT_VRS[i]] + c->s.input_der[i] * (t - c->s.input_time[i]);
    }
}

/* Dormand-Prince 5(4) coefficients (Dormand & Prince 1980; Hairer, Norsett & Wanner, II.5). */
static const double C2 = 1.0 / 5, C3 = 3.0 / 10, C4 = 4.0 / 5, C5 = 8.0 / 9;
static const double A21 = 1.0 / 5;
static const double A31 = 3.0 / 40, A32 = 9.0 / 40;
static const double A41 = 44.0 / 45, A42 = -56.0 / 15, A43 = 32.0 / 9;
static const double A51 = 19372.0 / 6561, A52 = -25360.0 / 2187, A53 = 64448.0 / 6561,
                    A54 = -212.0 / 729;
static const double A61 = 9017.0 / 3168, A62 = -355.0 / 33, A63 = 46732.0 / 5247,
                    A64 = 49.0 / 176, A65 = -5103.0 / 18656;
static const double B1 = 35.0 / 384, B3 = 500.0 / 1113, B4 = 125.0 / 192, B5 = -2187.0 / 6784,
                    B6 = 11.0 / 84;
/* fifth-order minus embedded fourth-order weights */
static const double E1 = 71.0 / 57600, E3 = -71.0 / 16695, E4 = 71.0 / 1920,
                    E5 = -17253.0 / 339200, E6 = 22.0 / 525, E7 = -1.0 / 40;

static void derivatives_at(const Instance *c, double t, const double *x, double *dx) {
    double u[N_INPUTS_ALLOC];
    inputs_at(c, t, u);
    model_derivatives(c->cache, x, u, dx);
}

/* RMS norm of v_i / (ATOL + RTOL * max(|a_i|, |b_i|)). */
static double error_norm(const double *v, const double *a, const double *b) {
    double sum = 0.0;
    for (int i = 0; i < N_STATES; i++) {
        double scale = ATOL + RTOL * fmax(fabs(a[i]), fabs(b[i]));
        double r = v[i] / scale;
        sum += r * r;
    }
    return N_STATES > 0 ? sqrt(sum / N_STATES) : 0.0;
}

/* First step size from the derivatives at the start (Hairer, Norsett & Wanner, II.4). */
static double initial_step(const Instance *c, double t, const double *f0, double h_max) {
    double x1[N_STATES], f1[N_STATES], diff[N_STATES];
    const double *x = c->s.x;
    double d0 = error_norm(x, x, x), d1 = error_norm(f0, x, x), d2, h0, h1;
    h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = fmin(h0, h_max);
    for (int i = 0; i < N_STATES; i++) x1[i] = x[i] + h0 * f0[i];
    derivatives_at(c, t + h0, x1, f1);
    for (int i = 0; i < N_STATES; i++) diff[i] = f1[i] - f0[i];
    d2 = error_norm(diff, x, x) / h0;
    if (fmax(d1, d2) <= 1e-15) {
        h1 = fmax(1e-6, h0 * 1e-3);
    } else {
        h1 = pow(0.01 / fmax(d1, d2), 1.0 / 5.0);
    }
    return fmin(fmin(100.0 * h0, h1), h_max);
}

/*
 * Integrate the states from t0 to t_end with error-controlled Dormand-Prince steps.
 * Returns 0, or -1 when the step size falls below MIN_STEP (the model is too stiff at these
 * parameters, or its state grows without bound or became non-finite).
 */
static int integrate(Instance *c, double t0, double t_end) {
    double k1[N_STATES], k2[N_STATES], k3[N_STATES], k4[N_STATES], k5[N_STATES], k6[N_STATES],
        k7[N_STATES], xt[N_STATES], x_new[N_STATES], err[N_STATES];
    double *x = c->s.x;
    double t = t0, h_try = c->s.h_next;
    int rejected = 0;
    if (N_STATES == 0 || !(t_end > t0)) return 0;
#if MODEL_LINEAR
    {
        double u[N_INPUTS_ALLOC];
        inputs_at(c, t0, u);
        linear_advance(&c->linear, t_end - t0, u, c->s.input_der, x);
        return 0;
    }
#endif
    derivatives_at(c, t, x, k1);
    if (!(h_try > 0.0)) h_try = initial_step(c, t, k1, t_end - t0);
    while (t < t_end) {
        const double remaining = t_end - t;
        const int clipped = h_try >= remaining * (1.0 - 1e-12);
        const double h = clipped ? remaining : h_try;
        double norm, factor;
        if (!clipped && !(h >= MIN_STEP)) return -1;
        for (int i = 0; i < N_STATES; i++) xt[i] = x[i] + h * A21 * k1[i];
        derivatives_at(c, t + C2 * h, xt, k2);
        for (int i = 0; i < N_STATES; i++) xt[i] = x[i] + h * (A31 * k1[i] + A32 * k2[i]);
        derivatives_at(c, t + C3 * h, xt, k3);
        for (int i = 0; i < N_STATES; i++) {
            xt[i] = x[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        derivatives_at(c, t + C4 * h, xt, k4);
        for (int i = 0; i < N_STATES; i++) {
            xt[i] = x[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        derivatives_at(c, t + C5 * h, xt, k5);
        for (int i = 0; i < N_STATES; i++) {
            xt[i] = x[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] +
                                A65 * k5[i]);
        }
        derivatives_at(c, t + h, xt, k6);
        for (int i = 0; i < N_STATES; i++) {
            x_new[i] = x[i] + h * (B1 * k1[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i]);
        }
        derivatives_at(c, t + h, x_new, k7);
        for (int i = 0; i < N_STATES; i++) {
            err[i] = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] +
                          E7 * k7[i]);
        }
        norm = error_norm(err, x, x_new);
        if (norm <= 1.0) {
            factor = norm == 0.0 ? 5.0 : fmin(5.0, 0.9 * pow(norm, -0.2));
            if (rejected) factor = fmin(factor, 1.0);
            memcpy(x, x_new, sizeof(x_new));
            memcpy(k1, k7, sizeof(k7));
            t = clipped ? t_end : t + h;
            h_try = clipped ? fmax(h_try, h * factor) : h * factor;
            rejected = 0;
        } else {
            factor = isfinite(norm) ? fmax(0.2, 0.9 * pow(norm, -0.2)) : 0.2;
            h_try = h * factor;
            rejected = 1;
        }
    }
    c->s.h_next = h_try;
    return 0;
}

/* ---------------------------------------------------------------- common functions */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean loggingOn,
                               size_t nCategories, const fmi2String categories[]) {
    (void)component;
    (void)loggingOn;
    (void)nCategories;
    (void)categories;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    Instance probe = {.functions = functions, .name = (char *)"?"};
    Instance *c;
    (void)fmuResourceLocation;
    (void)visible;
    (void)loggingOn;
    if (instanceName == NULL || instanceName[0] == '\0') {
        log_error(&probe, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    probe.name = (char *)instanceName;
    if (fmuType != fmi2CoSimulation) {
        log_error(&probe, "fmi2Instantiate: this FMU supports co-simulation only");
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, MODEL_GUID) != 0) {
        log_error(&probe, "fmi2Instantiate: GUID %s does not match %s", fmuGUID ? fmuGUID : "",
                  MODEL_GUID);
        return NULL;
    }
    c = calloc(1, sizeof(Instance));
    if (c == NULL) {
        log_error(&probe, "fmi2Instantiate: out of memory");
        return NULL;
    }
    c->cache = calloc(1, model_cache_size());
    c->name = malloc(strlen(instanceName) + 1);
    if (c->cache == NULL || c->name == NULL) {
        log_error(&probe, "fmi2Instantiate: out of memory");
        free(c->cache);
        free(c->name);
        free(c);
        return NULL;
    }
    strcpy(c->name, instanceName);
    c->functions = functions;
    restore_start_values(c);
    return c;
}

void fmi2FreeInstance(fmi2Component component) {
    Instance *c = component;
    if (c == NULL) {
        return;
    }
    free(c->cache);
    free(c->name);
    free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
    Instance *c = component;
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (!allowed(c, "fmi2SetupExperiment", MODE_INSTANTIATED)) return fmi2Error;
    if (!isfinite(startTime)) return fail(c, "fmi2SetupExperiment: start time is not finite");
    c->s.time = startTime;
    for (int i = 0; i < N_INPUTS; i++) c->s.input_time[i] = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2EnterInitializationMode", MODE_INSTANTIATED)) return fmi2Error;
    c->s.mode = MODE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2ExitInitializationMode", MODE_INITIALIZATION)) return fmi2Error;
    if (apply_parameters(c) != fmi2OK) return fmi2Error;
    c->s.mode = MODE_STEP;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component) {
    Instance *c = component;
    if (!allowed(c, "fmi2Terminate", MODE_STEP)) return fmi2Error;
    c->s.mode = MODE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component) {
    restore_start_values((Instance *)component);
    return fmi2OK;
}

/* ---------------------------------------------------------------- get and set values */

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Instance *c = component;
    if (!allowed(c, "fmi2GetReal", GETTABLE_MODES)) return fmi2Error;
    model_outputs(c->s.x, c->s.r);
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_REALS) return fail(c, "fmi2GetReal: unknown value reference %u", vr[i]);
        value[i] = c->s.r[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetReal", SETTABLE_MODES)) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_REALS) return fail(c, "fmi2SetReal: unknown value reference %u", vr[i]);
        if (VARIABLE_KIND[vr[i]] == KIND_OUTPUT) {
            return fail(c, "fmi2SetReal: %s is an output and cannot be set", VARIABLE_NAMES[vr[i]]);
        }
        if (!isfinite(value[i])) {
            return fail(c, "fmi2SetReal: value of %s is not finite", VARIABLE_NAMES[vr[i]]);
        }
        c->s.r[vr[i]] = value[i];
        if (VARIABLE_KIND[vr[i]] == KIND_INPUT) {
            c->s.input_time[INPUT_INDEX[vr[i]]] = c->s.time;
        } else {
            c->cache_valid = 0;
        }
    }
    return fmi2OK;
}

static fmi2Status no_variables(Instance *c, const char *function, size_t nvr, int modes) {
    if (!allowed(c, function, modes)) return fmi2Error;
    if (nvr > 0) return fail(c, "%s: this FMU has no variables of that type", function);
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return no_variables(component, "fmi2GetInteger", nvr, GETTABLE_MODES);
}

fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return no_variables(component, "fmi2GetBoolean", nvr, GETTABLE_MODES);
}

fmi2Status fmi2GetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)vr;
    (void)value;
    return no_variables(component, "fmi2GetString", nvr, GETTABLE_MODES);
}

fmi2Status fmi2SetInteger(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return no_variables(component, "fmi2SetInteger", nvr, SETTABLE_MODES);
}

fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return no_variables(component, "fmi2SetBoolean", nvr, SETTABLE_MODES);
}

fmi2Status fmi2SetString(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)vr;
    (void)value;
    return no_variables(component, "fmi2SetString", nvr, SETTABLE_MODES);
}

/* ---------------------------------------------------------------- FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component component, fmi2FMUstate *state) {
    Instance *c = component;
    Snapshot *snapshot = *state;
    if (snapshot == NULL) {
        snapshot = malloc(sizeof(Snapshot));
        if (snapshot == NULL) return fail(c, "fmi2GetFMUstate: out of memory");
    }
    memcpy(snapshot, &c->s, sizeof(Snapshot));
    *state = snapshot;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component component, fmi2FMUstate state) {
    Instance *c = component;
    if (state == NULL) return fail(c, "fmi2SetFMUstate: state is NULL");
    memcpy(&c->s, state, sizeof(Snapshot));
    c->cache_valid = 0;
    if (c->s.mode & (MODE_STEP | MODE_TERMINATED)) return apply_parameters(c);
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component component, fmi2FMUstate *state) {
    (void)component;
    if (state != NULL) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component component, fmi2FMUstate state,
                                      size_t *size) {
    (void)component;
    (void)state;
    *size = sizeof(Snapshot);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component component, fmi2FMUstate state,
                                 fmi2Byte serializedState[], size_t size) {
    Instance *c = component;
    if (state == NULL || size != sizeof(Snapshot)) {
        return fail(c, "fmi2SerializeFMUstate: expected a state and %zu bytes", sizeof(Snapshot));
    }
    memcpy(serializedState, state, sizeof(Snapshot));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component component, const fmi2Byte serializedState[],
                                   size_t size, fmi2FMUstate *state) {
    Instance *c = component;
    if (size != sizeof(Snapshot)) {
        return fail(c, "fmi2DeSerializeFMUstate: expected %zu bytes, got %zu", sizeof(Snapshot),
                    size);
    }
    if (*state == NULL) {
        *state = malloc(sizeof(Snapshot));
        if (*state == NULL) return fail(c, "fmi2DeSerializeFMUstate: out of memory");
    }
    memcpy(*state, serializedState, sizeof(Snapshot));
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component component,
                                        const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return fail(component, "fmi2GetDirectionalDerivative is not provided by this FMU");
}

/* ---------------------------------------------------------------- co-simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    Instance *c = component;
    if (!allowed(c, "fmi2SetRealInputDerivatives", SETTABLE_MODES)) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] >= N_REALS || VARIABLE_KIND[vr[i]] != KIND_INPUT) {
            return fail(c, "fmi2SetRealInputDerivatives: value reference %u is not an input",
                        vr[i]);
        }
        if (order[i] != 1) {
            return fail(c, "fmi2SetRealInputDerivatives: order %d is not supported (only 1)",
                        order[i]);
        }
        if (!isfinite(value[i])) {
            return fail(c, "fmi2SetRealInputDerivatives: derivative of %s is not finite",
                        VARIABLE_NAMES[vr[i]]);
        }
        c->s.input_der[INPUT_INDEX[vr[i]]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component component, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return fail(component, "fmi2GetRealOutputDerivatives: maxOutputDerivativeOrder is 0");
}

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *c = component;
    const double t0 = currentCommunicationPoint;
    const double h = communicationStepSize;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(c, "fmi2DoStep", MODE_STEP)) return fmi2Error;
    if (!isfinite(h) || h < 0.0) return fail(c, "fmi2DoStep: invalid step size %g", h);
    if (!(fabs(t0 - c->s.time) <= 1e-9 * fmax(1.0, fabs(c->s.time)))) {
        return fail(c, "fmi2DoStep: communication point %.17g differs from the FMU time %.17g",
                    t0, c->s.time);
    }
    if (apply_parameters(c) != fmi2OK) return fmi2Error;
    if (integrate(c, t0, t0 + h) != 0) {
        return fail(c, "fmi2DoStep: the step size fell below %g s between t = %g and %g: the "
                    "model is too stiff at these parameters, or its state grows without bound or "
                    "became non-finite", MIN_STEP, t0, t0 + h);
    }
    for (int i = 0; i < N_STATES; i++) {
        if (!isfinite(c->s.x[i])) {
            return fail(c, "fmi2DoStep: the state became non-finite between t = %g and %g", t0,
                        t0 + h);
        }
    }
    c->s.time = t0 + h;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component component) {
    return fail(component, "fmi2CancelStep: steps are never asynchronous in this FMU");
}

fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind s, fmi2Status *value) {
    (void)s;
    (void)value;
    return fail(component, "fmi2GetStatus: fmi2DoStep never returns fmi2Pending");
}

fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind s, fmi2Real *value) {
    Instance *c = component;
    if (s != fmi2LastSuccessfulTime) return fail(c, "fmi2GetRealStatus: unsupported status kind");
    *value = c->s.time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component component, const fmi2StatusKind s,
                                fmi2Integer *value) {
    (void)s;
    (void)value;
    return fail(component, "fmi2GetIntegerStatus: no integer status is provided");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component component, const fmi2StatusKind s,
                                fmi2Boolean *value) {
    if (s != fmi2Terminated) {
        return fail(component, "fmi2GetBooleanStatus: unsupported status kind");
    }
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component component, const fmi2StatusKind s,
                               fmi2String *value) {
    (void)s;
    (void)value;
    return fail(component, "fmi2GetStringStatus: no string status is provided");
}
