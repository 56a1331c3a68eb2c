/* SUNDIALS 6 (Debian's libsundials-dev) on the benchmark scenes: CVODE (Adams with fixed-point
 * iteration, BDF with Newton), ARKODE (ERK; DIRK with Newton), IDA on the implicit form
 * y' - f(t, y) = 0. Dense or band matrices by the problem's half-bandwidth, difference-quotient
 * Jacobians (SUNDIALS' defaults). */
#include <stdio.h>
#include <string.h>

#include <arkode/arkode_arkstep.h>
#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <ida/ida.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_band.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_band.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "peers.h"

extern char peers_error_message[256];

static int f_ode(realtype t, N_Vector y, N_Vector ydot, void *user) {
    const problem_t *p = user;
    p->rhs(t, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot), p);
    return 0;
}

static int f_res(realtype t, N_Vector y, N_Vector yp, N_Vector r, void *user) {
    const problem_t *p = user;
    double *rr = N_VGetArrayPointer(r);
    const double *ypp = N_VGetArrayPointer(yp);
    p->rhs(t, N_VGetArrayPointer(y), rr, p);
    for (int i = 0; i < p->dim; i++) rr[i] = ypp[i] - rr[i];
    return 0;
}

static const char *NAMES[] = {"CVODE-ADAMS", "CVODE-BDF", "ARKODE-ERK", "ARKODE-DIRK", "IDA"};

int sundials_run(const problem_t *p, int method, double t0, double t1, const double *y0,
                 double rtol, double atol, int record, traj_t *out, stats_t *st) {
    SUNContext ctx = NULL;
    if (SUNContext_Create(NULL, &ctx)) return -1;
    int n = p->dim, rc = 0;
    void *mem = NULL;
    SUNMatrix A = NULL;
    SUNLinearSolver LS = NULL;
    SUNNonlinearSolver NLS = NULL;
    N_Vector y = N_VNew_Serial(n, ctx), yp = N_VNew_Serial(n, ctx);
    memcpy(N_VGetArrayPointer(y), y0, (size_t)n * sizeof(double));
    p->rhs(t0, y0, N_VGetArrayPointer(yp), p);
    int implicit = method == SUN_CVODE_BDF || method == SUN_ARKODE_DIRK || method == SUN_IDA;
    if (implicit) {
        if (p->half_band >= 0) {
            A = SUNBandMatrix(n, p->half_band, p->half_band, ctx);
            LS = SUNLinSol_Band(y, A, ctx);
        } else {
            A = SUNDenseMatrix(n, n, ctx);
            LS = SUNLinSol_Dense(y, A, ctx);
        }
    }
    int flag = 0;
    switch (method) {
    case SUN_CVODE_ADAMS:
    case SUN_CVODE_BDF:
        mem = CVodeCreate(method == SUN_CVODE_BDF ? CV_BDF : CV_ADAMS, ctx);
        flag |= CVodeInit(mem, f_ode, t0, y);
        flag |= CVodeSStolerances(mem, rtol, atol);
        flag |= CVodeSetUserData(mem, (void *)p);
        flag |= CVodeSetStopTime(mem, t1);
        flag |= CVodeSetMaxNumSteps(mem, 20000000L);
        flag |= CVodeSetMaxHnilWarns(mem, -1);
        if (method == SUN_CVODE_BDF) {
            flag |= CVodeSetLinearSolver(mem, LS, A);
        } else {
            NLS = SUNNonlinSol_FixedPoint(y, 0, ctx);
            flag |= CVodeSetNonlinearSolver(mem, NLS);
        }
        break;
    case SUN_ARKODE_ERK:
        mem = ERKStepCreate(f_ode, t0, y, ctx);
        flag |= ERKStepSStolerances(mem, rtol, atol);
        flag |= ERKStepSetUserData(mem, (void *)p);
        flag |= ERKStepSetStopTime(mem, t1);
        flag |= ERKStepSetMaxNumSteps(mem, 20000000L);
        /* Order 8 (Fehlberg 13-7-8): the sweep goes to tight tolerances. */
        flag |= ERKStepSetOrder(mem, 8);
        break;
    case SUN_ARKODE_DIRK:
        mem = ARKStepCreate(NULL, f_ode, t0, y, ctx);
        flag |= ARKStepSStolerances(mem, rtol, atol);
        flag |= ARKStepSetUserData(mem, (void *)p);
        flag |= ARKStepSetStopTime(mem, t1);
        flag |= ARKStepSetMaxNumSteps(mem, 20000000L);
        flag |= ARKStepSetLinearSolver(mem, LS, A);
        /* Linear scenes: tell ARKODE the implicit right-hand side is linear in y (one Newton
         * iteration per stage); without it the DIRK fails its error test on scene F. */
        if (p->scene != SCENE_D2 && p->scene != SCENE_E) flag |= ARKStepSetLinear(mem, 1);
        break;
    case SUN_IDA:
        mem = IDACreate(ctx);
        flag |= IDAInit(mem, f_res, t0, y, yp);
        flag |= IDASStolerances(mem, rtol, atol);
        flag |= IDASetUserData(mem, (void *)p);
        flag |= IDASetStopTime(mem, t1);
        flag |= IDASetMaxNumSteps(mem, 20000000L);
        flag |= IDASetLinearSolver(mem, LS, A);
        break;
    default:
        flag = -1;
    }
    if (mem == NULL || flag) {
        snprintf(peers_error_message, sizeof peers_error_message, "%s: set-up failed",
                 method >= 0 && method <= SUN_IDA ? NAMES[method] : "sundials");
        rc = -5;
        goto done;
    }
    memset(st, 0, sizeof *st);
    if (record && traj_push(out, t0, y0)) { rc = -1; goto done; }
    double t = t0;
    while (t < t1) {
        switch (method) {
        case SUN_CVODE_ADAMS:
        case SUN_CVODE_BDF: flag = CVode(mem, t1, y, &t, CV_ONE_STEP); break;
        case SUN_ARKODE_ERK: flag = ERKStepEvolve(mem, t1, y, &t, ARK_ONE_STEP); break;
        case SUN_ARKODE_DIRK: flag = ARKStepEvolve(mem, t1, y, &t, ARK_ONE_STEP); break;
        default: flag = IDASolve(mem, t1, &t, y, yp, IDA_ONE_STEP); break;
        }
        if (flag < 0) {
            snprintf(peers_error_message, sizeof peers_error_message, "%s: flag %d at t = %g",
                     NAMES[method], flag, t);
            rc = -6;
            goto done;
        }
        if (record && traj_push(out, t, N_VGetArrayPointer(y))) {
            snprintf(peers_error_message, sizeof peers_error_message,
                     "%s: more than %lu recorded values by t = %g (steps collapsing?)",
                     NAMES[method], 50000000UL, t);
            rc = -1;
            goto done;
        }
    }
    if (!record && traj_push(out, t, N_VGetArrayPointer(y))) { rc = -1; goto done; }
    long nst = 0, nfe = 0, nfi = 0, nni = 0, netf = 0, ncf = 0;
    switch (method) {
    case SUN_CVODE_ADAMS:
    case SUN_CVODE_BDF:
        CVodeGetNumSteps(mem, &nst);
        CVodeGetNumRhsEvals(mem, &nfe);
        CVodeGetNumNonlinSolvIters(mem, &nni);
        CVodeGetNumErrTestFails(mem, &netf);
        CVodeGetNumNonlinSolvConvFails(mem, &ncf);
        break;
    case SUN_ARKODE_ERK:
        ERKStepGetNumSteps(mem, &nst);
        ERKStepGetNumRhsEvals(mem, &nfe);
        ERKStepGetNumErrTestFails(mem, &netf);
        break;
    case SUN_ARKODE_DIRK:
        ARKStepGetNumSteps(mem, &nst);
        ARKStepGetNumRhsEvals(mem, &nfe, &nfi);
        nfe += nfi;
        ARKStepGetNumNonlinSolvIters(mem, &nni);
        ARKStepGetNumErrTestFails(mem, &netf);
        ARKStepGetNumNonlinSolvConvFails(mem, &ncf);
        break;
    default:
        IDAGetNumSteps(mem, &nst);
        IDAGetNumResEvals(mem, &nfe);
        IDAGetNumNonlinSolvIters(mem, &nni);
        IDAGetNumErrTestFails(mem, &netf);
        IDAGetNumNonlinSolvConvFails(mem, &ncf);
        break;
    }
    st->steps = nst;
    st->rhs_evals = nfe;
    st->newton_iters = nni;
    st->rejected = netf + ncf;
done:
    switch (method) {
    case SUN_CVODE_ADAMS:
    case SUN_CVODE_BDF: CVodeFree(&mem); break;
    case SUN_ARKODE_ERK: ERKStepFree(&mem); break;
    case SUN_ARKODE_DIRK: ARKStepFree(&mem); break;
    case SUN_IDA: IDAFree(&mem); break;
    default: break;
    }
    if (LS) SUNLinSolFree(LS);
    if (NLS) SUNNonlinSolFree(NLS);
    if (A) SUNMatDestroy(A);
    N_VDestroy(y);
    N_VDestroy(yp);
    SUNContext_Free(&ctx);
    return rc;
}
