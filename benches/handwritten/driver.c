/* The one harness of `scripts/bench-dostep`: the same binary drives our FMU and the
 * hand-written one (benches/handwritten/fmu.c) through the C ABI (dlopen, dlsym), so both
 * pay the same call path.
 *
 *   driver LIB GUID RESOURCE_URI STATE_VRS [vr=value | ivr=value]... count COUNT
 *   driver LIB GUID RESOURCE_URI STATE_VRS [vr=value | ivr=value]... time REPS N
 *   driver LIB GUID RESOURCE_URI STATE_VRS [vr=value | ivr=value]... bad
 *
 * STATE_VRS: comma-separated value references printed at the end of `count` (states, and
 * any outputs wanted). `vr=value` sets a Real (fmi2SetReal), `ivr=value` an Integer
 * (fmi2SetInteger; the `i` is a prefix: `i3=1`), both after fmi2Instantiate, before
 * fmi2SetupExperiment (start 0, no tolerance, no stop time); then fmi2EnterInitializationMode
 * and fmi2ExitInitializationMode.
 *
 * count COUNT: COUNT calls fmi2DoStep(t, 1e-3), t advancing by t += 1e-3, then prints
 *   `t=<time>` and one `vr=<value>` line per STATE_VRS entry (%.17g). For callgrind:
 *   instructions per doStep = (Ir(COUNT) − Ir(0)) / COUNT.
 * time REPS N: REPS repetitions of N doSteps, each timed with clock_gettime
 *   (CLOCK_MONOTONIC); prints one line per repetition: ns per doStep.
 * bad: after 10 good steps, the refusals a careful FMU gives: h = 0, h < 0, h = NaN, a wrong
 *   current time, then one more good step; prints `<case> <status>` per call.
 *
 * Exits 1 on any unexpected status.
 */

#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef const char *fmi2String;
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;

typedef struct {
    void (*logger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*Instantiate)(fmi2String, fmi2Type, fmi2String, fmi2String,
                                     const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
typedef void (*FreeInstance)(fmi2Component);
typedef fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean,
                                      fmi2Real);
typedef fmi2Status (*Simple)(fmi2Component);
typedef fmi2Status (*GetReal)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
typedef fmi2Status (*SetReal)(fmi2Component, const fmi2ValueReference *, size_t,
                              const fmi2Real *);
typedef fmi2Status (*SetInteger)(fmi2Component, const fmi2ValueReference *, size_t,
                                 const fmi2Integer *);
typedef fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);

static const char *const STATUS[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};

/* The logger prints (to stderr, the FMU's message formatted with its arguments). */
static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    char text[2048];
    va_list ap;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message, ap);
    va_end(ap);
    fprintf(stderr, "[%s] %s %s: %s\n", instance ? instance : "?",
            (unsigned)status < 6 ? STATUS[status] : "?", category ? category : "", text);
}

static void die(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    exit(1);
}

static void *sym(void *lib, const char *name, int required) {
    void *f = dlsym(lib, name);
    if (!f && required) die("driver: %s not found: %s", name, dlerror());
    return f;
}

static void check(fmi2Status s, const char *what) {
    if (s != fmi2OK) die("driver: %s returned %s", what, (unsigned)s < 6 ? STATUS[s] : "?");
}

static double now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

int main(int argc, char **argv) {
    if (argc < 7)
        die("usage: %s LIB GUID RESOURCE_URI STATE_VRS [vr=value|ivr=value]... "
            "(count COUNT | time REPS N | bad)",
            argv[0]);
    const char *lib_path = argv[1], *guid = argv[2], *resources = argv[3];
    /* State value references. */
    fmi2ValueReference state_vr[64];
    size_t n_states = 0;
    {
        char *list = strdup(argv[4]);
        for (char *tok = strtok(list, ","); tok; tok = strtok(NULL, ",")) {
            if (n_states == 64) die("driver: too many value references");
            state_vr[n_states++] = (fmi2ValueReference)strtoul(tok, NULL, 10);
        }
        free(list);
    }

    void *lib = dlopen(lib_path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) die("driver: dlopen %s: %s", lib_path, dlerror());
    Instantiate instantiate = (Instantiate)sym(lib, "fmi2Instantiate", 1);
    FreeInstance free_instance = (FreeInstance)sym(lib, "fmi2FreeInstance", 1);
    SetupExperiment setup = (SetupExperiment)sym(lib, "fmi2SetupExperiment", 1);
    Simple enter_init = (Simple)sym(lib, "fmi2EnterInitializationMode", 1);
    Simple exit_init = (Simple)sym(lib, "fmi2ExitInitializationMode", 1);
    Simple terminate = (Simple)sym(lib, "fmi2Terminate", 1);
    GetReal get_real = (GetReal)sym(lib, "fmi2GetReal", 1);
    SetReal set_real = (SetReal)sym(lib, "fmi2SetReal", 1);
    SetInteger set_integer = (SetInteger)sym(lib, "fmi2SetInteger", 0);
    DoStep do_step = (DoStep)sym(lib, "fmi2DoStep", 1);

    const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = instantiate("bench", fmi2CoSimulation, guid, resources, &callbacks, 0, 0);
    if (!c) die("driver: fmi2Instantiate failed");

    /* Start values, then the mode. */
    int i = 5;
    for (; i < argc && strchr(argv[i], '='); i++) {
        const char *arg = argv[i];
        const char *eq = strchr(arg, '=');
        if (arg[0] == 'i') {
            fmi2ValueReference vr = (fmi2ValueReference)strtoul(arg + 1, NULL, 10);
            fmi2Integer v = (fmi2Integer)strtol(eq + 1, NULL, 10);
            if (!set_integer) die("driver: the FMU has no fmi2SetInteger");
            check(set_integer(c, &vr, 1, &v), arg);
        } else {
            fmi2ValueReference vr = (fmi2ValueReference)strtoul(arg, NULL, 10);
            fmi2Real v = strtod(eq + 1, NULL);
            check(set_real(c, &vr, 1, &v), arg);
        }
    }
    if (i >= argc) die("driver: no mode (count COUNT | time REPS N | bad)");
    const char *mode = argv[i];
    check(setup(c, 0, 0.0, 0.0, 0, 0.0), "fmi2SetupExperiment");
    check(enter_init(c), "fmi2EnterInitializationMode");
    check(exit_init(c), "fmi2ExitInitializationMode");

    const double h = 1e-3;
    double t = 0.0;
    if (strcmp(mode, "count") == 0 && i + 1 < argc) {
        long count = strtol(argv[i + 1], NULL, 10);
        for (long k = 0; k < count; k++) {
            if (do_step(c, t, h, 1) != fmi2OK) die("driver: fmi2DoStep failed at t = %g", t);
            t += h;
        }
        double values[64];
        check(get_real(c, state_vr, n_states, values), "fmi2GetReal");
        printf("t=%.17g\n", t);
        for (size_t k = 0; k < n_states; k++) printf("%u=%.17g\n", state_vr[k], values[k]);
    } else if (strcmp(mode, "time") == 0 && i + 2 < argc) {
        long reps = strtol(argv[i + 1], NULL, 10), n = strtol(argv[i + 2], NULL, 10);
        for (long r = 0; r < reps; r++) {
            const double start = now_ns();
            for (long k = 0; k < n; k++) {
                if (do_step(c, t, h, 1) != fmi2OK) die("driver: fmi2DoStep failed at t = %g", t);
                t += h;
            }
            printf("%.3f\n", (now_ns() - start) / (double)n);
        }
    } else if (strcmp(mode, "bad") == 0) {
        for (int k = 0; k < 10; k++) {
            check(do_step(c, t, h, 1), "fmi2DoStep");
            t += h;
        }
        struct {
            const char *name;
            double current, step;
        } cases[] = {
            {"h_zero", t, 0.0},
            {"h_negative", t, -h},
            {"h_nan", t, NAN},
            {"h_inf", t, INFINITY},
            {"time_ahead", t + 1e-6, h},
            {"time_behind", t - h, h},
            {"time_nan", NAN, h},
        };
        for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
            fmi2Status s = do_step(c, cases[k].current, cases[k].step, 1);
            printf("%s %s\n", cases[k].name, (unsigned)s < 6 ? STATUS[s] : "?");
        }
        fmi2Status s = do_step(c, t, h, 1);
        printf("good %s\n", (unsigned)s < 6 ? STATUS[s] : "?");
        t += h;
        double values[64];
        check(get_real(c, state_vr, n_states, values), "fmi2GetReal");
        printf("t=%.17g\n", t);
        for (size_t k = 0; k < n_states; k++) printf("%u=%.17g\n", state_vr[k], values[k]);
    } else {
        die("driver: unknown mode %s", mode);
    }
    fflush(stdout);
    check(terminate(c), "fmi2Terminate");
    free_instance(c);
    /* (No dlclose: a Rust cdylib may keep thread-local destructors registered.) */
    return 0;
}
