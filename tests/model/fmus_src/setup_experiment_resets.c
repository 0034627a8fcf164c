/* FMI 2.0 layer with 20-sim's quirk: fmuid's shared layer (copied beside this file as
 * fmi2_cs_shared.c by the test fixture) whose fmi2SetupExperiment first re-applies every start
 * value, so that parameters set between fmi2Instantiate and fmi2SetupExperiment are lost.
 */
#include <string.h>

#include "fmi2Functions.h"

#undef fmi2SetupExperiment
#define fmi2SetupExperiment shared_setup_experiment
#include "fmi2_cs_shared.c"
#undef fmi2SetupExperiment
#define fmi2SetupExperiment fmi2FullName(fmi2SetupExperiment)

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
    Instance *c = component;
    if (c->s.mode == MODE_INSTANTIATED) {
        memcpy(c->s.r, START_VALUES, sizeof(c->s.r));
        c->cache_valid = 0;
    }
    return shared_setup_experiment(component, toleranceDefined, tolerance, startTime,
                                   stopTimeDefined, stopTime);
}
