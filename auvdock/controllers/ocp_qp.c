/* One real-time-iteration step of auvdock's docking MPC in one call: the QP's data from the
 * CasADi-generated function AUVDOCK_QP_BLOCKS (compiled into the same library) and the QP solved by
 * HPIPM's OCP-QP interface, whose memory (dimensions, QP, solution, arguments, workspace) is created
 * once, by auvdock_ocp_create, and reused by every step.
 *
 * The QP is the one CasADi's hpipm conic plugin builds from the same data, operation for operation
 * (auvdock/controllers/ocp_qp.py says why and how it is checked): every variable boxed, infinite
 * bounds replaced by +-inf_value, the Hessian and gradient halved, the gap rows' right-hand side
 * -(0 - g), a zero first guess.  So the plugin (the reference) and this step give the same bits.
 *
 * Layout (stage order, as auvdock.controllers.mpc.DockingMPC lays the problem out):
 *   w = [x_0, u_0, x_1, u_1, ..., x_N],   g = [F_0(x_0, u_0) - x_1, ..., F_(N-1)(.) - x_N]
 * AUVDOCK_QP_BLOCKS(w, p) -> (blocks, f): blocks = every A_k (k < N, column-major, dense), every B_k,
 * every b_k, then every Q_k (k <= N), every S_k, R_k, q_k, r_k (the Hessian's and gradient's stage
 * blocks); f the cost.
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "hpipm_d_ocp_qp.h"
#include "hpipm_d_ocp_qp_dim.h"
#include "hpipm_d_ocp_qp_ipm.h"
#include "hpipm_d_ocp_qp_sol.h"

#ifndef AUVDOCK_QP_BLOCKS
#error "AUVDOCK_QP_BLOCKS must name the generated QP-data function"
#endif
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)

typedef long long int cint; /* casadi_int of the generated code */
extern int AUVDOCK_QP_BLOCKS(const double **arg, double **res, cint *iw, double *w, int mem);
extern int CAT(AUVDOCK_QP_BLOCKS, _work)(cint *sz_arg, cint *sz_res, cint *sz_iw, cint *sz_w);

typedef struct {
    int N, nw;
    int *nx, *nu, *nbx, *nbu, *ng, *ns;
    double inf;
    /* HPIPM */
    struct d_ocp_qp_dim dim;
    struct d_ocp_qp qp;
    struct d_ocp_qp_sol sol;
    struct d_ocp_qp_ipm_arg arg;
    struct d_ocp_qp_ipm_ws ws;
    void *mem_dim, *mem_qp, *mem_sol, *mem_arg, *mem_ws;
    /* stage pointers into the blocks and bound buffers */
    double **hA, **hB, **hb, **hQ, **hS, **hR, **hq, **hr;
    double **hlbx, **hubx, **hlbu, **hubu, **hx, **hu;
    int **hidxbx, **hidxbu;
    double *blocks, *lbx, *ubx, *lbu, *ubu, *xs, *us, *zero;
    int *idx;
    void **nulls; /* N + 1 null pointers: the absent constraint and slack blocks */
    /* the generated function's work */
    const double **fn_arg;
    double **fn_res;
    cint *fn_iw;
    double *fn_w;
    double f;
} auvdock_ocp;

static void *zalloc(size_t n) { return calloc(n > 0 ? n : 1, 1); }

void auvdock_ocp_free(auvdock_ocp *o) {
    if (!o) return;
    void *ptrs[] = {o->nx, o->nu, o->nbx, o->nbu, o->ng, o->ns, o->mem_dim, o->mem_qp, o->mem_sol,
                    o->mem_arg, o->mem_ws, o->hA, o->hB, o->hb, o->hQ, o->hS, o->hR, o->hq, o->hr,
                    o->hlbx, o->hubx, o->hlbu, o->hubu, o->hx, o->hu, o->hidxbx, o->hidxbu, o->blocks,
                    o->lbx, o->ubx, o->lbu, o->ubu, o->xs, o->us, o->zero, o->idx, o->fn_arg,
                    o->fn_res, o->fn_iw, o->fn_w, o->nulls};
    for (size_t i = 0; i < sizeof(ptrs) / sizeof(ptrs[0]); ++i) free(ptrs[i]);
    free(o);
}

/* The solver of a problem of N stages with nx[k] states (N + 1) and nu[k] inputs (N + 1, nu[N] = 0);
 * HPIPM's mode (0 speed_abs, 1 speed, 2 balance, 3 robust), iteration limit and warm start.  NULL when
 * memory runs out. */
auvdock_ocp *auvdock_ocp_create(int N, const int *nx, const int *nu, double inf_value, int mode,
                                int iter_max, int warm_start) {
    auvdock_ocp *o = zalloc(sizeof(auvdock_ocp));
    if (!o) return NULL;
    int S = N + 1, k, nxt = 0, nut = 0, nblk = 0;
    o->N = N;
    o->inf = inf_value;
    o->nx = zalloc(S * sizeof(int));
    o->nu = zalloc(S * sizeof(int));
    o->nbx = zalloc(S * sizeof(int));
    o->nbu = zalloc(S * sizeof(int));
    o->ng = zalloc(S * sizeof(int));
    o->ns = zalloc(S * sizeof(int));
    if (!o->nx || !o->nu || !o->nbx || !o->nbu || !o->ng || !o->ns) goto fail;
    for (k = 0; k < S; ++k) {
        o->nx[k] = o->nbx[k] = nx[k];
        o->nu[k] = o->nbu[k] = nu[k];
        nxt += nx[k];
        nut += nu[k];
        if (k < N) nblk += nx[k + 1] * (nx[k] + nu[k] + 1);
        nblk += nx[k] * nx[k] + nu[k] * nx[k] + nu[k] * nu[k] + nx[k] + nu[k];
    }
    o->nw = nxt + nut;
#define ARR(name, type, n) if (!(o->name = zalloc((size_t)(n) * sizeof(type)))) goto fail
    ARR(hA, double *, S); ARR(hB, double *, S); ARR(hb, double *, S); ARR(hQ, double *, S);
    ARR(hS, double *, S); ARR(hR, double *, S); ARR(hq, double *, S); ARR(hr, double *, S);
    ARR(hlbx, double *, S); ARR(hubx, double *, S); ARR(hlbu, double *, S); ARR(hubu, double *, S);
    ARR(hx, double *, S); ARR(hu, double *, S); ARR(hidxbx, int *, S); ARR(hidxbu, int *, S);
    ARR(blocks, double, nblk); ARR(lbx, double, nxt); ARR(ubx, double, nxt); ARR(lbu, double, nut);
    ARR(ubu, double, nut); ARR(xs, double, nxt); ARR(us, double, nut); ARR(zero, double, nxt + nut);
    ARR(idx, int, nxt + nut);
    ARR(nulls, void *, S);
    {
        double *b = o->blocks;
        for (k = 0; k < N; ++k) { o->hA[k] = b; b += nx[k + 1] * nx[k]; }
        for (k = 0; k < N; ++k) { o->hB[k] = b; b += nx[k + 1] * nu[k]; }
        for (k = 0; k < N; ++k) { o->hb[k] = b; b += nx[k + 1]; }
        for (k = 0; k < S; ++k) { o->hQ[k] = b; b += nx[k] * nx[k]; }
        for (k = 0; k < S; ++k) { o->hS[k] = b; b += nu[k] * nx[k]; }
        for (k = 0; k < S; ++k) { o->hR[k] = b; b += nu[k] * nu[k]; }
        for (k = 0; k < S; ++k) { o->hq[k] = b; b += nx[k]; }
        for (k = 0; k < S; ++k) { o->hr[k] = b; b += nu[k]; }
        int ox = 0, ou = 0, oi = 0, i;
        for (k = 0; k < S; ++k) {
            o->hlbx[k] = o->lbx + ox; o->hubx[k] = o->ubx + ox; o->hx[k] = o->xs + ox;
            o->hlbu[k] = o->lbu + ou; o->hubu[k] = o->ubu + ou; o->hu[k] = o->us + ou;
            o->hidxbx[k] = o->idx + oi;
            for (i = 0; i < nx[k]; ++i) o->hidxbx[k][i] = i;
            oi += nx[k];
            o->hidxbu[k] = o->idx + oi;
            for (i = 0; i < nu[k]; ++i) o->hidxbu[k][i] = i;
            oi += nu[k];
            ox += nx[k];
            ou += nu[k];
        }
    }
    /* HPIPM's memory, once */
    if (!(o->mem_dim = zalloc(d_ocp_qp_dim_memsize(N)))) goto fail;
    d_ocp_qp_dim_create(N, &o->dim, o->mem_dim);
    d_ocp_qp_dim_set_all(o->nx, o->nu, o->nbx, o->nbu, o->ng, o->ns, &o->dim);
    if (!(o->mem_qp = zalloc(d_ocp_qp_memsize(&o->dim)))) goto fail;
    d_ocp_qp_create(&o->dim, &o->qp, o->mem_qp);
    if (!(o->mem_sol = zalloc(d_ocp_qp_sol_memsize(&o->dim)))) goto fail;
    d_ocp_qp_sol_create(&o->dim, &o->sol, o->mem_sol);
    if (!(o->mem_arg = zalloc(d_ocp_qp_ipm_arg_memsize(&o->dim)))) goto fail;
    d_ocp_qp_ipm_arg_create(&o->dim, &o->arg, o->mem_arg);
    d_ocp_qp_ipm_arg_set_default((enum hpipm_mode)mode, &o->arg);
    o->arg.iter_max = iter_max;
    o->arg.warm_start = warm_start;
    if (!(o->mem_ws = zalloc(d_ocp_qp_ipm_ws_memsize(&o->dim, &o->arg)))) goto fail;
    d_ocp_qp_ipm_ws_create(&o->dim, &o->arg, &o->ws, o->mem_ws);
    /* the generated function's work vectors */
    {
        cint sa = 0, sr = 0, si = 0, sw = 0;
        CAT(AUVDOCK_QP_BLOCKS, _work)(&sa, &sr, &si, &sw);
        ARR(fn_arg, double *, sa < 2 ? 2 : sa);
        ARR(fn_res, double *, sr < 2 ? 2 : sr);
        ARR(fn_iw, cint, si);
        ARR(fn_w, double, sw);
    }
#undef ARR
    return o;
fail:
    auvdock_ocp_free(o);
    return NULL;
}

int auvdock_ocp_nw(const auvdock_ocp *o) { return o->nw; }

/* One step from w_bar (nw) with parameters p: the QP's data, then HPIPM.  w_out (nw) = w_bar + dw;
 * info (8) = [HPIPM's status (0 solved), iterations, the model cost f(w_bar) + q(dw), max |dw|,
 * f(w_bar), the data function's flag, the data's and the QP's time (s, monotonic clock)].  Returns HPIPM's status, or -1 when the data function failed. */
int auvdock_ocp_step(auvdock_ocp *o, const double *wbar, const double *p, const double *lbw,
                     const double *ubw, double *w_out, double *info) {
    int N = o->N, S = N + 1, k, i, j, ow = 0, status = 0, iters = 0;
    const double inf = o->inf;
    struct timespec t0, t1, t2;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    o->fn_arg[0] = wbar;
    o->fn_arg[1] = p;
    o->fn_res[0] = o->blocks;
    o->fn_res[1] = &o->f;
    int flag = AUVDOCK_QP_BLOCKS(o->fn_arg, o->fn_res, o->fn_iw, o->fn_w, 0);
    info[5] = flag;
    if (flag) {
        info[0] = -1;
        return -1;
    }
    /* as the plugin: H and gradient halved; b = -(lbg - g) with lbg = 0; the bounds relative to
     * w_bar, infinities clipped */
    for (k = 0; k < S; ++k) {
        int nxk = o->nx[k], nuk = o->nu[k];
        for (i = 0; i < nxk * nxk; ++i) o->hQ[k][i] *= 0.5;
        for (i = 0; i < nuk * nxk; ++i) o->hS[k][i] *= 0.5;
        for (i = 0; i < nuk * nuk; ++i) o->hR[k][i] *= 0.5;
        for (i = 0; i < nxk; ++i) o->hq[k][i] *= 0.5;
        for (i = 0; i < nuk; ++i) o->hr[k][i] *= 0.5;
        if (k < N)
            for (i = 0; i < o->nx[k + 1]; ++i) o->hb[k][i] = -1.0 * (0.0 - o->hb[k][i]);
        for (i = 0; i < nxk; ++i, ++ow) {
            double lo = lbw[ow] - wbar[ow], hi = ubw[ow] - wbar[ow];
            o->hlbx[k][i] = lo < -inf ? -inf : lo;
            o->hubx[k][i] = hi > inf ? inf : hi;
        }
        for (i = 0; i < nuk; ++i, ++ow) {
            double lo = lbw[ow] - wbar[ow], hi = ubw[ow] - wbar[ow];
            o->hlbu[k][i] = lo < -inf ? -inf : lo;
            o->hubu[k][i] = hi > inf ? inf : hi;
        }
    }
    double **nd = (double **)o->nulls;
    d_ocp_qp_set_all(o->hA, o->hB, o->hb, o->hQ, o->hS, o->hR, o->hq, o->hr, o->hidxbx, o->hlbx,
                     o->hubx, o->hidxbu, o->hlbu, o->hubu, nd, nd, nd, nd, nd, nd, nd, nd,
                     (int **)o->nulls, NULL, nd, nd, &o->qp);
    for (k = 0; k < S; ++k) {
        d_ocp_qp_sol_set_u(k, o->zero, &o->sol);
        d_ocp_qp_sol_set_x(k, o->zero, &o->sol);
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    d_ocp_qp_ipm_solve(&o->qp, &o->sol, &o->arg, &o->ws);
    d_ocp_qp_ipm_get_status(&o->ws, &status);
    d_ocp_qp_ipm_get_iter(&o->ws, &iters);
    /* dw, the model cost (with the Hessian and gradient as given: twice the halved) and max |dw| */
    double cost = 0.0, step = 0.0;
    ow = 0;
    for (k = 0; k < S; ++k) {
        int nxk = o->nx[k], nuk = o->nu[k];
        double *x = o->hx[k], *u = o->hu[k];
        d_ocp_qp_sol_get_x(k, &o->sol, x);
        d_ocp_qp_sol_get_u(k, &o->sol, u);
        for (i = 0; i < nxk; ++i) {
            double qx = 0.0;
            for (j = 0; j < nxk; ++j) qx += o->hQ[k][i + j * nxk] * x[j];
            for (j = 0; j < nuk; ++j) qx += o->hS[k][j + i * nuk] * u[j];
            cost += x[i] * (qx + 2.0 * o->hq[k][i]);
        }
        for (i = 0; i < nuk; ++i) {
            double ru = 0.0;
            for (j = 0; j < nuk; ++j) ru += o->hR[k][i + j * nuk] * u[j];
            for (j = 0; j < nxk; ++j) ru += o->hS[k][i + j * nuk] * x[j];
            cost += u[i] * (ru + 2.0 * o->hr[k][i]);
        }
        for (i = 0; i < nxk; ++i, ++ow) {
            w_out[ow] = wbar[ow] + x[i];
            if (fabs(x[i]) > step) step = fabs(x[i]);
        }
        for (i = 0; i < nuk; ++i, ++ow) {
            w_out[ow] = wbar[ow] + u[i];
            if (fabs(u[i]) > step) step = fabs(u[i]);
        }
    }
    clock_gettime(CLOCK_MONOTONIC, &t2);
    info[0] = status;
    info[1] = iters;
    info[6] = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    info[7] = (double)(t2.tv_sec - t1.tv_sec) + 1e-9 * (double)(t2.tv_nsec - t1.tv_nsec);
    info[2] = o->f + cost;
    info[3] = step;
    info[4] = o->f;
    return status;
}
