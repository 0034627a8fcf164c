/* Test FMU (model exchange): a damped oscillator whose state nominals are 0 and negative, as
 * Dymola's FMUs report them. Built on the Reference-FMUs' framework (fmi2Functions.c,
 * cosimulation.c, model.h from a Reference-FMU's sources/ folder). */
#ifndef config_h
#define config_h

#define MODEL_IDENTIFIER zero_nominals
#define INSTANTIATION_TOKEN "{5a1e0c2d-7a4b-4f0e-9d0c-0b7c1e2f3a40}"

#define MODEL_EXCHANGE

#define MAX_CONTINUOUS_STATES 2

#define SET_FLOAT64

#define FIXED_SOLVER_STEP 1e-2
#define DEFAULT_STOP_TIME 4

typedef enum { vr_time, vr_x, vr_der_x, vr_v, vr_der_v, vr_k, vr_c } ValueReference;

typedef struct {
    double x;
    double der_x;
    double v;
    double der_v;
    double k;
    double c;
} ModelData;

#endif /* config_h */
