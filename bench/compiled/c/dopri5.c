/* Adaptive Dormand-Prince 5(4) with FSAL and the elementary step-size controller
 * (Hairer, Norsett, Wanner, Solving ODEs I, II.4 and II.5). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "peers.h"

char peers_error_message[256];

const char *peers_last_error(void) { return peers_error_message; }

static const double C2 = 1.0 / 5, C3 = 3.0 / 10, C4 = 4.0 / 5, C5 = 8.0 / 9;
static const double A21 = 1.0 / 5;
static const double A31 = 3.0 / 40, A32 = 9.0 / 40;
static const double A41 = 44.0 / 45, A42 = -56.0 / 15, A43 = 32.0 / 9;
static const double A51 = 19372.0 / 6561, A52 = -25360.0 / 2187, A53 = 64448.0 / 6561,
                    A54 = -212.0 / 729;
static const double A61 = 9017.0 / 3168, A62 = -355.0 / 33, A63 = 46732.0 / 5247,
                    A64 = 49.0 / 176, A65 = -5103.0 / 18656;
static const double B1 = 35.0 / 384, B3 = 500.0 / 1113, B4 = 125.0 / 192, B5 = -2187.0 / 6784,
                    B6 = 11.0 / 84;
/* b - b_hat (the error estimate's weights). */
static const double E1 = 71.0 / 57600, E3 = -71.0 / 16695, E4 = 71.0 / 1920,
                    E5 = -17253.0 / 339200, E6 = 22.0 / 525, E7 = -1.0 / 40;

int dopri5(const problem_t *p, double t0, double t1, const double *y0, double rtol, double atol,
           int record, traj_t *out, stats_t *st) {
    int n = p->dim;
    double *w = malloc((size_t)n * 10 * sizeof(double));
    if (!w) return -1;
    double *y = w, *yn = w + n, *k1 = w + 2 * n, *k2 = w + 3 * n, *k3 = w + 4 * n,
           *k4 = w + 5 * n, *k5 = w + 6 * n, *k6 = w + 7 * n, *k7 = w + 8 * n, *tmp = w + 9 * n;
    memcpy(y, y0, (size_t)n * sizeof(double));
    double t = t0;
    memset(st, 0, sizeof *st);
    p->rhs(t, y, k1, p);
    st->rhs_evals = 1;
    /* Initial step: h = 0.01 |y|/|f| (scaled norms), at most the interval. */
    double dn = 0, fn = 0;
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fabs(y[i]);
        dn += (y[i] / sc) * (y[i] / sc);
        fn += (k1[i] / sc) * (k1[i] / sc);
    }
    double h = (dn < 1e-10 || fn < 1e-10) ? 1e-6 : 0.01 * sqrt(dn / fn);
    if (h > t1 - t0) h = t1 - t0;
    if (record && traj_push(out, t, y)) goto fail_mem;
    while (t < t1) {
        if (t + h > t1) h = t1 - t;
        for (int i = 0; i < n; i++) tmp[i] = y[i] + h * A21 * k1[i];
        p->rhs(t + C2 * h, tmp, k2, p);
        for (int i = 0; i < n; i++) tmp[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i]);
        p->rhs(t + C3 * h, tmp, k3, p);
        for (int i = 0; i < n; i++) tmp[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        p->rhs(t + C4 * h, tmp, k4, p);
        for (int i = 0; i < n; i++)
            tmp[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        p->rhs(t + C5 * h, tmp, k5, p);
        for (int i = 0; i < n; i++)
            tmp[i] = y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] + A65 * k5[i]);
        p->rhs(t + h, tmp, k6, p);
        for (int i = 0; i < n; i++)
            yn[i] = y[i] + h * (B1 * k1[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i]);
        p->rhs(t + h, yn, k7, p);
        st->rhs_evals += 6;
        double err = 0;
        for (int i = 0; i < n; i++) {
            double e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            double sc = atol + rtol * fmax(fabs(y[i]), fabs(yn[i]));
            err += (e / sc) * (e / sc);
        }
        err = sqrt(err / n);
        if (!isfinite(err)) {
            snprintf(peers_error_message, sizeof peers_error_message,
                     "dopri5: non-finite error estimate at t = %g, h = %g", t, h);
            free(w);
            return -2;
        }
        double fac = err > 0 ? 0.9 * pow(err, -0.2) : 10.0;
        fac = fmin(10.0, fmax(0.2, fac));
        if (err <= 1.0) {
            t += h;
            memcpy(y, yn, (size_t)n * sizeof(double));
            memcpy(k1, k7, (size_t)n * sizeof(double));
            st->steps++;
            if (record && traj_push(out, t, y)) goto fail_mem;
            h *= fac;
        } else {
            st->rejected++;
            h *= fmin(1.0, fac);
        }
        if (h < 1e-14 * fmax(1.0, fabs(t))) {
            snprintf(peers_error_message, sizeof peers_error_message,
                     "dopri5: step size %g too small at t = %g", h, t);
            free(w);
            return -3;
        }
    }
    if (!record && traj_push(out, t, y)) goto fail_mem;
    free(w);
    return 0;
fail_mem:
    snprintf(peers_error_message, sizeof peers_error_message,
             "dopri5: trajectory too long or out of memory at t = %g", t);
    free(w);
    return -1;
}
