/* x' = v, v' = -k x - c v, x(0) = 1, v(0) = 0; nominals of x and v: -2 and 0 (invalid). */
#include "config.h"
#include "model.h"

Status setStartValues(ModelInstance *comp) {
    M(x) = 1;
    M(v) = 0;
    M(k) = 4;
    M(c) = 0.4;
    comp->isDirtyValues = true;
    return OK;
}

Status calculateValues(ModelInstance *comp) {
    M(der_x) = M(v);
    M(der_v) = -M(k) * M(x) - M(c) * M(v);
    comp->isDirtyValues = false;
    return OK;
}

Status getFloat64(ModelInstance *comp, ValueReference vr, double values[], size_t nValues,
                  size_t *index) {
    calculateValues(comp);
    ASSERT_NVALUES(1);
    switch (vr) {
        case vr_time: values[(*index)++] = comp->time; return OK;
        case vr_x: values[(*index)++] = M(x); return OK;
        case vr_der_x: values[(*index)++] = M(der_x); return OK;
        case vr_v: values[(*index)++] = M(v); return OK;
        case vr_der_v: values[(*index)++] = M(der_v); return OK;
        case vr_k: values[(*index)++] = M(k); return OK;
        case vr_c: values[(*index)++] = M(c); return OK;
        default:
            logError(comp, "Get Float64 is not allowed for value reference %u.", vr);
            return Error;
    }
}

Status setFloat64(ModelInstance *comp, ValueReference vr, const double values[], size_t nValues,
                  size_t *index) {
    ASSERT_NVALUES(1);
    switch (vr) {
        case vr_x: M(x) = values[(*index)++]; break;
        case vr_v: M(v) = values[(*index)++]; break;
        case vr_k: M(k) = values[(*index)++]; break;
        case vr_c: M(c) = values[(*index)++]; break;
        default:
            logError(comp, "Set Float64 is not allowed for value reference %u.", vr);
            return Error;
    }
    comp->isDirtyValues = true;
    return OK;
}

size_t getNumberOfContinuousStates(ModelInstance *comp) {
    UNUSED(comp);
    return MAX_CONTINUOUS_STATES;
}

Status getContinuousStates(ModelInstance *comp, double x[], size_t nx) {
    ASSERT_SIZE_T(nx, MAX_CONTINUOUS_STATES);
    x[0] = M(x);
    x[1] = M(v);
    return OK;
}

Status getNominalsOfContinuousStates(ModelInstance *comp, double nominals[], size_t nx) {
    ASSERT_SIZE_T(nx, MAX_CONTINUOUS_STATES);
    nominals[0] = -2.0;
    nominals[1] = 0.0;
    return OK;
}

Status setContinuousStates(ModelInstance *comp, const double x[], size_t nx) {
    ASSERT_SIZE_T(nx, MAX_CONTINUOUS_STATES);
    M(x) = x[0];
    M(v) = x[1];
    comp->isDirtyValues = true;
    return OK;
}

Status getDerivatives(ModelInstance *comp, double dx[], size_t nx) {
    ASSERT_SIZE_T(nx, MAX_CONTINUOUS_STATES);
    calculateValues(comp);
    dx[0] = M(der_x);
    dx[1] = M(der_v);
    return OK;
}

Status eventUpdate(ModelInstance *comp) {
    comp->valuesOfContinuousStatesChanged = false;
    comp->nominalsOfContinuousStatesChanged = false;
    comp->terminateSimulation = false;
    comp->nextEventTimeDefined = false;
    return OK;
}
