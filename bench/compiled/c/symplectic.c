/* Explicit symplectic integrators for separable problems H = |p|^2/2 + V(q): Stormer-Verlet
 * (kick-drift-kick, the discrete flow of the trapezoid discrete Lagrangian) and its symmetric
 * compositions of order 4 (triple jump), 6 (Yoshida 1990, solution A) and 8 (Kahan & Li 1997,
 * s17odr8a, as in Hairer, Lubich & Wanner, GNI V.3.2). The force at the end
 * of a substep is reused at the start of the next, so a step costs one force evaluation per
 * stage, and the two half kicks between substeps are merged into one. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>

#include "peers.h"

extern char peers_error_message[256];

int symplectic(const problem_t *p, double t0, double t1, const double *y0, long steps, int order,
               int record, traj_t *out, stats_t *st) {
    if (!p->separable || steps <= 0) {
        snprintf(peers_error_message, sizeof peers_error_message,
                 "symplectic: scene is not separable or no steps");
        return -4;
    }
    double gam[17];
    int m;
    if (order == 2) {
        m = 1;
        gam[0] = 1.0;
    } else if (order == 4) {
        double c = cbrt(2.0), g1 = 1.0 / (2.0 - c);
        m = 3;
        gam[0] = g1;
        gam[1] = -c * g1;
        gam[2] = g1;
    } else if (order == 6) {
        const double w1 = -1.17767998417887, w2 = 0.235573213359357, w3 = 0.784513610477560;
        double w0 = 1.0 - 2.0 * (w1 + w2 + w3);
        m = 7;
        gam[0] = w3; gam[1] = w2; gam[2] = w1; gam[3] = w0; gam[4] = w1; gam[5] = w2; gam[6] = w3;
    } else if (order == 8) {
        const double w[8] = {0.13020248308889008087881763, 0.56116298177510838456196441,
                             -0.38947496264484728640807860, 0.15884190655515560089621075,
                             -0.39590389413323757733623154, 0.18453964097831570709183254,
                             0.25837438768632204729397911, 0.29501172360931029887096624};
        double sum = 0.0;
        m = 17;
        for (int i = 0; i < 8; i++) {
            gam[i] = w[i];
            gam[16 - i] = w[i];
            sum += w[i];
        }
        gam[8] = 1.0 - 2.0 * sum;
    } else {
        snprintf(peers_error_message, sizeof peers_error_message, "symplectic: order %d", order);
        return -4;
    }
    int n = p->nq;
    double *y = malloc((size_t)(2 * n + n) * sizeof(double));
    if (!y) return -1;
    double *q = y, *v = y + n, *f = y + 2 * n;
    memcpy(y, y0, (size_t)(2 * n) * sizeof(double));
    double h = (t1 - t0) / (double)steps;
    memset(st, 0, sizeof *st);
    if (record && traj_push(out, t0, y)) goto fail_mem;
    p->force(q, f, p);
    st->rhs_evals = 1;
    for (long k = 0; k < steps; k++) {
        /* Adjacent half kicks at the same point are merged: v += (h_s + h_{s+1})/2 f. */
        double kick = 0.5 * gam[0] * h;
        for (int s = 0; s < m; s++) {
            double hs = gam[s] * h;
            for (int i = 0; i < n; i++) {
                v[i] += kick * f[i];
                q[i] += hs * v[i];
            }
            p->force(q, f, p);
            kick = 0.5 * (hs + (s + 1 < m ? gam[s + 1] * h : 0.0));
        }
        for (int i = 0; i < n; i++) v[i] += kick * f[i];
        st->rhs_evals += m;
        st->steps++;
        if (record && traj_push(out, t0 + (double)(k + 1) * h, y)) goto fail_mem;
    }
    if (!record && traj_push(out, t1, y)) goto fail_mem;
    free(y);
    return 0;
fail_mem:
    snprintf(peers_error_message, sizeof peers_error_message, "symplectic: out of memory");
    free(y);
    return -1;
}
