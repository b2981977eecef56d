/* A hand-written FMI 2.0 Co-Simulation FMU in plain C: the comparator of issue 12
 * (`scripts/bench-dostep`). What a careful person writing one of the benchmark systems by
 * hand would ship: the equations of src/bench/floors.rs typed on fixed-size arrays, a
 * fixed-step RK4 doStep with the step plan of our FMUs (src/integrators/problem.rs
 * step_count, src/integrators/rk4.rs: the same arithmetic), the state-machine and argument
 * checks of every FMU function, a finiteness check, the projection where the system has
 * one, and the outputs evaluated after every step and served by fmi2GetReal. Logging off:
 * the logger is only called on errors.
 *
 * Built once per system:
 *   gcc -O2 -fPIC -shared -ffp-contract=off -DSYSTEM_<Name> fmu.c -o <Name>.so -lm
 * with <Name> one of MassSpringDamper TwoMassChain RigidBody CompoundPendulum
 * DoublePendulum. There is no modelDescription.xml: the value references are the indices
 * of VAR_NAMES below (states, then outputs, then parameters with solver_step last, then
 * inputs), the GUID is "{handwritten-<Name>}", and the only Integer is the solver
 * (value reference 0; this FMU has RK4 = 1 only).
 */

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- The FMI 2.0 types this file needs (fmi2TypesPlatform.h, fmi2FunctionTypes.h) ---- */

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef const char *fmi2String;
#define fmi2True 1
#define fmi2False 0

typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum {
    fmi2DoStepStatus,
    fmi2PendingStatus,
    fmi2LastSuccessfulTime,
    fmi2Terminated
} fmi2StatusKind;

typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String,
                                   fmi2String, ...);
typedef void *(*fmi2CallbackAllocateMemory)(size_t, size_t);
typedef void (*fmi2CallbackFreeMemory)(void *);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment, fmi2Status);

typedef struct {
    const fmi2CallbackLogger logger;
    const fmi2CallbackAllocateMemory allocateMemory;
    const fmi2CallbackFreeMemory freeMemory;
    const fmi2StepFinished stepFinished;
    const fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

#define EXPORT __attribute__((visibility("default")))

/* ---- The systems: sizes, variables, start values, equations ---- */
/* Each defines NX states, NY outputs, NP parameters (solver_step is added after them), NU
 * inputs; VAR_NAMES and START in that order; rhs(t, x, u, p, dx); outputs(t, x, u, p, y);
 * project(p, x). The equations are those of src/bench/floors.rs, the outputs those our
 * FMU computes after a step (src/systems/<system>.rs). */

#if defined(SYSTEM_MassSpringDamper)

#define MODEL "MassSpringDamper"
#define NX 2
#define NY 1
#define NP 5
#define NU 1
static const char *const VAR_NAMES[] = {"x", "v", "E", "m", "k", "c", "F_amp", "F_omega",
                                        "solver_step", "F"};
static const double START[] = {0.1, 0.0, 0.0, 1.0, 100.0, 2.0, 0.0, 10.0, 1e-3, 0.0};

/* m ẍ + c ẋ + k x = F + F_amp sin(F_omega t) */
static inline void rhs(double t, const double *x, const double *u, const double *p, double *dx) {
    const double m = p[0], k = p[1], c = p[2], f_amp = p[3], f_omega = p[4];
    const double force = f_amp == 0.0 ? u[0] : u[0] + f_amp * sin(f_omega * t);
    dx[0] = x[1];
    dx[1] = (force - c * x[1] - k * x[0]) / m;
}

/* E = ½ m v² + ½ k x² */
static inline void outputs(double t, const double *x, const double *u, const double *p,
                           double *y) {
    (void)t, (void)u;
    y[0] = p[0] * x[1] * x[1] * 0.5 + p[1] * x[0] * x[0] * 0.5;
}

static inline void project(const double *p, double *x) { (void)p, (void)x; }

#elif defined(SYSTEM_TwoMassChain)

#define MODEL "TwoMassChain"
#define NX 4
#define NY 1
#define NP 5
#define NU 1
static const char *const VAR_NAMES[] = {"x1", "x2", "v1", "v2", "E", "m1", "m2", "k1",
                                        "k2", "c2", "solver_step", "F"};
static const double START[] = {0.1, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 100.0, 100.0, 2.0, 1e-3, 0.0};

/* wall–k1–m1–(k2 ∥ c2)–m2, force F on m1 */
static inline void rhs(double t, const double *x, const double *u, const double *p, double *dx) {
    (void)t;
    const double m1 = p[0], m2 = p[1], k1 = p[2], k2 = p[3], c2 = p[4];
    const double coupling = k2 * (x[1] - x[0]) + c2 * (x[3] - x[2]);
    dx[0] = x[2];
    dx[1] = x[3];
    dx[2] = (u[0] - k1 * x[0] + coupling) / m1;
    dx[3] = -coupling / m2;
}

/* E = ½ m1 v1² + ½ m2 v2² + ½ k1 x1² + ½ k2 (x2 − x1)² */
static inline void outputs(double t, const double *x, const double *u, const double *p,
                           double *y) {
    (void)t, (void)u;
    const double m1 = p[0], m2 = p[1], k1 = p[2], k2 = p[3];
    const double stretch = x[1] - x[0];
    y[0] = (m1 * x[2] * x[2] + m2 * x[3] * x[3] + k1 * x[0] * x[0] + k2 * stretch * stretch) *
           0.5;
}

static inline void project(const double *p, double *x) { (void)p, (void)x; }

#elif defined(SYSTEM_RigidBody)

#define MODEL "RigidBody"
#define NX 7
#define NY 7
#define NP 3
#define NU 3
static const char *const VAR_NAMES[] = {
    "omega1", "omega2", "omega3", "q0", "q1", "q2", "q3", "roll", "pitch", "yaw", "H1", "H2",
    "H3", "E", "I1", "I2", "I3", "solver_step", "N1", "N2", "N3"};
static const double START[] = {1.0, 0.5, 0.2, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                               0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 1e-3, 0.0, 0.0, 0.0};

/* Euler's equations and q̇ = ½ q ⊗ (0, Ω) */
static inline void rhs(double t, const double *x, const double *u, const double *p, double *dx) {
    (void)t;
    const double i1 = p[0], i2 = p[1], i3 = p[2];
    const double w1 = x[0], w2 = x[1], w3 = x[2], q0 = x[3], q1 = x[4], q2 = x[5], q3 = x[6];
    dx[0] = ((i2 - i3) * w2 * w3 + u[0]) / i1;
    dx[1] = ((i3 - i1) * w3 * w1 + u[1]) / i2;
    dx[2] = ((i1 - i2) * w1 * w2 + u[2]) / i3;
    dx[3] = -(q1 * w1 + q2 * w2 + q3 * w3) * 0.5;
    dx[4] = (q0 * w1 + q2 * w3 - q3 * w2) * 0.5;
    dx[5] = (q0 * w2 + q3 * w1 - q1 * w3) * 0.5;
    dx[6] = (q0 * w3 + q1 * w2 - q2 * w1) * 0.5;
}

/* roll, pitch, yaw (atan2 of the attitude matrix, roll = 0 at gimbal lock), the inertial
 * angular momentum H = R(q) (I1 Ω1, I2 Ω2, I3 Ω3) and the energy, as our FMU computes
 * them (src/systems/rigid_body.rs). */
static inline void outputs(double t, const double *x, const double *u, const double *p,
                           double *y) {
    (void)t, (void)u;
    const double i1 = p[0], i2 = p[1], i3 = p[2];
    const double w1 = x[0], w2 = x[1], w3 = x[2], q0 = x[3], q1 = x[4], q2 = x[5], q3 = x[6];
    const double n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3;
    const double d00 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3;
    const double d11 = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3;
    const double d22 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3;
    const double o01 = q1 * q2 - q0 * q3, o10 = q1 * q2 + q0 * q3;
    const double o02 = q1 * q3 + q0 * q2, o20 = q1 * q3 - q0 * q2;
    const double o12 = q2 * q3 - q0 * q1, o21 = q2 * q3 + q0 * q1;
    /* The angles on the unnormalised matrix (atan2 is invariant to the factor |q|²). */
    const double r20 = o20 * 2.0, r21 = o21 * 2.0, r10 = o10 * 2.0;
    const double cos_theta = sqrt(r21 * r21 + d22 * d22);
    y[1] = atan2(-r20, cos_theta);
    if (cos_theta <= 1e-12 * n2) {
        y[0] = 0.0;
        y[2] = atan2(-(o01 * 2.0), d11);
    } else {
        y[0] = atan2(r21, d22);
        y[2] = atan2(r10, d00);
    }
    /* H on the normalised matrix R(q) = homogeneous form / |q|². */
    const double s = 1.0 / n2, two = s * 2.0;
    const double h0 = i1 * w1, h1 = i2 * w2, h2 = i3 * w3;
    y[3] = d00 * s * h0 + o01 * two * h1 + o02 * two * h2;
    y[4] = o10 * two * h0 + d11 * s * h1 + o12 * two * h2;
    y[5] = o20 * two * h0 + o21 * two * h1 + d22 * s * h2;
    y[6] = (i1 * w1 * w1 + i2 * w2 * w2 + i3 * w3 * w3) * 0.5;
}

/* q ← q / |q| after every step (a zero or non-finite norm leaves q alone). */
static inline void project(const double *p, double *x) {
    (void)p;
    const double n = sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6]);
    if (isfinite(n) && n > 0.0) {
        x[3] /= n;
        x[4] /= n;
        x[5] /= n;
        x[6] /= n;
    }
}

#elif defined(SYSTEM_CompoundPendulum)

#define MODEL "CompoundPendulum"
#define NX 2
#define NY 1
#define NP 4
#define NU 1
static const char *const VAR_NAMES[] = {"theta", "theta_dot", "E",           "m", "l",
                                        "I_O",   "g",         "solver_step", "tau"};
static const double START[] = {0.1, 0.0, 0.0, 1.0, 0.5, 1.0 / 3.0, 9.81, 1e-3, 0.0};

/* I_O θ̈ + m g l sin θ = τ */
static inline void rhs(double t, const double *x, const double *u, const double *p, double *dx) {
    (void)t;
    const double m = p[0], l = p[1], i_o = p[2], g = p[3];
    dx[0] = x[1];
    dx[1] = (u[0] - m * g * l * sin(x[0])) / i_o;
}

/* E = ½ I_O θ̇² − m g l cos θ */
static inline void outputs(double t, const double *x, const double *u, const double *p,
                           double *y) {
    (void)t, (void)u;
    const double m = p[0], l = p[1], i_o = p[2], g = p[3];
    y[0] = 0.5 * i_o * x[1] * x[1] - m * g * l * cos(x[0]);
}

static inline void project(const double *p, double *x) { (void)p, (void)x; }

#elif defined(SYSTEM_DoublePendulum)

#define MODEL "DoublePendulum"
#define NX 4
#define NY 3
#define NP 5
#define NU 2
static const char *const VAR_NAMES[] = {"theta1", "phi", "theta1_dot", "phi_dot", "F1",
                                        "F2",     "E",   "m1",         "m2",      "r1",
                                        "l2",     "g",   "solver_step", "tau1",   "tau2"};
static const double START[] = {0.05, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
                               1.0,  1.0,  1.0, 9.81, 1e-3, 0.0, 0.0};

/* Absolute angles, Cramer's rule on the 2×2 mass matrix; generalised forces of the joint
 * torques (τ1 − τ2, τ2). */
static inline void rhs(double t, const double *x, const double *u, const double *p, double *dx) {
    (void)t;
    const double th = x[0], ph = x[1], thd = x[2], phd = x[3];
    const double m1 = p[0], m2 = p[1], r1 = p[2], l2 = p[3], g = p[4];
    const double s = sin(ph - th), c = cos(ph - th);
    const double a11 = (m1 + m2) * r1 * r1;
    const double a12 = m2 * r1 * l2 * c;
    const double a22 = m2 * l2 * l2;
    const double b1 = u[0] - u[1] + m2 * r1 * l2 * phd * phd * s - (m1 + m2) * g * r1 * sin(th);
    const double b2 = u[1] - m2 * r1 * l2 * thd * thd * s - m2 * g * l2 * sin(ph);
    const double det = a11 * a22 - a12 * a12;
    dx[0] = thd;
    dx[1] = phd;
    dx[2] = (b1 * a22 - a12 * b2) / det;
    dx[3] = (a11 * b2 - b1 * a12) / det;
}

/* The rod tensions F1, F2 (axial components, from Newton's law on each particle with the
 * accelerations at the new state) and E = T + V, as src/systems/double_pendulum.rs. */
static inline void outputs(double t, const double *x, const double *u, const double *p,
                           double *y) {
    const double th = x[0], ph = x[1], thd = x[2], phd = x[3];
    const double m1 = p[0], m2 = p[1], r1 = p[2], l2 = p[3], g = p[4];
    double dx[4];
    rhs(t, x, u, p, dx);
    const double s1 = sin(th), c1 = cos(th), s2 = sin(ph), c2 = cos(ph);
    const double a1x = r1 * (dx[2] * c1 - thd * thd * s1);
    const double a1z = r1 * (dx[2] * -s1 - thd * thd * c1);
    const double a2x = a1x + l2 * (dx[3] * c2 - phd * phd * s2);
    const double a2z = a1z + l2 * (dx[3] * -s2 - phd * phd * c2);
    const double f1x = m1 * (0.0 - a1x), f1z = m1 * (g - a1z);
    const double f2x = m2 * (0.0 - a2x), f2z = m2 * (g - a2z);
    y[0] = (f1x + f2x) * s1 + (f1z + f2z) * c1;
    y[1] = f2x * s2 + f2z * c2;
    const double kinetic = 0.5 * (m1 + m2) * r1 * r1 * thd * thd + 0.5 * m2 * l2 * l2 * phd * phd +
                           m2 * r1 * l2 * thd * phd * cos(ph - th);
    const double potential = -g * ((m1 + m2) * r1 * c1 + m2 * l2 * c2);
    y[2] = kinetic + potential;
}

static inline void project(const double *p, double *x) { (void)p, (void)x; }

#else
#error "define one of SYSTEM_MassSpringDamper SYSTEM_TwoMassChain SYSTEM_RigidBody SYSTEM_CompoundPendulum SYSTEM_DoublePendulum"
#endif

/* ---- The instance ---- */

#define NV (NX + NY + NP + 1 + NU)
#define IX 0
#define IY NX
#define IP (NX + NY)
#define ISTEP (NX + NY + NP)
#define IU (NX + NY + NP + 1)
#define GUID "{handwritten-" MODEL "}"

_Static_assert(sizeof(VAR_NAMES) / sizeof(VAR_NAMES[0]) == NV, "one name per variable");
_Static_assert(sizeof(START) / sizeof(START[0]) == NV, "one start value per variable");

typedef enum {
    INSTANTIATED = 1 << 0,
    INITIALIZATION_MODE = 1 << 1,
    STEP_COMPLETE = 1 << 2,
    STEP_FAILED = 1 << 3,
    TERMINATED = 1 << 4,
    ERROR_STATE = 1 << 5,
} Machine;

#define ANY_STATE 0x3f
#define GET_STATES (INITIALIZATION_MODE | STEP_COMPLETE | STEP_FAILED | TERMINATED | ERROR_STATE)
#define SET_STATES (INSTANTIATED | INITIALIZATION_MODE | STEP_COMPLETE)
#define BEFORE_INIT_DONE (INSTANTIATED | INITIALIZATION_MODE)

typedef struct {
    double v[NV]; /* states, outputs, parameters, solver_step, inputs */
    double time;
    double stop_time;
    int stop_time_defined;
    int solver;
    Machine machine;
    int logging_on;
    char *name;
    const fmi2CallbackFunctions *cb;
} Instance;

/* Errors go to the logger (always, as FMI 2.0 asks for fmi2Error); nothing is logged on
 * the success path. */
static fmi2Status fail(const Instance *m, fmi2Status status, const char *fmt, ...) {
    if (m && m->cb && m->cb->logger) {
        char msg[512];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(msg, sizeof msg, fmt, ap);
        va_end(ap);
        m->cb->logger(m->cb->componentEnvironment, m->name,
                      status, status == fmi2Discard ? "logStatusDiscard" : "logStatusError",
                      "%s", msg);
    }
    return status;
}

#define REQUIRE(m, states, fn)                                                                 \
    do {                                                                                       \
        if (!(m)) return fmi2Error;                                                            \
        if (!((m)->machine & (states)))                                                        \
            return fail((m), fmi2Error, fn ": not allowed in state %d", (int)(m)->machine);    \
    } while (0)

static void reset_values(Instance *m) {
    memcpy(m->v, START, sizeof m->v);
    m->time = 0.0;
    m->stop_time = 0.0;
    m->stop_time_defined = 0;
    m->solver = 1;
    m->machine = INSTANTIATED;
}

/* max(1, a) for a ≥ 0 (fmax is a libm call at -O2). */
static inline double max1(double a) { return a > 1.0 ? a : 1.0; }

static int all_finite(const double *a, int n) {
    for (int i = 0; i < n; i++)
        if (!isfinite(a[i])) return 0;
    return 1;
}

/* ---- Fixed-step RK4, the step plan and arithmetic of src/integrators/{problem,rk4}.rs ---- */

static inline uint64_t step_count(double span, double step) {
    if (!(step > 0.0 && isfinite(step))) return 1;
    const double full = (double)(uint64_t)(span / step);
    const double rest = span - full * step;
    return (uint64_t)(rest <= 1e-10 * step ? (full > 1.0 ? full : 1.0) : full + 1.0);
}

/* From (t0, x) to t_end: 0 on success (x at t_end), else -1 with x untouched at the last
 * good step (its time in *t_reached). */
static int rk4(double t0, double t_end, double step, double *x, const double *u, const double *p,
               double *t_reached) {
    const uint64_t n = step_count(t_end - t0, step);
    double k1[NX], k2[NX], k3[NX], k4[NX], y[NX];
    double t = t0;
    for (uint64_t i = 0; i < n; i++) {
        const double ta = t;
        const double tb = i + 1 == n ? t_end : t0 + (double)(i + 1) * step;
        const double h = tb - ta;
        const double tm = ta + 0.5 * h;
        rhs(ta, x, u, p, k1);
        for (int j = 0; j < NX; j++) y[j] = x[j] + 0.5 * h * k1[j];
        rhs(tm, y, u, p, k2);
        for (int j = 0; j < NX; j++) y[j] = x[j] + 0.5 * h * k2[j];
        rhs(tm, y, u, p, k3);
        for (int j = 0; j < NX; j++) y[j] = x[j] + h * k3[j];
        rhs(tb, y, u, p, k4);
        for (int j = 0; j < NX; j++) y[j] = x[j] + h / 6.0 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
        if (!all_finite(y, NX)) {
            *t_reached = ta;
            return -1;
        }
        memcpy(x, y, sizeof y);
        t = tb;
    }
    *t_reached = t;
    return 0;
}

/* ---- FMI 2.0 functions ---- */

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                                     fmi2String resourceLocation,
                                     const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                                     fmi2Boolean loggingOn) {
    (void)resourceLocation, (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    Instance probe = {.cb = functions, .name = (char *)(instanceName ? instanceName : "?")};
    if (!instanceName || !*instanceName) {
        fail(&probe, fmi2Error, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        fail(&probe, fmi2Error, "fmi2Instantiate: only Co-Simulation is supported");
        return NULL;
    }
    if (!guid || strcmp(guid, GUID) != 0) {
        fail(&probe, fmi2Error, "fmi2Instantiate: GUID %s is not " GUID, guid ? guid : "(null)");
        return NULL;
    }
    Instance *m = functions->allocateMemory(1, sizeof(Instance));
    if (!m) return NULL;
    size_t len = strlen(instanceName) + 1;
    m->name = functions->allocateMemory(len, 1);
    if (!m->name) {
        functions->freeMemory(m);
        return NULL;
    }
    memcpy(m->name, instanceName, len);
    m->cb = functions;
    m->logging_on = loggingOn;
    reset_values(m);
    return m;
}

EXPORT void fmi2FreeInstance(fmi2Component c) {
    Instance *m = c;
    if (!m) return;
    fmi2CallbackFreeMemory free_memory = m->cb->freeMemory;
    free_memory(m->name);
    free_memory(m);
}

EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n,
                                      const fmi2String categories[]) {
    Instance *m = c;
    REQUIRE(m, ANY_STATE, "fmi2SetDebugLogging");
    (void)n, (void)categories;
    m->logging_on = loggingOn;
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                                      fmi2Real tolerance, fmi2Real startTime,
                                      fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *m = c;
    REQUIRE(m, INSTANTIATED, "fmi2SetupExperiment");
    (void)toleranceDefined, (void)tolerance;
    if (!isfinite(startTime))
        return fail(m, fmi2Error, "fmi2SetupExperiment: startTime must be finite");
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime))
        return fail(m, fmi2Error, "fmi2SetupExperiment: stopTime %g before startTime %g", stopTime,
                    startTime);
    m->time = startTime;
    m->stop_time_defined = stopTimeDefined != 0;
    m->stop_time = stopTime;
    return fmi2OK;
}

EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *m = c;
    REQUIRE(m, INSTANTIATED, "fmi2EnterInitializationMode");
    m->machine = INITIALIZATION_MODE;
    return fmi2OK;
}

EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *m = c;
    REQUIRE(m, INITIALIZATION_MODE, "fmi2ExitInitializationMode");
    if (!all_finite(m->v, NV))
        return fail(m, fmi2Error, "fmi2ExitInitializationMode: a start value is not finite");
    outputs(m->time, m->v + IX, m->v + IU, m->v + IP, m->v + IY);
    m->machine = STEP_COMPLETE;
    return fmi2OK;
}

EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *m = c;
    REQUIRE(m, STEP_COMPLETE | STEP_FAILED, "fmi2Terminate");
    m->machine = TERMINATED;
    return fmi2OK;
}

EXPORT fmi2Status fmi2Reset(fmi2Component c) {
    Instance *m = c;
    REQUIRE(m, ANY_STATE, "fmi2Reset");
    reset_values(m);
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                              fmi2Real value[]) {
    Instance *m = c;
    REQUIRE(m, GET_STATES, "fmi2GetReal");
    if (nvr > 0 && (!vr || !value)) return fail(m, fmi2Error, "fmi2GetReal: NULL array");
    if (m->machine == INITIALIZATION_MODE) /* the outputs of the start values set so far */
        outputs(m->time, m->v + IX, m->v + IU, m->v + IP, m->v + IY);
    for (size_t i = 0; i < nvr; i++)
        if (vr[i] >= NV) return fail(m, fmi2Error, "fmi2GetReal: unknown value reference %u", vr[i]);
    for (size_t i = 0; i < nvr; i++) value[i] = m->v[vr[i]];
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                              const fmi2Real value[]) {
    Instance *m = c;
    REQUIRE(m, SET_STATES, "fmi2SetReal");
    if (nvr > 0 && (!vr || !value)) return fail(m, fmi2Error, "fmi2SetReal: NULL array");
    for (size_t i = 0; i < nvr; i++) {
        const fmi2ValueReference r = vr[i];
        if (r >= NV) return fail(m, fmi2Error, "fmi2SetReal: unknown value reference %u", r);
        if (r >= IY && r < IP)
            return fail(m, fmi2Error, "fmi2SetReal: %s is a calculated output", VAR_NAMES[r]);
        if (r < IU && !(m->machine & BEFORE_INIT_DONE))
            return fail(m, fmi2Error, "fmi2SetReal: %s can only be set before initialization ends",
                        VAR_NAMES[r]);
        if (!isfinite(value[i]))
            return fail(m, fmi2Error, "fmi2SetReal: %s = %g is not finite", VAR_NAMES[r], value[i]);
        if (r == ISTEP && !(value[i] > 0.0))
            return fail(m, fmi2Error, "fmi2SetReal: solver_step must be positive");
    }
    for (size_t i = 0; i < nvr; i++) m->v[vr[i]] = value[i];
    /* A new input changes the outputs that depend on it at once. */
    if (m->machine == STEP_COMPLETE) outputs(m->time, m->v + IX, m->v + IU, m->v + IP, m->v + IY);
    return fmi2OK;
}

EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                 fmi2Integer value[]) {
    Instance *m = c;
    REQUIRE(m, GET_STATES, "fmi2GetInteger");
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != 0) return fail(m, fmi2Error, "fmi2GetInteger: unknown value reference %u", vr[i]);
        value[i] = m->solver;
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                 const fmi2Integer value[]) {
    Instance *m = c;
    REQUIRE(m, BEFORE_INIT_DONE, "fmi2SetInteger");
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] != 0) return fail(m, fmi2Error, "fmi2SetInteger: unknown value reference %u", vr[i]);
        if (value[i] != 1) return fail(m, fmi2Error, "fmi2SetInteger: solver %d: only RK4 (1)", value[i]);
    }
    return fmi2OK;
}

EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                             fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    Instance *m = c;
    REQUIRE(m, STEP_COMPLETE, "fmi2DoStep");
    const double h = communicationStepSize, current = currentCommunicationPoint;
    if (!(isfinite(h) && h > 0.0))
        return fail(m, fmi2Error,
                    "fmi2DoStep: communicationStepSize must be positive and finite, got %g", h);
    const double now = m->time;
    if (!isfinite(current) || fabs(current - now) > 1e-9 * max1(fabs(now)))
        return fail(m, fmi2Error, "fmi2DoStep: currentCommunicationPoint %.17g is not the FMU's time %.17g",
                    current, now);
    const double t_end = current + h;
    if (m->stop_time_defined && t_end > m->stop_time + 1e-9 * max1(fabs(m->stop_time)))
        return fail(m, fmi2Error, "fmi2DoStep: the step ends at %.17g, after stopTime %.17g", t_end,
                    m->stop_time);

    double x[NX], y[NY], t_reached;
    memcpy(x, m->v + IX, sizeof x);
    const double *u = m->v + IU, *p = m->v + IP;
    if (rk4(current, t_end, m->v[ISTEP], x, u, p, &t_reached) != 0) {
        m->machine = STEP_FAILED;
        return fail(m, fmi2Discard, "fmi2DoStep: the state became non-finite after t = %.17g; state kept at t = %.17g",
                    t_reached, now);
    }
    project(p, x);
    outputs(t_end, x, u, p, y);
    if (!all_finite(x, NX) || !all_finite(y, NY)) {
        m->machine = STEP_FAILED;
        return fail(m, fmi2Discard, "fmi2DoStep: outputs became non-finite at t = %.17g; state kept at t = %.17g",
                    t_end, now);
    }
    memcpy(m->v + IX, x, sizeof x);
    memcpy(m->v + IY, y, sizeof y);
    m->time = t_end;
    return fmi2OK;
}

EXPORT fmi2Status fmi2CancelStep(fmi2Component c) {
    Instance *m = c;
    return m ? fail(m, fmi2Error, "fmi2CancelStep: doStep is synchronous") : fmi2Error;
}

EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    Instance *m = c;
    REQUIRE(m, STEP_COMPLETE | STEP_FAILED | TERMINATED, "fmi2GetStatus");
    (void)s, (void)value;
    return fail(m, fmi2Discard, "fmi2GetStatus: not available (doStep is synchronous)");
}

EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *m = c;
    REQUIRE(m, STEP_COMPLETE | STEP_FAILED | TERMINATED, "fmi2GetRealStatus");
    if (s == fmi2LastSuccessfulTime && value) {
        *value = m->time;
        return fmi2OK;
    }
    return fail(m, fmi2Discard, "fmi2GetRealStatus: status kind %d not available", (int)s);
}
