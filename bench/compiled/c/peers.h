/* Compiled peers of the dirac benchmark (bench/SCENES.md): the scenes' right-hand sides in C and
 * the C integrators (adaptive Dormand-Prince 5(4), explicit symplectic compositions, SUNDIALS
 * CVODE / ARKODE / IDA). Called from the Rust driver (src/main.rs), which times the calls and
 * scores the trajectories they record. */
#ifndef PEERS_H
#define PEERS_H

#include <stddef.h>

/* Scene identifiers, in the order of the Rust enum `Scene` (src/scenes.rs). */
enum scene_id { SCENE_A = 0, SCENE_B, SCENE_D1, SCENE_D2, SCENE_E, SCENE_F, SCENE_C };

typedef struct problem problem_t;

/* One scene as a first-order system y' = f(t, y). */
struct problem {
    int scene;
    int dim;
    int n;              /* sections (F, C); 0 otherwise */
    int half_band;      /* half-bandwidth of the Jacobian for banded solvers, -1 for dense */
    int separable;      /* 1: y = (q, p), q' = p (unit masses), p' = force(q) */
    int nq;             /* number of positions when separable */
    double *par;        /* scene parameters (F: R_i then C_i; C: R, L, C, V) */
    void (*rhs)(double t, const double *y, double *dy, const problem_t *p);
    void (*force)(const double *q, double *f, const problem_t *p);
};

/* Creates the problem of a scene (n: sections for F and C). NULL on an unknown scene. */
problem_t *problem_new(int scene, int n);
void problem_free(problem_t *p);

/* Recorded trajectory: len points (t, y), y stored row by row (dim values per point). */
typedef struct {
    size_t dim, len, cap;
    double *t;
    double *y;
} traj_t;

void traj_init(traj_t *tr, size_t dim);
int traj_push(traj_t *tr, double t, const double *y);
void traj_free(traj_t *tr);

/* Counters of one run. */
typedef struct {
    long steps;       /* accepted steps */
    long rejected;    /* rejected steps (error test or convergence failures) */
    long rhs_evals;
    long newton_iters;
} stats_t;

/* Return codes: 0 success, < 0 failure (message in peers_last_error()). */
const char *peers_last_error(void);

/* Adaptive Dormand-Prince 5(4) with the standard controller (Hairer-Norsett-Wanner II.4,
 * PI-free, safety 0.9, factors in [0.2, 10]); records every accepted step when `record`. */
int dopri5(const problem_t *p, double t0, double t1, const double *y0, double rtol, double atol,
           int record, traj_t *out, stats_t *st);

/* Fixed-step explicit symplectic integration of a separable problem: Stormer-Verlet (order 2,
 * kick-drift-kick) or its symmetric compositions: Yoshida's of order 4 and 6 (solution A),
 * Kahan and Li's s17odr8a of order 8. `order`: 2, 4, 6 or 8. `steps` steps of size (t1 - t0) / steps. */
int symplectic(const problem_t *p, double t0, double t1, const double *y0, long steps, int order,
               int record, traj_t *out, stats_t *st);

/* SUNDIALS methods. */
enum sundials_method {
    SUN_CVODE_ADAMS = 0,
    SUN_CVODE_BDF,
    SUN_ARKODE_ERK,
    SUN_ARKODE_DIRK,
    SUN_IDA
};

/* Runs a SUNDIALS method with scalar tolerances, the dense or band linear solver (by
 * p->half_band) and difference-quotient Jacobians; records every internal step (ONE_STEP mode
 * with the end time as stop time) when `record`, else only the final state. */
int sundials_run(const problem_t *p, int method, double t0, double t1, const double *y0,
                 double rtol, double atol, int record, traj_t *out, stats_t *st);

#endif
