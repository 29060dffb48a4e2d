/* The loops and the smoother around a traced system (costa.compiled.kernel).

   The generated part above defines NX (states), NU (inputs), NP (parameter numbers), NA (states the
   smoother adds), NC (channels) and ARGS (the arguments x[..], u[..], p[..] of the system's
   functions); the system's functions go between the two parts: step, sensors and their duals
   step_d, sensors_d (the results and their tangents along the D = NX + NA directions, from
   pointers to the arguments' tangents).  Arrays are row-major. */

#include <pthread.h>

#define D (NX + NA)
#define L (NX + NA)
#define FOR(j) for (int j = 0; j < D; j++)

static const double ZERO[D];

/* One call of an exported function: its sizes and arrays; its rows are shared among threads. */
typedef struct {
    long R, S;
    const double *X, *U, *P, *DX, *DP, *Y, *MIX, *MEAN0, *COV0, *Q, *RV;
    double *OUT, *END, *DOUT, *DEND, *MEAN, *STD, *INNOVATION, *LL, *FINAL;
    int backward, status, record;
} call_t;
enum { RECORD_NONE, RECORD_CHANNELS, RECORD_STATES };
typedef void (*rows_t)(call_t *, long, long);
typedef struct {
    call_t *call;
    rows_t work;
    long begin, end;
} chunk_t;

static int THREADS = 1;

/* How many threads share a call's rows (each row is computed alone: the results do not depend on it). */
void set_threads(const int n) { THREADS = n < 1 ? 1 : (n > 64 ? 64 : n); }

static void *run_chunk(void *chunk)
{
    chunk_t *c = chunk;
    c->work(c->call, c->begin, c->end);
    return NULL;
}

static void parallel(call_t *call, rows_t work)
{
    const long t = THREADS < call->R ? THREADS : 1;
    pthread_t threads[64];
    chunk_t chunks[64];
    int started[64];
    for (long i = 0; i < t; i++) chunks[i] = (chunk_t){call, work, call->R * i / t, call->R * (i + 1) / t};
    for (long i = 1; i < t; i++) started[i] = pthread_create(&threads[i], NULL, run_chunk, &chunks[i]) == 0;
    run_chunk(&chunks[0]);
    for (long i = 1; i < t; i++) {
        if (started[i])
            pthread_join(threads[i], NULL);
        else
            run_chunk(&chunks[i]);
    }
}

/* --- the system's functions --- */

static void march_rows(call_t *c, const long begin, const long end)
{
    const long S = c->S;
    for (long r = begin; r < end; r++) {
        double x[NX], next[NX];
        const double *p = c->P + r * NP;
        for (int i = 0; i < NX; i++) x[i] = c->X[r * NX + i];
        for (long s = 0; s < S; s++) {
            const double *u = c->U + (r * S + s) * NU;
            if (c->record == RECORD_CHANNELS) sensors(ARGS, c->OUT + (r * S + s) * NC);
            if (c->record == RECORD_STATES)
                for (int i = 0; i < NX; i++) c->OUT[(r * S + s) * NX + i] = x[i];
            step(ARGS, next);
            for (int i = 0; i < NX; i++) x[i] = next[i];
        }
        for (int i = 0; i < NX; i++) c->END[r * NX + i] = x[i];
    }
}

static void step_rows_rows(call_t *c, const long begin, const long end)
{
    for (long r = begin; r < end; r++) {
        const double *x = c->X + r * NX, *u = c->U + r * NU, *p = c->P + r * NP;
        step(ARGS, c->OUT + r * NX);
    }
}

static void sense_rows_rows(call_t *c, const long begin, const long end)
{
    for (long r = begin; r < end; r++) {
        const double *x = c->X + r * NX, *u = c->U + r * NU, *p = c->P + r * NP;
        sensors(ARGS, c->OUT + r * NC);
    }
}

/* From X (R, NX) over U (R, S, NU) with the parameters P (R, NP): the channels OUT (R, S, NC) (record
   RECORD_CHANNELS) or the states (R, S, NX) (RECORD_STATES) at each step before it, or nothing (RECORD_NONE);
   the states END (R, NX) after the last.  step_rows, sense_rows: one step (OUT (R, NX)), the channels
   (OUT (R, NC)) at X, U (R, NU). */
void march(const long R, const long S, const double *X, const double *U, const double *P, double *OUT, double *END,
           const int record)
{
    call_t c = {.R = R, .S = S, .X = X, .U = U, .P = P, .OUT = OUT, .END = END, .record = record};
    parallel(&c, march_rows);
}

void step_rows(const long R, const double *X, const double *U, const double *P, double *OUT)
{
    call_t c = {.R = R, .X = X, .U = U, .P = P, .OUT = OUT};
    parallel(&c, step_rows_rows);
}

void sense_rows(const long R, const double *X, const double *U, const double *P, double *OUT)
{
    call_t c = {.R = R, .X = X, .U = U, .P = P, .OUT = OUT};
    parallel(&c, sense_rows_rows);
}

/* --- derivatives --- */

static void march_channels_d_rows(call_t *c, const long begin, const long end)
{
    const long S = c->S;
    for (long r = begin; r < end; r++) {
        double x[NX], dx[NX * D], next[NX], dnext[NX * D];
        const double *p = c->P + r * NP, *din[NX + NU + NP];
        for (int i = 0; i < NX; i++) din[i] = dx + i * D;
        for (int i = 0; i < NU; i++) din[NX + i] = ZERO;
        for (int i = 0; i < NP; i++) din[NX + NU + i] = c->DP + (r * NP + i) * D;
        for (int i = 0; i < NX; i++) x[i] = c->X[r * NX + i];
        for (int i = 0; i < NX * D; i++) dx[i] = c->DX[r * NX * D + i];
        for (long s = 0; s < S; s++) {
            const double *u = c->U + (r * S + s) * NU;
            sensors_d(ARGS, din, c->OUT + (r * S + s) * NC, c->DOUT + (r * S + s) * NC * D);
            step_d(ARGS, din, next, dnext);
            for (int i = 0; i < NX; i++) x[i] = next[i];
            for (int i = 0; i < NX * D; i++) dx[i] = dnext[i];
        }
        for (int i = 0; i < NX; i++) c->END[r * NX + i] = x[i];
        for (int i = 0; i < NX * D; i++) c->DEND[r * NX * D + i] = dx[i];
    }
}

/* march_channels with tangents: DX (R, NX, D) of the start, DP (R, NP, D) of the parameters; DOUT
   (R, S, NC, D) and DEND (R, NX, D) */
void march_channels_d(const long R, const long S, const double *X, const double *U, const double *P, double *OUT,
                      double *END, const double *DX, const double *DP, double *DOUT, double *DEND)
{
    call_t c = {.R = R, .S = S, .X = X, .U = U, .P = P, .OUT = OUT, .END = END, .DX = DX, .DP = DP, .DOUT = DOUT,
                .DEND = DEND};
    parallel(&c, march_channels_d_rows);
}

/* ---------------------------------------------------------------- small dense linear algebra */

/* LU with partial pivoting of the n x n matrix a, in place; 1 where a pivot is exactly zero (singular) */
static int lu_factor(const int n, double *a, int *pivot)
{
    for (int k = 0; k < n; k++) {
        int best = k;
        for (int i = k + 1; i < n; i++)
            if (fabs(a[i * n + k]) > fabs(a[best * n + k])) best = i;
        pivot[k] = best;
        if (a[best * n + k] == 0.0) return 1;
        if (best != k)
            for (int j = 0; j < n; j++) {
                const double t = a[k * n + j];
                a[k * n + j] = a[best * n + j];
                a[best * n + j] = t;
            }
        for (int i = k + 1; i < n; i++) {
            const double f = a[i * n + k] /= a[k * n + k];
            for (int j = k + 1; j < n; j++) a[i * n + j] -= f * a[k * n + j];
        }
    }
    return 0;
}

/* 1 where the symmetric a (n x n) is not positive definite (or not finite): its Cholesky factor fails */
static int not_positive_definite(const int n, const double *a)
{
    double l[n * n > 0 ? n * n : 1];
    for (int j = 0; j < n; j++) {
        double diagonal = a[j * n + j];
        for (int k = 0; k < j; k++) diagonal -= l[j * n + k] * l[j * n + k];
        if (!(diagonal > 0.0) || !isfinite(diagonal)) return 1;
        l[j * n + j] = sqrt(diagonal);
        for (int i = j + 1; i < n; i++) {
            double sum = a[i * n + j];
            for (int k = 0; k < j; k++) sum -= l[i * n + k] * l[j * n + k];
            l[i * n + j] = sum / l[j * n + j];
        }
    }
    return 0;
}

/* b (n x m) <- a^-1 b, a factored by lu_factor */
static void lu_solve(const int n, const double *a, const int *pivot, double *b, const int m)
{
    for (int k = 0; k < n; k++)
        if (pivot[k] != k)
            for (int j = 0; j < m; j++) {
                const double t = b[k * m + j];
                b[k * m + j] = b[pivot[k] * m + j];
                b[pivot[k] * m + j] = t;
            }
    for (int i = 0; i < n; i++)
        for (int k = 0; k < i; k++)
            for (int j = 0; j < m; j++) b[i * m + j] -= a[i * n + k] * b[k * m + j];
    for (int i = n - 1; i >= 0; i--) {
        for (int k = i + 1; k < n; k++)
            for (int j = 0; j < m; j++) b[i * m + j] -= a[i * n + k] * b[k * m + j];
        for (int j = 0; j < m; j++) b[i * m + j] /= a[i * n + i];
    }
}

/* c (n x m) = a (n x k) b (k x m) */
static void product(const int n, const int k, const int m, const double *a, const double *b, double *c)
{
    for (int i = 0; i < n; i++)
        for (int j = 0; j < m; j++) {
            double sum = 0.0;
            for (int l = 0; l < k; l++) sum += a[i * k + l] * b[l * m + j];
            c[i * m + j] = sum;
        }
}

/* c (n x m) = a (n x k) b' (b: m x k) */
static void product_t(const int n, const int k, const int m, const double *a, const double *b, double *c)
{
    for (int i = 0; i < n; i++)
        for (int j = 0; j < m; j++) {
            double sum = 0.0;
            for (int l = 0; l < k; l++) sum += a[i * k + l] * b[j * k + l];
            c[i * m + j] = sum;
        }
}

static void symmetrised(const int n, double *a)
{
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++) a[i * n + j] = a[j * n + i] = 0.5 * (a[i * n + j] + a[j * n + i]);
}

static void fill_nan(const int n, double *a)
{
    for (int i = 0; i < n; i++) a[i] = NAN;
}

/* ---------------------------------------------------------------- the smoother */

/* One measurement update of mean (L) and cov (L x L) at the channels y (NaN: not sampled); writes the
   standardised innovations and returns the log density of the sampled values. */
static double update(const double *x, const double *u, const double *p, const double *const *din, const double *y,
                     const double *rv, double *mean, double *cov, double *innovation)
{
    double h[NC > 0 ? NC : 1], dh[NC * D > 0 ? NC * D : 1], residual[NC > 0 ? NC : 1];
    double hp[NC * L > 0 ? NC * L : 1], s[NC * NC > 0 ? NC * NC : 1], lu[NC * NC > 0 ? NC * NC : 1];
    double x_s[NC * L > 0 ? NC * L : 1], q[NC > 0 ? NC : 1];
    int measured[NC > 0 ? NC : 1], pivot[NC > 0 ? NC : 1], count = 0;
    sensors_d(ARGS, din, h, dh);
    for (int c = 0; c < NC; c++) {
        measured[c] = isfinite(y[c]);
        count += measured[c];
        residual[c] = measured[c] ? y[c] - h[c] : 0.0;
        if (!measured[c])
            for (int l = 0; l < L; l++) dh[c * D + l] = 0.0;
    }
    /* S = H P H' + diag(r), symmetrised */
    product(NC, L, L, dh, cov, hp);
    product_t(NC, L, NC, hp, dh, s);
    for (int c = 0; c < NC; c++) s[c * NC + c] += rv[c];
    symmetrised(NC, s);
    for (int c = 0; c < NC; c++) innovation[c] = measured[c] ? residual[c] / sqrt(s[c * NC + c]) : NAN;
    for (int i = 0; i < NC * NC; i++) lu[i] = s[i];
    if (NC > 0 && (not_positive_definite(NC, s) || lu_factor(NC, lu, pivot))) {
        /* S not a covariance (the filter's P lost, or singular): this row is lost from here */
        fill_nan(L, mean);
        fill_nan(L * L, cov);
        return NAN;
    }
    /* the gain K = P H' S^-1 = (S^-1 H P)' */
    for (int i = 0; i < NC * L; i++) x_s[i] = hp[i];
    lu_solve(NC, lu, pivot, x_s, L);
    for (int l = 0; l < L; l++)
        for (int c = 0; c < NC; c++) mean[l] += x_s[c * L + l] * residual[c];
    /* Joseph form: (I - K H) P (I - K H)' + K R K' */
    double joseph[L * L], jp[L * L], updated[L * L];
    for (int i = 0; i < L; i++)
        for (int j = 0; j < L; j++) {
            double kh = 0.0;
            for (int c = 0; c < NC; c++) kh += x_s[c * L + i] * dh[c * D + j];
            joseph[i * L + j] = (i == j) - kh;
        }
    product(L, L, L, joseph, cov, jp);
    product_t(L, L, L, jp, joseph, updated);
    for (int i = 0; i < L; i++)
        for (int j = 0; j < L; j++) {
            double krk = 0.0;
            for (int c = 0; c < NC; c++) krk += x_s[c * L + i] * rv[c] * x_s[c * L + j];
            cov[i * L + j] = updated[i * L + j] + krk;
        }
    symmetrised(L, cov);
    /* log N(residual; 0, S) over the sampled channels: an unsampled one has S_cc = r_c, residual 0 */
    double log_det = 0.0, quadratic = 0.0;
    for (int c = 0; c < NC; c++) {
        log_det += log(fabs(lu[c * NC + c]));
        if (!measured[c]) log_det -= log(rv[c]);
        q[c] = residual[c];
    }
    lu_solve(NC, lu, pivot, q, 1);
    for (int c = 0; c < NC; c++) quadratic += residual[c] * q[c];
    return -0.5 * (quadratic + log_det + count * log(6.283185307179586));
}

static void smooth_rows(call_t *c, const long begin, const long end)
{
    const long K = c->S;
    const int backward = c->backward;
    const double *Y = c->Y, *U = c->U, *MIX = c->MIX, *MEAN0 = c->MEAN0, *COV0 = c->COV0, *Q = c->Q, *RV = c->RV;
    double *MEAN = c->MEAN, *STD = c->STD, *INNOVATION = c->INNOVATION, *LL = c->LL, *FINAL = c->FINAL;
    double *history = NULL, *means = NULL, *covs = NULL, *transitions = NULL, *predicted = NULL;
    if (backward) {
        history = malloc(sizeof(double) * (size_t)K * (2 * L + 2 * L * L));
        if (history == NULL) {
            c->status = 1;
            return;
        }
        means = history;
        covs = means + K * L;
        transitions = covs + K * L * L;
        predicted = transitions + K * L * L;
    }
    double seeds[NX * D], dparameters[NP * D > 0 ? NP * D : 1];
    for (int i = 0; i < NX * D; i++) seeds[i] = 0.0;
    for (int i = 0; i < NX; i++) seeds[i * D + i] = 1.0;
    for (long r = begin; r < end; r++) {
        double mean[L], cov[L * L], x[NX], p[NP > 0 ? NP : 1], next[NX], dnext[NX * D], a[L * L], ap[L * L];
        const double *mix = MIX + r * NP * NA, *q = Q + r * L, *din[NX + NU + NP];
        for (int i = 0; i < NX; i++) din[i] = seeds + i * D;
        for (int i = 0; i < NU; i++) din[NX + i] = ZERO;
        for (int k = 0; k < NP; k++) {
            for (int j = 0; j < D; j++) dparameters[k * D + j] = j >= NX ? mix[k * NA + j - NX] : 0.0;
            din[NX + NU + k] = dparameters + k * D;
        }
        for (int i = 0; i < L; i++) mean[i] = MEAN0[r * L + i];
        for (int i = 0; i < L * L; i++) cov[i] = COV0[r * L * L + i];
        double log_likelihood = 0.0;
        for (long k = 0; k < K; k++) {
            const double *u = U + (r * K + k) * NU;
            for (int i = 0; i < NX; i++) x[i] = mean[i];
            for (int i = 0; i < NP; i++) {
                p[i] = 0.0;
                for (int j = 0; j < NA; j++) p[i] += mix[i * NA + j] * mean[NX + j];
            }
            log_likelihood += update(x, u, p, din, Y + (r * K + k) * NC, RV, mean, cov, INNOVATION + (r * K + k) * NC);
            if (backward) {
                for (int i = 0; i < L; i++) means[k * L + i] = mean[i];
                for (int i = 0; i < L * L; i++) covs[k * L * L + i] = cov[i];
            }
            if (k + 1 == K) break;
            /* predict: z = (step(x), a), P = A P A' + Q */
            for (int i = 0; i < NX; i++) x[i] = mean[i];
            for (int i = 0; i < NP; i++) {
                p[i] = 0.0;
                for (int j = 0; j < NA; j++) p[i] += mix[i * NA + j] * mean[NX + j];
            }
            step_d(ARGS, din, next, dnext);
            for (int i = 0; i < L; i++)
                for (int j = 0; j < L; j++) a[i * L + j] = i < NX ? dnext[i * D + j] : (double)(i == j);
            for (int i = 0; i < NX; i++) mean[i] = next[i];
            product(L, L, L, a, cov, ap);
            product_t(L, L, L, ap, a, cov);
            for (int i = 0; i < L; i++) cov[i * L + i] += q[i];
            if (backward) {
                for (int i = 0; i < L * L; i++) transitions[k * L * L + i] = a[i];
                for (int i = 0; i < L; i++) predicted[k * L + i] = mean[i];
            }
        }
        LL[r] = log_likelihood;
        if (!backward) {
            for (int i = 0; i < L; i++) {
                MEAN[r * L + i] = mean[i];
                STD[r * L + i] = sqrt(cov[i * L + i] < 0.0 ? 0.0 : cov[i * L + i]);
            }
            for (int i = 0; i < L * L; i++) FINAL[r * L * L + i] = cov[i];
            continue;
        }
        /* Rauch-Tung-Striebel, backward from the last filtered state */
        double smoothed[L], smoothed_cov[L * L], pc[L * L], lu[L * L], gain[L * L], gap[L], dc[L * L], gd[L * L];
        int pivot[L];
        for (int i = 0; i < L; i++) smoothed[i] = means[(K - 1) * L + i];
        for (int i = 0; i < L * L; i++) smoothed_cov[i] = FINAL[r * L * L + i] = covs[(K - 1) * L * L + i];
        for (int i = 0; i < L; i++) {
            MEAN[(r * K + K - 1) * L + i] = smoothed[i];
            STD[(r * K + K - 1) * L + i] = sqrt(smoothed_cov[i * L + i] < 0.0 ? 0.0 : smoothed_cov[i * L + i]);
        }
        for (long k = K - 2; k >= 0; k--) {
            const double *ak = transitions + k * L * L, *ck = covs + k * L * L;
            product(L, L, L, ak, ck, ap); /* A P */
            product_t(L, L, L, ap, ak, pc); /* predicted cov A P A' + Q */
            for (int i = 0; i < L; i++) pc[i * L + i] += q[i];
            for (int i = 0; i < L * L; i++) lu[i] = pc[i];
            if (lu_factor(L, lu, pivot)) {
                fill_nan(L * L, gain);
            } else { /* G = P A' Ppred^-1 = (Ppred^-1 A P)' */
                for (int i = 0; i < L * L; i++) dc[i] = ap[i];
                lu_solve(L, lu, pivot, dc, L);
                for (int i = 0; i < L; i++)
                    for (int j = 0; j < L; j++) gain[i * L + j] = dc[j * L + i];
            }
            for (int i = 0; i < L; i++) gap[i] = smoothed[i] - predicted[k * L + i];
            for (int i = 0; i < L; i++) {
                double sum = 0.0;
                for (int j = 0; j < L; j++) sum += gain[i * L + j] * gap[j];
                smoothed[i] = means[k * L + i] + sum;
            }
            for (int i = 0; i < L * L; i++) dc[i] = smoothed_cov[i] - pc[i];
            product(L, L, L, gain, dc, gd);
            product_t(L, L, L, gd, gain, dc);
            for (int i = 0; i < L * L; i++) smoothed_cov[i] = ck[i] + dc[i];
            for (int i = 0; i < L; i++) {
                MEAN[(r * K + k) * L + i] = smoothed[i];
                STD[(r * K + k) * L + i] = sqrt(smoothed_cov[i * L + i] < 0.0 ? 0.0 : smoothed_cov[i * L + i]);
            }
        }
    }
    free(history);
}

/* Filter (and, with backward, smooth) R rows of K steps; see CompiledSystem.smooth.  0, or 1 where the
   history could not be allocated. */
int smooth(const long R, const long K, const double *Y, const double *U, const double *MIX, const double *MEAN0,
           const double *COV0, const double *Q, const double *RV, const int backward, double *MEAN, double *STD,
           double *INNOVATION, double *LL, double *FINAL)
{
    call_t c = {.R = R, .S = K, .Y = Y, .U = U, .MIX = MIX, .MEAN0 = MEAN0, .COV0 = COV0, .Q = Q, .RV = RV,
                .backward = backward, .MEAN = MEAN, .STD = STD, .INNOVATION = INNOVATION, .LL = LL, .FINAL = FINAL};
    parallel(&c, smooth_rows);
    return c.status;
}
