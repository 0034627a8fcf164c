/* FMI 2.0 layer of an FMU that ignores every parameter the master sets: fmuid's shared layer
 * (copied beside this file as fmi2_cs_shared.c by the test fixture) whose
 * fmi2EnterInitializationMode re-applies every start value, whatever the call order.
 */
#include <string.h>

#include "fmi2Functions.h"

#undef fmi2EnterInitializationMode
#define fmi2EnterInitializationMode shared_enter_initialization_mode
#include "fmi2_cs_shared.c"
#undef fmi2EnterInitializationMode
#define fmi2EnterInitializationMode fmi2FullName(fmi2EnterInitializationMode)

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
    Instance *c = component;
    if (c->s.mode == MODE_INSTANTIATED) {
        memcpy(c->s.r, START_VALUES, sizeof(c->s.r));
        c->cache_valid = 0;
    }
    return shared_enter_initialization_mode(component);
}
