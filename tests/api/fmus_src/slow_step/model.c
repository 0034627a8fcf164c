/* Test FMU: the msd physics (model_src/msd) that sleeps SLEEP_NS in every parameter update (once
 * per simulation), so that a job on it lasts seconds on any machine: tests that act on a running
 * job (kill the service, count its processes) need one that cannot end between two looks. */
#define _POSIX_C_SOURCE 199309L
#include <time.h>

#define model_apply_parameters msd_apply_parameters
#include "msd/model.c"
#undef model_apply_parameters

#define SLEEP_NS 20000000L

const char *model_apply_parameters(const double *r, ModelCache *k) {
    struct timespec pause = {0, SLEEP_NS};
    nanosleep(&pause, NULL);
    return msd_apply_parameters(r, k);
}
