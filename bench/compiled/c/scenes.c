/* The benchmark scenes' right-hand sides (bench/SCENES.md), written as a user of a compiled ODE
 * solver would write them. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "peers.h"

/* A: seed RLC loop, y = (q_C, i): q' = i, L i' = -R i - q/C. */
static void rhs_a(double t, const double *y, double *dy, const problem_t *p) {
    (void)t;
    const double L = 0.75, C = 3.0, R = 0.1;
    (void)p;
    dy[0] = y[1];
    dy[1] = (-R * y[1] - y[0] / C) / L;
}

/* B: damped oscillator m = k = 1, c = 0.01, y = (q, p). */
static void rhs_b(double t, const double *y, double *dy, const problem_t *p) {
    (void)t;
    (void)p;
    dy[0] = y[1];
    dy[1] = -y[0] - 0.01 * y[1];
}

/* D1: ten unit masses, springs k_0..k_10 (1 for even index, 1e6 for odd), walls at both ends. */
static void force_d1(const double *x, double *f, const problem_t *p) {
    const double *k = p->par;
    for (int i = 0; i < 10; i++) {
        double left = i > 0 ? x[i] - x[i - 1] : x[i];
        double right = i < 9 ? x[i + 1] - x[i] : -x[i];
        f[i] = -k[i] * left + k[i + 1] * right;
    }
}

static void rhs_separable(double t, const double *y, double *dy, const problem_t *p) {
    (void)t;
    int n = p->nq;
    memcpy(dy, y + n, (size_t)n * sizeof(double));
    p->force(y, dy + n, p);
}

/* D2: double pendulum, unit masses and lengths, g = 9.81; y = (th1, th2, w1, w2). */
static void rhs_d2(double t, const double *y, double *dy, const problem_t *p) {
    (void)t;
    (void)p;
    const double g = 9.81;
    double th1 = y[0], th2 = y[1], w1 = y[2], w2 = y[3];
    double d = th1 - th2, cd = cos(d), sd = sin(d);
    double m11 = 2.0, m12 = cd, m22 = 1.0;
    double f1 = -w2 * w2 * sd - 2.0 * g * sin(th1);
    double f2 = w1 * w1 * sd - g * sin(th2);
    double det = m11 * m22 - m12 * m12;
    dy[0] = w1;
    dy[1] = w2;
    dy[2] = (m22 * f1 - m12 * f2) / det;
    dy[3] = (m11 * f2 - m12 * f1) / det;
}

/* E: Henon-Heiles force -grad V. */
static void force_e(const double *q, double *f, const problem_t *p) {
    (void)p;
    f[0] = -q[0] * (1.0 + 2.0 * q[1]);
    f[1] = -q[1] - (q[0] * q[0] - q[1] * q[1]);
}

/* F: SciMLBenchmarks RC ladder, y = capacitor voltages v_1..v_n;
 * C_i v_i' = (v_{i-1} - v_i)/R_i - (v_i - v_{i+1})/R_{i+1}, v_0 = sin(2 pi 10 t). */
static void rhs_f(double t, const double *y, double *dy, const problem_t *p) {
    int n = p->n;
    const double *r = p->par, *c = p->par + n;
    double prev = sin(2.0 * M_PI * 10.0 * t);
    for (int i = 0; i < n; i++) {
        double in = (prev - y[i]) / r[i];
        double out = i + 1 < n ? (y[i] - y[i + 1]) / r[i + 1] : 0.0;
        dy[i] = (in - out) / c[i];
        prev = y[i];
    }
}

/* C: RLC ladder (R = 0.1, L = 1, C = 1 per section, 1 V DC), y = (i_1, v_1, ..., i_N, v_N):
 * L i_k' = v_{k-1} - v_k - R i_k (v_0 = 1), C v_k' = i_k - i_{k+1}. */
static void rhs_c(double t, const double *y, double *dy, const problem_t *p) {
    (void)t;
    int n = p->n;
    const double R = 0.1, L = 1.0, C = 1.0;
    double prev = 1.0;
    for (int k = 0; k < n; k++) {
        double i = y[2 * k], v = y[2 * k + 1];
        double inext = k + 1 < n ? y[2 * k + 2] : 0.0;
        dy[2 * k] = (prev - v - R * i) / L;
        dy[2 * k + 1] = (i - inext) / C;
        prev = v;
    }
}

problem_t *problem_new(int scene, int n) {
    problem_t *p = calloc(1, sizeof *p);
    if (!p) return NULL;
    p->scene = scene;
    p->half_band = -1;
    switch (scene) {
    case SCENE_A:
        p->dim = 2;
        p->rhs = rhs_a;
        break;
    case SCENE_B:
        p->dim = 2;
        p->rhs = rhs_b;
        break;
    case SCENE_D1:
        p->dim = 20;
        p->separable = 1;
        p->nq = 10;
        p->par = malloc(11 * sizeof(double));
        if (!p->par) break;
        for (int i = 0; i <= 10; i++) p->par[i] = i % 2 == 0 ? 1.0 : 1e6;
        p->force = force_d1;
        p->rhs = rhs_separable;
        break;
    case SCENE_D2:
        p->dim = 4;
        p->rhs = rhs_d2;
        break;
    case SCENE_E:
        p->dim = 4;
        p->separable = 1;
        p->nq = 2;
        p->force = force_e;
        p->rhs = rhs_separable;
        break;
    case SCENE_F:
        p->dim = n;
        p->n = n;
        p->half_band = 1;
        p->par = malloc(2 * (size_t)n * sizeof(double));
        if (!p->par) break;
        for (int i = 1; i <= n; i++) {
            p->par[i - 1] = 1.0 / i;
            p->par[n + i - 1] = 1.0 / ((double)i * i);
        }
        p->rhs = rhs_f;
        break;
    case SCENE_C:
        p->dim = 2 * n;
        p->n = n;
        p->half_band = 1;
        p->rhs = rhs_c;
        break;
    default:
        free(p);
        return NULL;
    }
    if (p->rhs == NULL || ((scene == SCENE_D1 || scene == SCENE_F) && p->par == NULL)) {
        free(p->par);
        free(p);
        return NULL;
    }
    return p;
}

void problem_free(problem_t *p) {
    if (!p) return;
    free(p->par);
    free(p);
}

void traj_init(traj_t *tr, size_t dim) {
    tr->dim = dim;
    tr->len = 0;
    tr->cap = 0;
    tr->t = NULL;
    tr->y = NULL;
}

/* At most this many recorded values (400 MB): a run that needs more has lost its way (a solver
 * crawling at a tiny step after the solution left its bounded region). */
#define TRAJ_MAX_VALUES 50000000UL

int traj_push(traj_t *tr, double t, const double *y) {
    if ((tr->len + 1) * tr->dim > TRAJ_MAX_VALUES) return -1;
    if (tr->len == tr->cap) {
        size_t cap = tr->cap ? 2 * tr->cap : 1024;
        double *nt = realloc(tr->t, cap * sizeof(double));
        if (!nt) return -1;
        tr->t = nt;
        double *ny = realloc(tr->y, cap * tr->dim * sizeof(double));
        if (!ny) return -1;
        tr->y = ny;
        tr->cap = cap;
    }
    tr->t[tr->len] = t;
    memcpy(tr->y + tr->len * tr->dim, y, tr->dim * sizeof(double));
    tr->len++;
    return 0;
}

void traj_free(traj_t *tr) {
    free(tr->t);
    free(tr->y);
    tr->t = tr->y = NULL;
    tr->len = tr->cap = 0;
}
