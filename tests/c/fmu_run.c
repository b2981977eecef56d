/* fmu_run: runs one FMU binary's default experiment through its C API alone, and prints
 * the values of the named value references at every communication point, one line each,
 * "%.17g" (enough digits to read the doubles back bit for bit).
 *
 *   fmu_run fmi2|fmi3 LIBRARY TOKEN RESOURCES_URI STOP STEP [VR=VALUE...] VR...
 *
 * VR=VALUE sets that Real (Float64) variable before initialisation (a start value).
 * Compiled for each platform an FMU carries (gcc, aarch64-linux-gnu-gcc,
 * x86_64-w64-mingw32-gcc) and run there (natively, under qemu-aarch64, under wine) by
 * tests/python/test_platforms.py, which compares the platforms' lines. Co-Simulation,
 * FMI 2.0 or FMI 3.0; exit status 0 when every call returned OK, 1 otherwise (the failing
 * call named on stderr).
 */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <stdarg.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
typedef HMODULE Library;
static Library open_library(const char *path) { return LoadLibraryA(path); }
static void *symbol(Library l, const char *name) { return (void *)GetProcAddress(l, name); }
#else
#include <dlfcn.h>
typedef void *Library;
static Library open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *symbol(Library l, const char *name) { return dlsym(l, name); }
#endif

static Library lib;

static void *need(const char *name) {
    void *f = symbol(lib, name);
    if (!f) {
        fprintf(stderr, "fmu_run: no symbol %s\n", name);
        exit(2);
    }
    return f;
}

static void check(int status, const char *call) {
    if (status != 0) {
        fprintf(stderr, "fmu_run: %s returned status %d\n", call, status);
        exit(1);
    }
}

/* ---- FMI 2.0 ---- */
typedef void (*Logger2)(void *, const char *, int, const char *, const char *, ...);
typedef struct {
    Logger2 logger;
    void *(*allocate)(size_t, size_t);
    void (*free)(void *);
    void *step_finished;
    void *env;
} Callbacks2;

static void logger2(void *env, const char *instance, int status, const char *category,
                    const char *message, ...) {
    va_list args;
    (void)env;
    va_start(args, message);
    fprintf(stderr, "[%s %d %s] ", instance, status, category);
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

static int run2(const char *token, const char *resources, double stop, double step,
                const unsigned *set_vrs, const double *set_values, int n_set,
                const unsigned *vrs, int n) {
    typedef void *(*Instantiate)(const char *, int, const char *, const char *,
                                 const Callbacks2 *, int, int);
    typedef int (*Setup)(void *, int, double, double, int, double);
    typedef int (*Mode)(void *);
    typedef int (*DoStep)(void *, double, double, int);
    typedef int (*GetReal)(void *, const unsigned *, size_t, double *);
    typedef int (*SetReal)(void *, const unsigned *, size_t, const double *);
    typedef void (*Free)(void *);
    static Callbacks2 callbacks = {logger2, calloc, free, NULL, NULL};
    void *c = ((Instantiate)need("fmi2Instantiate"))("run", 1 /* fmi2CoSimulation */, token,
                                                      resources, &callbacks, 0, 0);
    double *v = calloc((size_t)n + 1, sizeof(double));
    long steps = (long)(stop / step + 0.5), i;
    int k;
    if (!c) {
        fprintf(stderr, "fmu_run: fmi2Instantiate returned NULL\n");
        return 1;
    }
    check(((Setup)need("fmi2SetupExperiment"))(c, 0, 0.0, 0.0, 1, stop), "fmi2SetupExperiment");
    if (n_set > 0)
        check(((SetReal)need("fmi2SetReal"))(c, set_vrs, (size_t)n_set, set_values), "fmi2SetReal");
    check(((Mode)need("fmi2EnterInitializationMode"))(c), "fmi2EnterInitializationMode");
    check(((Mode)need("fmi2ExitInitializationMode"))(c), "fmi2ExitInitializationMode");
    for (i = 0; i <= steps; i++) {
        double t = i * step;
        check(((GetReal)need("fmi2GetReal"))(c, vrs, (size_t)n, v), "fmi2GetReal");
        printf("%.17g", t);
        for (k = 0; k < n; k++) printf(" %.17g", v[k]);
        printf("\n");
        if (i < steps) check(((DoStep)need("fmi2DoStep"))(c, t, step, 1), "fmi2DoStep");
    }
    check(((Mode)need("fmi2Terminate"))(c), "fmi2Terminate");
    ((Free)need("fmi2FreeInstance"))(c);
    free(v);
    return 0;
}

/* ---- FMI 3.0 ---- */
static void logger3(void *env, int status, const char *category, const char *message) {
    (void)env;
    fprintf(stderr, "[%d %s] %s\n", status, category, message);
}

static int run3(const char *token, const char *resources, double stop, double step,
                const unsigned *set_vrs, const double *set_values, int n_set,
                const unsigned *vrs, int n) {
    typedef void *(*Instantiate)(const char *, const char *, const char *, bool, bool, bool,
                                 bool, const unsigned *, size_t, void *, void *, void *);
    typedef int (*Enter)(void *, bool, double, double, bool, double);
    typedef int (*Mode)(void *);
    typedef int (*DoStep)(void *, double, double, bool, bool *, bool *, bool *, double *);
    typedef int (*GetFloat64)(void *, const unsigned *, size_t, double *, size_t);
    typedef int (*SetFloat64)(void *, const unsigned *, size_t, const double *, size_t);
    typedef void (*Free)(void *);
    void *c = ((Instantiate)need("fmi3InstantiateCoSimulation"))(
        "run", token, resources, false, false, false, false, NULL, 0, NULL, (void *)logger3, NULL);
    double *v = calloc((size_t)n + 1, sizeof(double));
    long steps = (long)(stop / step + 0.5), i;
    int k;
    bool event, terminate, early;
    double last;
    if (!c) {
        fprintf(stderr, "fmu_run: fmi3InstantiateCoSimulation returned NULL\n");
        return 1;
    }
    if (n_set > 0)
        check(((SetFloat64)need("fmi3SetFloat64"))(c, set_vrs, (size_t)n_set, set_values,
                                                    (size_t)n_set),
              "fmi3SetFloat64");
    check(((Enter)need("fmi3EnterInitializationMode"))(c, false, 0.0, 0.0, true, stop),
          "fmi3EnterInitializationMode");
    check(((Mode)need("fmi3ExitInitializationMode"))(c), "fmi3ExitInitializationMode");
    for (i = 0; i <= steps; i++) {
        double t = i * step;
        check(((GetFloat64)need("fmi3GetFloat64"))(c, vrs, (size_t)n, v, (size_t)n),
              "fmi3GetFloat64");
        printf("%.17g", t);
        for (k = 0; k < n; k++) printf(" %.17g", v[k]);
        printf("\n");
        if (i < steps)
            check(((DoStep)need("fmi3DoStep"))(c, t, step, true, &event, &terminate, &early, &last),
                  "fmi3DoStep");
    }
    check(((Mode)need("fmi3Terminate"))(c), "fmi3Terminate");
    ((Free)need("fmi3FreeInstance"))(c);
    free(v);
    return 0;
}

int main(int argc, char **argv) {
    unsigned *vrs, *set_vrs;
    double *set_values;
    int n = 0, n_set = 0, k;
    if (argc < 8) {
        fprintf(stderr,
                "usage: fmu_run fmi2|fmi3 LIBRARY TOKEN RESOURCES_URI STOP STEP [VR=VALUE...] VR...\n");
        return 2;
    }
    lib = open_library(argv[2]);
    if (!lib) {
        fprintf(stderr, "fmu_run: cannot load %s\n", argv[2]);
        return 2;
    }
    vrs = calloc((size_t)argc, sizeof(unsigned));
    set_vrs = calloc((size_t)argc, sizeof(unsigned));
    set_values = calloc((size_t)argc, sizeof(double));
    for (k = 7; k < argc; k++) {
        const char *eq = strchr(argv[k], '=');
        if (eq) {
            set_vrs[n_set] = (unsigned)strtoul(argv[k], NULL, 10);
            set_values[n_set++] = strtod(eq + 1, NULL);
        } else {
            vrs[n++] = (unsigned)strtoul(argv[k], NULL, 10);
        }
    }
    if (strcmp(argv[1], "fmi3") == 0)
        return run3(argv[3], argv[4], atof(argv[5]), atof(argv[6]), set_vrs, set_values, n_set,
                    vrs, n);
    return run2(argv[3], argv[4], atof(argv[5]), atof(argv[6]), set_vrs, set_values, n_set, vrs,
                n);
}
