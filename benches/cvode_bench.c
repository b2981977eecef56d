/* CVODE on a linear system x' = A x, for benches/peers.py (SUNDIALS 6.x).
 *
 * stdin: n, T, reps, rtol, then atol[n], x0[n], A[n*n] (row-major).
 * argv[1]: "adams" (Adams-Moulton, fixed-point iteration: the non-stiff setting) or
 *          "bdf" (BDF, Newton with a dense solver and the exact Jacobian A).
 * stdout: one line "ok nfev nsteps netf njev cpu_s x(T)[0] ... x(T)[n-1]" or "fail FLAG".
 * Time: CLOCK_MONOTONIC around CVodeInit..CVode(T), minimum over reps.
 */
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>
#include <time.h>

static int n;
static double *A;

static int rhs(realtype t, N_Vector y, N_Vector ydot, void *data) {
  (void)t; (void)data;
  double *x = N_VGetArrayPointer(y), *dx = N_VGetArrayPointer(ydot);
  for (int i = 0; i < n; i++) {
    double s = 0;
    for (int j = 0; j < n; j++) s += A[i * n + j] * x[j];
    dx[i] = s;
  }
  return 0;
}

static int jac(realtype t, N_Vector y, N_Vector fy, SUNMatrix J, void *data, N_Vector t1,
               N_Vector t2, N_Vector t3) {
  (void)t; (void)y; (void)fy; (void)data; (void)t1; (void)t2; (void)t3;
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) SM_ELEMENT_D(J, i, j) = A[i * n + j];
  return 0;
}

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv) {
  if (argc < 2) return 2;
  int bdf = strcmp(argv[1], "bdf") == 0;
  double T, rtol;
  int reps;
  if (scanf("%d %lf %d %lf", &n, &T, &reps, &rtol) != 4) return 2;
  double *atol = malloc(n * sizeof *atol), *x0 = malloc(n * sizeof *x0);
  A = malloc(n * n * sizeof *A);
  for (int i = 0; i < n; i++) if (scanf("%lf", &atol[i]) != 1) return 2;
  for (int i = 0; i < n; i++) if (scanf("%lf", &x0[i]) != 1) return 2;
  for (int i = 0; i < n * n; i++) if (scanf("%lf", &A[i]) != 1) return 2;

  SUNContext ctx;
  if (SUNContext_Create(NULL, &ctx)) return 3;
  double best = 1e300;
  long nfev = 0, nsteps = 0, netf = 0, njev = 0;
  double *xT = malloc(n * sizeof *xT);
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
    flag |= CVodeSetMaxNumSteps(mem, 10000000);
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
    double t;
    flag = CVode(mem, T, y, &t, CV_NORMAL);
    double dt = now() - t0;
    if (flag < 0) { printf("fail %d\n", flag); return 0; }
    if (dt < best) best = dt;
    CVodeGetNumRhsEvals(mem, &nfev);
    CVodeGetNumSteps(mem, &nsteps);
    CVodeGetNumErrTestFails(mem, &netf);
    if (bdf) CVodeGetNumJacEvals(mem, &njev);
    for (int i = 0; i < n; i++) xT[i] = NV_Ith_S(y, i);
    CVodeFree(&mem);
    if (LS) SUNLinSolFree(LS);
    if (J) SUNMatDestroy(J);
    if (NLS) SUNNonlinSolFree(NLS);
    N_VDestroy(y);
    N_VDestroy(av);
  }
  printf("ok %ld %ld %ld %ld %.6e", nfev, nsteps, netf, njev, best);
  for (int i = 0; i < n; i++) printf(" %.17g", xT[i]);
  printf("\n");
  SUNContext_Free(&ctx);
  return 0;
}
