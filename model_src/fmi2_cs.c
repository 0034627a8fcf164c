/*
 * Shared FMI 2.0 co-simulation layer used by every fmuid model.
 *
 * The model's physics (model.h) is integrated with a fixed-step classical Runge-Kutta method:
 * a communication step h is split into n = ceil(h / 4 ms) equal sub-steps, so runs are
 * deterministic and the outputs are smooth functions of the parameters. At 4 ms the tractor's
 * yaw rates stay within 1e-6 rad/s of a tight solve_ivp reference at every corner of the thesis's
 * Table 3.2 bounds (tests/model), at a quarter of the cost of 1 ms. Inputs are linear inside a step when the master sets first-order input
 * derivatives (fmi2SetRealInputDerivatives): u(t) = u + du/dt * (t - t_set), with t_set the
 * communication point at which the value was set. Every error returns fmi2Error, logs a message
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

#define MAX_SUBSTEP 4e-3
#define N_INPUTS_ALLOC (N_INPUTS > 0 ? N_INPUTS : 1)

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
    Mode mode;
} Snapshot;

typedef struct {
    Snapshot s;
    ModelCache *cache;
    int cache_valid;
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
    c->cache_valid = 1;
    return fmi2OK;
}

static void inputs_at(const Instance *c, double t, double *u) {
    for (int i = 0; i < N_INPUTS; i++) {
        u[i] = c->s.r[INPUT_VRS[i]] + c->s.input_der[i] * (t - c->s.input_time[i]);
    }
}

static void rk4_step(Instance *c, double t, double h) {
    double k1[N_STATES], k2[N_STATES], k3[N_STATES], k4[N_STATES], xt[N_STATES];
    double u[N_INPUTS_ALLOC];
    double *x = c->s.x;
    const double half = 0.5 * h;

    inputs_at(c, t, u);
    model_derivatives(c->cache, x, u, k1);
    for (int i = 0; i < N_STATES; i++) xt[i] = x[i] + half * k1[i];
    inputs_at(c, t + half, u);
    model_derivatives(c->cache, xt, u, k2);
    for (int i = 0; i < N_STATES; i++) xt[i] = x[i] + half * k2[i];
    model_derivatives(c->cache, xt, u, k3);
    for (int i = 0; i < N_STATES; i++) xt[i] = x[i] + h * k3[i];
    inputs_at(c, t + h, u);
    model_derivatives(c->cache, xt, u, k4);
    for (int i = 0; i < N_STATES; i++) {
        x[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    }
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
    long n;
    double dt;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(c, "fmi2DoStep", MODE_STEP)) return fmi2Error;
    if (!isfinite(h) || h < 0.0) return fail(c, "fmi2DoStep: invalid step size %g", h);
    if (!(fabs(t0 - c->s.time) <= 1e-9 * fmax(1.0, fabs(c->s.time)))) {
        return fail(c, "fmi2DoStep: communication point %.17g differs from the FMU time %.17g",
                    t0, c->s.time);
    }
    if (apply_parameters(c) != fmi2OK) return fmi2Error;
    n = (long)ceil(h / MAX_SUBSTEP - 1e-9);
    if (n < 1) n = 1;
    dt = h / (double)n;
    for (long k = 0; k < n; k++) {
        rk4_step(c, t0 + (double)k * dt, dt);
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
