/* Test FMU: the msd physics (model_src/msd) whose library constructor, and the first parameter
 * update in each process (during a run), start a helper that escapes as far as a process can:
 * a new session (setsid), then an exec of `sleep SPAWN_MARK` with an empty environment, so that
 * neither its process group nor its environment ties it to the process that loaded the FMU.
 * Tests find these helpers by their command line. */
#define _POSIX_C_SOURCE 200809L
#include <unistd.h>

#define model_apply_parameters msd_apply_parameters
#include "msd/model.c"
#undef model_apply_parameters

#define SPAWN_MARK "3517"

static void spawn_helper(void) {
    pid_t pid = fork();
    if (pid == 0) {
        char *argv[] = {"sleep", SPAWN_MARK, NULL};
        char *envp[] = {NULL};
        setsid();
        execve("/bin/sleep", argv, envp);
        _exit(127);
    }
}

__attribute__((constructor)) static void on_load(void) { spawn_helper(); }

const char *model_apply_parameters(const double *r, ModelCache *k) {
    static pid_t spawned_in = 0;
    if (spawned_in != getpid()) {
        spawned_in = getpid();
        spawn_helper();
    }
    return msd_apply_parameters(r, k);
}
