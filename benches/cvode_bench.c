/* SUNDIALS CVODE (6.x) on a scene of an mbfmu FMU, for benches/peers.py.
 *
 * The right-hand side is the FMU's own: the program dlopens binaries/linux64/<Model>.so and,
 * on an instance left in Initialization Mode (fmi2Instantiate, fmi2SetupExperiment,
 * fmi2EnterInitializationMode, fmi2SetReal of the scene's parameters and inputs), evaluates
 *     f(x):    fmi2SetReal(states, x); fmi2GetReal(der(states))
 *     J(x):    fmi2GetDirectionalDerivative(der(states), {state_j}, {1}) for every column j
 * No equation is typed here.
 *
 * argv[1]: "adams" (Adams-Moulton, fixed-point iteration: the non-stiff setting), "bdf" (BDF,
 *          Newton with a dense linear solver and the FMU's exact Jacobian), "rhscost" (time
 *          the FMI calls alone: one f(x0) and one J(x0)), or "fmu": no CVODE, the FMU's own
 *          integrator through its C ABI (a cross-check of the in-process times of `mbfmu
 *          bench`: fmi2Instantiate, the start values, fmi2SetInteger(solver),
 *          fmi2SetupExperiment(tol), initialisation, fmi2DoStep to T in steps of `comm`).
 * stdin (whitespace separated):
 *     so_path guid
 *     n T reps rtol ntrace
 *     state_vr[n] der_vr[n] atol[n] x0[n]
 *     nset (vr value)[nset]                  parameters and inputs of the scene
 *     nforce [vr amplitude omega]            nforce = 1: input vr := amplitude sin(omega t)
 *     trace_t[ntrace]                        output times (ntrace = 0: the stop time only)
 *     fmu mode only: solver_vr code solver_step_vr step comm
 * stdout: "ok nfev nsteps netf njev nnlcf cpu_s x(T)[0..n)" then, when ntrace > 0, one line
 *     "trace t x[0..n)" per output time; or "fail WHY". rhscost: "ok rhs_s jac_s"; fmu:
 *     "ok cpu_s x(T)[0..n)" (the FMU does not report its RHS count through FMI).
 * Time: CLOCK_MONOTONIC around CVodeCreate .. CVode(T) (the FMU instance is created before),
 * minimum over reps; trace runs are run once and their time includes the outputs.
 */
#include <cvode/cvode.h>
#include <dlfcn.h>
#include <math.h>
#include <nvector/nvector_serial.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>
#include <time.h>

/* The FMI 2.0 types used here (fmi2TypesPlatform.h, fmi2FunctionTypes.h). */
typedef void *fmi2Component;
typedef unsigned int fmi2ValueReference;
typedef struct {
  void (*logger)(void *, const char *, int, const char *, const char *, ...);
  void *(*allocateMemory)(size_t, size_t);
  void (*freeMemory)(void *);
  void (*stepFinished)(void *, int);
  void *componentEnvironment;
} fmi2CallbackFunctions;
typedef fmi2Component (*Instantiate)(const char *, int, const char *, const char *,
                                     const fmi2CallbackFunctions *, int, int);
typedef int (*Setup)(fmi2Component, int, double, double, int, double);
typedef int (*Comp)(fmi2Component);
typedef void (*FreeInstance)(fmi2Component);
typedef int (*Real)(fmi2Component, const fmi2ValueReference *, size_t, double *);
typedef int (*SetRealT)(fmi2Component, const fmi2ValueReference *, size_t, const double *);
typedef int (*SetIntT)(fmi2Component, const fmi2ValueReference *, size_t, const int *);
typedef int (*DoStepT)(fmi2Component, double, double, int);
typedef int (*DirDer)(fmi2Component, const fmi2ValueReference *, size_t,
                      const fmi2ValueReference *, size_t, const double *, double *);

static void logger(void *env, const char *name, int status, const char *category,
                   const char *message, ...) {
  (void)env;
  va_list ap;
  va_start(ap, message);
  fprintf(stderr, "[%s %d %s] ", name, status, category);
  vfprintf(stderr, message, ap);
  fputc('\n', stderr);
  va_end(ap);
}

static fmi2Component comp;
static SetRealT set_real;
static Real get_real;
static DirDer dir_der;
static int n, force_on;
static fmi2ValueReference *svr, *dvr, force_vr;
static double force_amp, force_omega;

static int rhs(realtype t, N_Vector y, N_Vector ydot, void *data) {
  (void)data;
  if (force_on) {
    double u = force_amp * sin(force_omega * t);
    if (set_real(comp, &force_vr, 1, &u) > 1) return -1;
  }
  /* A state outside its [min, max] is refused by the FMU: recoverable (a smaller step). */
  if (set_real(comp, svr, n, N_VGetArrayPointer(y)) > 1) return 1;
  if (get_real(comp, dvr, n, N_VGetArrayPointer(ydot)) > 1) return -1;
  return 0;
}

static int jac(realtype t, N_Vector y, N_Vector fy, SUNMatrix J, void *data, N_Vector t1,
               N_Vector t2, N_Vector t3) {
  (void)t; (void)fy; (void)data; (void)t2; (void)t3;
  if (set_real(comp, svr, n, N_VGetArrayPointer(y)) > 1) return 1;
  double one = 1.0, *col = N_VGetArrayPointer(t1);
  for (int j = 0; j < n; j++) {
    if (dir_der(comp, dvr, n, &svr[j], 1, &one, col) > 1) return -1;
    for (int i = 0; i < n; i++) SM_ELEMENT_D(J, i, j) = col[i];
  }
  return 0;
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#define READ(fmt, ptr) \
  if (scanf(fmt, ptr) != 1) { printf("fail input\n"); return 0; }

int main(int argc, char **argv) {
  if (argc < 2) return 2;
  int bdf = strcmp(argv[1], "bdf") == 0, cost = strcmp(argv[1], "rhscost") == 0;
  int own = strcmp(argv[1], "fmu") == 0;
  char so[4096], guid[256];
  double T, rtol;
  int reps, ntrace, nset;
  if (scanf("%4095s %255s", so, guid) != 2) { printf("fail input\n"); return 0; }
  if (scanf("%d %lf %d %lf %d", &n, &T, &reps, &rtol, &ntrace) != 5) { printf("fail input\n"); return 0; }
  svr = malloc(n * sizeof *svr);
  dvr = malloc(n * sizeof *dvr);
  double *atol = malloc(n * sizeof *atol), *x0 = malloc(n * sizeof *x0);
  for (int i = 0; i < n; i++) READ("%u", &svr[i]);
  for (int i = 0; i < n; i++) READ("%u", &dvr[i]);
  for (int i = 0; i < n; i++) READ("%lf", &atol[i]);
  for (int i = 0; i < n; i++) READ("%lf", &x0[i]);
  READ("%d", &nset);
  fmi2ValueReference *set_vr = malloc((nset + 1) * sizeof *set_vr);
  double *set_val = malloc((nset + 1) * sizeof *set_val);
  for (int i = 0; i < nset; i++) {
    READ("%u", &set_vr[i]);
    READ("%lf", &set_val[i]);
  }
  READ("%d", &force_on);
  if (force_on) {
    READ("%u", &force_vr);
    READ("%lf", &force_amp);
    READ("%lf", &force_omega);
  }
  double *trace = malloc((ntrace + 1) * sizeof *trace);
  for (int i = 0; i < ntrace; i++) READ("%lf", &trace[i]);
  fmi2ValueReference solver_vr = 0, step_vr = 0;
  int code = 0;
  double step = 0, comm = 0;
  if (own) {
    READ("%u", &solver_vr);
    READ("%d", &code);
    READ("%u", &step_vr);
    READ("%lf", &step);
    READ("%lf", &comm);
  }

  void *lib = dlopen(so, RTLD_NOW | RTLD_LOCAL);
  if (!lib) { printf("fail dlopen %s\n", dlerror()); return 0; }
  Instantiate instantiate = (Instantiate)dlsym(lib, "fmi2Instantiate");
  Setup setup = (Setup)dlsym(lib, "fmi2SetupExperiment");
  Comp enter = (Comp)dlsym(lib, "fmi2EnterInitializationMode");
  FreeInstance free_instance = (FreeInstance)dlsym(lib, "fmi2FreeInstance");
  set_real = (SetRealT)dlsym(lib, "fmi2SetReal");
  get_real = (Real)dlsym(lib, "fmi2GetReal");
  dir_der = (DirDer)dlsym(lib, "fmi2GetDirectionalDerivative");
  if (!instantiate || !setup || !enter || !free_instance || !set_real || !get_real || !dir_der) {
    printf("fail dlsym\n");
    return 0;
  }
  fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
  if (own) {
    Comp exit_init = (Comp)dlsym(lib, "fmi2ExitInitializationMode");
    SetIntT set_integer = (SetIntT)dlsym(lib, "fmi2SetInteger");
    DoStepT do_step = (DoStepT)dlsym(lib, "fmi2DoStep");
    if (!exit_init || !set_integer || !do_step) { printf("fail dlsym\n"); return 0; }
    double best = 1e300, *xT = malloc(n * sizeof *xT);
    long n_comm = comm > 0 ? lround(T / comm) : 1;
    if (n_comm < 1) n_comm = 1;
    for (int r = 0; r < reps; r++) {
      double t0 = now();
      fmi2Component c = instantiate("ours", 1, guid, "", &cb, 0, 0);
      if (!c) { printf("fail fmi2Instantiate\n"); return 0; }
      int st = nset ? set_real(c, set_vr, nset, set_val) : 0;
      st |= set_real(c, svr, n, x0);
      st |= set_integer(c, &solver_vr, 1, &code);
      if (step > 0) st |= set_real(c, &step_vr, 1, &step);
      st |= setup(c, 1, rtol, 0.0, 1, T);
      st |= enter(c);
      st |= exit_init(c);
      if (st > 1) { printf("fail setup\n"); return 0; }
      double t = 0.0;
      for (long k = 0; k < n_comm; k++) {
        double h = k + 1 == n_comm ? T - t : comm;
        if (do_step(c, t, h, 1) > 1) { printf("fail fmi2DoStep at t = %g\n", t); return 0; }
        t = k + 1 == n_comm ? T : t + h;
      }
      get_real(c, svr, n, xT);
      double dt = now() - t0;
      free_instance(c);
      if (dt < best) best = dt;
    }
    printf("ok %.6e", best);
    for (int i = 0; i < n; i++) printf(" %.17g", xT[i]);
    printf("\n");
    return 0;
  }
  comp = instantiate("cvode", 1 /* fmi2CoSimulation */, guid, "", &cb, 0, 0);
  if (!comp) { printf("fail fmi2Instantiate\n"); return 0; }
  if (setup(comp, 0, 0.0, 0.0, 1, T) > 1 || enter(comp) > 1) { printf("fail init\n"); return 0; }
  if (nset && set_real(comp, set_vr, nset, set_val) > 1) { printf("fail fmi2SetReal\n"); return 0; }

  SUNContext ctx;
  if (SUNContext_Create(NULL, &ctx)) return 3;

  if (cost) {
    /* Cost of the FMI calls alone: f(x0), and one column of J(x0). */
    N_Vector y = N_VNew_Serial(n, ctx), yd = N_VNew_Serial(n, ctx);
    for (int i = 0; i < n; i++) NV_Ith_S(y, i) = x0[i];
    long calls = 200000;
    double best_f = 1e300, best_j = 1e300, one = 1.0;
    for (int r = 0; r < 3; r++) {
      double t0 = now();
      for (long k = 0; k < calls; k++) rhs(0.0, y, yd, NULL);
      double dt = (now() - t0) / calls;
      if (dt < best_f) best_f = dt;
      t0 = now();
      for (long k = 0; k < calls / 4; k++)
        dir_der(comp, dvr, n, &svr[k % n], 1, &one, N_VGetArrayPointer(yd));
      dt = (now() - t0) / (calls / 4);
      if (dt < best_j) best_j = dt;
    }
    printf("ok %.6e %.6e\n", best_f, best_j * n);
    return 0;
  }

  double best = 1e300;
  long nfev = 0, nsteps = 0, netf = 0, njev = 0, nnlcf = 0;
  double *xT = malloc(n * sizeof *xT);
  double *tr = malloc((size_t)(ntrace + 1) * n * sizeof *tr);
  if (ntrace) reps = 1;
  for (int r = 0; r < reps; r++) {
    N_Vector y = N_VNew_Serial(n, ctx), av = N_VNew_Serial(n, ctx);
    for (int i = 0; i < n; i++) {
      NV_Ith_S(y, i) = x0[i];
      NV_Ith_S(av, i) = atol[i];
    }
    SUNMatrix J = NULL;
    SUNLinearSolver LS = NULL;
    SUNNonlinearSolver NLS = NULL;
    double t0 = now();
    void *mem = CVodeCreate(bdf ? CV_BDF : CV_ADAMS, ctx);
    int flag = CVodeInit(mem, rhs, 0.0, y);
    flag |= CVodeSVtolerances(mem, rtol, av);
    flag |= CVodeSetMaxNumSteps(mem, 20000000);
    flag |= CVodeSetStopTime(mem, T);
    if (bdf) {
      J = SUNDenseMatrix(n, n, ctx);
      LS = SUNLinSol_Dense(y, J, ctx);
      flag |= CVodeSetLinearSolver(mem, LS, J);
      flag |= CVodeSetJacFn(mem, jac);
    } else {
      NLS = SUNNonlinSol_FixedPoint(y, 0, ctx);
      flag |= CVodeSetNonlinearSolver(mem, NLS);
    }
    if (flag) { printf("fail setup\n"); return 0; }
    double t = 0.0;
    if (ntrace) {
      for (int k = 0; k < ntrace && flag >= 0; k++) {
        flag = CVode(mem, trace[k], y, &t, CV_NORMAL);
        for (int i = 0; i < n; i++) tr[(size_t)k * n + i] = NV_Ith_S(y, i);
      }
      if (flag >= 0 && t < T) flag = CVode(mem, T, y, &t, CV_NORMAL);
    } else {
      flag = CVode(mem, T, y, &t, CV_NORMAL);
    }
    double dt = now() - t0;
    if (flag < 0) { printf("fail CVode flag %d at t = %g\n", flag, t); return 0; }
    if (dt < best) best = dt;
    CVodeGetNumRhsEvals(mem, &nfev);
    CVodeGetNumSteps(mem, &nsteps);
    CVodeGetNumErrTestFails(mem, &netf);
    CVodeGetNumNonlinSolvConvFails(mem, &nnlcf);
    if (bdf) CVodeGetNumJacEvals(mem, &njev);
    for (int i = 0; i < n; i++) xT[i] = NV_Ith_S(y, i);
    CVodeFree(&mem);
    if (LS) SUNLinSolFree(LS);
    if (J) SUNMatDestroy(J);
    if (NLS) SUNNonlinSolFree(NLS);
    N_VDestroy(y);
    N_VDestroy(av);
  }
  printf("ok %ld %ld %ld %ld %ld %.6e", nfev, nsteps, netf, njev, nnlcf, best);
  for (int i = 0; i < n; i++) printf(" %.17g", xT[i]);
  printf("\n");
  for (int k = 0; k < ntrace; k++) {
    printf("trace %.17g", trace[k]);
    for (int i = 0; i < n; i++) printf(" %.17g", tr[(size_t)k * n + i]);
    printf("\n");
  }
  free_instance(comp);
  SUNContext_Free(&ctx);
  dlclose(lib);
  return 0;
}
