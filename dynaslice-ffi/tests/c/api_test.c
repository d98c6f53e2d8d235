/*
 * The C host test of the DynaSlice C ABI (built and run by dynaslice-ffi/tests/hosts.rs).
 *
 * Usage: api_test MODEL.dsm SCRATCH_DIR exact|approx
 *
 * expected.h (on the include path) holds the Rust answers for MODEL.dsm as IEEE bit patterns.
 * Single-point calls must match them bit for bit (one portable code path). Batch calls use SIMD
 * kernels picked for the CPU: "exact" (native run, same CPU as the Rust side) demands bit
 * equality, "approx" (under valgrind, whose CPU lacks AVX-512) a relative 2e-4.
 * Broken variants of the model are written to SCRATCH_DIR to test every load error.
 * MODEL.dsm is a model without motion or a motion model (REF_MOTION): the same calls answer
 * both, and the displacement is zero without motion.
 */
#define _POSIX_C_SOURCE 200809L /* mkfifo */

#include "dynaslice.h"
#include "expected.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int checks, failures;

#define CHECK(cond)                                                                  \
    do {                                                                             \
        checks++;                                                                    \
        if (!(cond)) {                                                               \
            failures++;                                                              \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
        }                                                                            \
    } while (0)

#define CHECK_RC(call, want)                                                          \
    do {                                                                              \
        int rc_ = (call);                                                             \
        checks++;                                                                     \
        if (rc_ != (want)) {                                                          \
            failures++;                                                               \
            fprintf(stderr, "%s:%d: %s returned %d (%s), want %d\n  last error: %s\n", \
                    __FILE__, __LINE__, #call, rc_, ds_error_string(rc_), (want),     \
                    ds_last_error_message());                                         \
        }                                                                             \
    } while (0)

static float from_bits(uint32_t b) {
    float f;
    memcpy(&f, &b, sizeof f);
    return f;
}

static int same_bits(float a, uint32_t b) {
    uint32_t ab;
    memcpy(&ab, &a, sizeof ab);
    return ab == b;
}

static int close_to(float a, uint32_t b_bits) {
    float b = from_bits(b_bits);
    float scale = fabsf(b) > 1.0f ? fabsf(b) : 1.0f;
    return fabsf(a - b) <= 2e-4f * scale;
}

static int last_error_contains(const char *text) {
    return strstr(ds_last_error_message(), text) != NULL;
}

/* Reads a whole file; the caller frees it. */
static uint8_t *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *buf = malloc((size_t)n + 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *len = (size_t)n;
    return buf;
}

static void write_file(const char *path, const uint8_t *bytes, size_t len) {
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(bytes, 1, len, f) != len) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(2);
    }
    fclose(f);
}

/* Opening a broken variant of the model fails with `want` and leaves *out NULL. */
static void check_open_fails(const char *dir, const char *name, const uint8_t *bytes,
                             size_t len, int want, const char *detail) {
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    write_file(path, bytes, len);
    DsModel *m = (DsModel *)&checks; /* a non-NULL sentinel that must be overwritten */
    CHECK_RC(ds_model_open(path, &m), want);
    CHECK(m == NULL);
    CHECK(last_error_contains("ds_model_open"));
    CHECK(last_error_contains(detail));
    m = (DsModel *)&checks;
    CHECK_RC(ds_model_from_bytes(bytes, len, &m), want);
    CHECK(m == NULL);
    CHECK(last_error_contains(detail));
}

static void test_load_errors(const char *model_path, const char *dir) {
    size_t len = 0;
    uint8_t *bytes = read_file(model_path, &len);
    CHECK(bytes != NULL && len > 1000);
    if (!bytes) return;

    DsModel *m = (DsModel *)&checks;
    CHECK_RC(ds_model_open(NULL, &m), DS_E_NULL_POINTER);
    CHECK(m == NULL);
    CHECK(last_error_contains("`path` is NULL"));
    CHECK_RC(ds_model_open(model_path, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_model_from_bytes(NULL, len, &m), DS_E_NULL_POINTER);
    CHECK_RC(ds_model_from_bytes(bytes, len, NULL), DS_E_NULL_POINTER);

    char missing[4096];
    snprintf(missing, sizeof missing, "%s/no-such-model.dsm", dir);
    m = (DsModel *)&checks;
    CHECK_RC(ds_model_open(missing, &m), DS_E_IO);
    CHECK(m == NULL);
    CHECK(last_error_contains("no-such-model.dsm"));
    /* Regular files only: a directory, a device and a FIFO fail at once (opening a FIFO for
     * reading would block until a writer came). */
    const char *not_files[] = {dir, "/dev/null", NULL};
    char fifo[4096];
    snprintf(fifo, sizeof fifo, "%s/fifo.dsm", dir);
    remove(fifo);
    CHECK(mkfifo(fifo, 0600) == 0);
    not_files[2] = fifo;
    for (size_t i = 0; i < sizeof not_files / sizeof not_files[0]; i++) {
        m = (DsModel *)&checks;
        CHECK_RC(ds_model_open(not_files[i], &m), DS_E_IO);
        CHECK(m == NULL && last_error_contains("not a regular file"));
    }
    remove(fifo);
    /* `out` over the path's own bytes is refused (and still set to NULL). */
    DsModel *path_and_out[2];
    memset(path_and_out, 0, sizeof path_and_out);
    memcpy(path_and_out, "/tmp/x.dsm", 11);
    CHECK_RC(ds_model_open((const char *)path_and_out, &path_and_out[0]), DS_E_INVALID_ARGUMENT);
    CHECK(path_and_out[0] == NULL && last_error_contains("`path` and `out` overlap"));

    check_open_fails(dir, "empty.dsm", bytes, 0, DS_E_TRUNCATED, "truncated");
    check_open_fails(dir, "header.dsm", bytes, 100, DS_E_TRUNCATED, "truncated");
    check_open_fails(dir, "half.dsm", bytes, len / 2, DS_E_TRUNCATED, "truncated");
    check_open_fails(dir, "short.dsm", bytes, len - 1, DS_E_TRUNCATED, "truncated");

    uint8_t *bad = malloc(len + 1);
    memcpy(bad, bytes, len);
    bad[len - 100] ^= 0x01; /* one bit of a weight */
    check_open_fails(dir, "flipped.dsm", bad, len, DS_E_CHECKSUM, "CRC mismatch");
    memcpy(bad, bytes, len);
    bad[0] ^= 0xff; /* the magic */
    check_open_fails(dir, "magic.dsm", bad, len, DS_E_BAD_FORMAT, "magic");
    memcpy(bad, bytes, len);
    bad[8] = 99; /* the format version */
    check_open_fails(dir, "version.dsm", bad, len, DS_E_UNSUPPORTED, "version 99");
    memcpy(bad, bytes, len);
    bad[len] = 0; /* one byte past the CRC trailer */
    check_open_fails(dir, "long.dsm", bad, len + 1, DS_E_BAD_FORMAT, "after the CRC");

    /* `out` inside the bytes is refused. */
    memcpy(bad, bytes, len);
    CHECK_RC(ds_model_from_bytes(bad, len, (DsModel **)(void *)(bad + 64)), DS_E_INVALID_ARGUMENT);
    CHECK(last_error_contains("`bytes` and `out` overlap"));

    /* Any alignment: the bytes are copied, and may be freed right after the call. */
    memcpy(bad + 1, bytes, len);
    CHECK_RC(ds_model_from_bytes(bad + 1, len, &m), DS_OK);
    free(bad);
    CHECK(m != NULL);
    float f[REF_K];
    const float x[3] = {from_bits(REF_XYZT[0][0]), from_bits(REF_XYZT[0][1]),
                        from_bits(REF_XYZT[0][2])};
    CHECK_RC(ds_eval(m, x, from_bits(REF_XYZT[0][3]), f, REF_K), DS_OK);
    for (int k = 0; k < REF_K; k++) CHECK(same_bits(f[k], REF_F[0][k]));
    ds_model_free(m);
    free(bytes);
}

static void test_metadata(const DsModel *m) {
    CHECK(ds_num_classes(m) == REF_K);
    CHECK(ds_num_classes(NULL) == 0);
    for (uint32_t k = 1; k <= REF_K; k++) {
        char name[DS_MAX_NAME_LEN + 1];
        int n = ds_class_name(m, k, name, sizeof name);
        CHECK(n == (int)strlen(REF_NAMES[k - 1]));
        CHECK(strcmp(name, REF_NAMES[k - 1]) == 0);
        CHECK(ds_class_name(m, k, NULL, 0) == n); /* size query */
        int32_t label = 12345;
        CHECK_RC(ds_class_label(m, k, &label), DS_OK);
        CHECK(label == REF_LABELS[k - 1]);
    }
    /* A short buffer: snprintf-style truncation, nothing written past `len`. */
    char small[8];
    memset(small, 'X', sizeof small);
    CHECK(ds_class_name(m, 2, small, 5) == (int)strlen(REF_NAMES[1]));
    CHECK(strcmp(small, "left") == 0);
    CHECK(small[5] == 'X');
    /* Class 3 is "ünïcödé…": 4 bytes would end inside "ï", so only "ün" (3 bytes) is written. */
    memset(small, 'X', sizeof small);
    CHECK(ds_class_name(m, 3, small, 5) > 5);
    CHECK(strlen(small) == 3 && memcmp(small, REF_NAMES[2], 3) == 0);
    CHECK_RC(ds_class_name(m, 1, NULL, 5), DS_E_NULL_POINTER);
    CHECK_RC(ds_class_name(m, 0, small, sizeof small), DS_E_NO_SUCH_CLASS);
    CHECK(last_error_contains("no class 0"));
    CHECK_RC(ds_class_name(m, REF_K + 1, small, sizeof small), DS_E_NO_SUCH_CLASS);
    CHECK_RC(ds_class_name(NULL, 1, small, sizeof small), DS_E_NULL_POINTER);
    int32_t label;
    CHECK_RC(ds_class_label(m, 0, &label), DS_E_NO_SUCH_CLASS);
    CHECK_RC(ds_class_label(m, 1, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_class_label(NULL, 1, &label), DS_E_NULL_POINTER);

    char meta[256];
    CHECK(ds_metadata(m, meta, sizeof meta) == (int)strlen(REF_METADATA));
    CHECK(strcmp(meta, REF_METADATA) == 0);
    CHECK_RC(ds_metadata(NULL, meta, sizeof meta), DS_E_NULL_POINTER);

    float t0 = 0, t1 = 0, lo[3], hi[3];
    CHECK_RC(ds_time_range(m, &t0, &t1), DS_OK);
    CHECK(same_bits(t0, REF_TIME_RANGE[0]) && same_bits(t1, REF_TIME_RANGE[1]));
    CHECK_RC(ds_time_range(m, NULL, &t1), DS_E_NULL_POINTER);
    CHECK_RC(ds_time_range(m, &t0, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_time_range(NULL, &t0, &t1), DS_E_NULL_POINTER);
    CHECK_RC(ds_time_range(m, &t0, &t0), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_time_range(m, NULL, NULL), DS_E_NULL_POINTER); /* missing, not overlapping */
    CHECK_RC(ds_bounds(m, lo, hi), DS_OK);
    for (int d = 0; d < 3; d++) {
        CHECK(same_bits(lo[d], REF_BOUNDS[d]));
        CHECK(same_bits(hi[d], REF_BOUNDS[3 + d]));
    }
    CHECK_RC(ds_bounds(m, NULL, hi), DS_E_NULL_POINTER);
    CHECK_RC(ds_bounds(m, lo, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_bounds(NULL, lo, hi), DS_E_NULL_POINTER);
    CHECK_RC(ds_bounds(m, NULL, NULL), DS_E_NULL_POINTER);
}

static void test_points(const DsModel *m) {
    for (int i = 0; i < REF_N; i++) {
        const float x[3] = {from_bits(REF_XYZT[i][0]), from_bits(REF_XYZT[i][1]),
                            from_bits(REF_XYZT[i][2])};
        const float t = from_bits(REF_XYZT[i][3]);
        /* One spare entry past K (and 3 in grad) that must stay untouched. */
        float f[REF_K + 1], g[3 * (REF_K + 1)], d[REF_K + 1];
        f[REF_K] = d[REF_K] = g[3 * REF_K] = 42.0f;
        CHECK_RC(ds_eval(m, x, t, f, REF_K + 1), DS_OK);
        for (int k = 0; k < REF_K; k++) CHECK(same_bits(f[k], REF_F[i][k]));
        CHECK(f[REF_K] == 42.0f);
        CHECK_RC(ds_eval_grad(m, x, t, f, g, REF_K + 1), DS_OK);
        for (int k = 0; k < REF_K; k++) CHECK(same_bits(f[k], REF_F[i][k]));
        for (int j = 0; j < 3 * REF_K; j++) CHECK(same_bits(g[j], REF_GRAD[i][j]));
        CHECK(g[3 * REF_K] == 42.0f);
        /* grad holds 3K floats whatever sdf_len is (valgrind watches the bound). */
        float g_exact[3 * REF_K];
        CHECK_RC(ds_eval_grad(m, x, t, f, g_exact, REF_K + 1), DS_OK);
        for (int j = 0; j < 3 * REF_K; j++) CHECK(same_bits(g_exact[j], REF_GRAD[i][j]));
        CHECK_RC(ds_eval_jacobian(m, x, t, f, g, d, REF_K), DS_OK);
        for (int k = 0; k < REF_K; k++) {
            CHECK(same_bits(f[k], REF_F[i][k]));
            CHECK(same_bits(d[k], REF_DFDT[i][k]));
        }
        for (int j = 0; j < 3 * REF_K; j++) CHECK(same_bits(g[j], REF_GRAD[i][j]));
        CHECK(d[REF_K] == 42.0f);
        uint32_t label = 12345;
        CHECK_RC(ds_label(m, x, t, &label), DS_OK);
        CHECK(label == REF_LABEL[i]);
        float u[4] = {0.0f, 0.0f, 0.0f, 42.0f};
        CHECK_RC(ds_displacement(m, x, t, u), DS_OK);
        for (int d = 0; d < 3; d++) {
            CHECK(same_bits(u[d], REF_DISP[i][d]));
            if (!REF_MOTION) CHECK(u[d] == 0.0f);
        }
        CHECK(u[3] == 42.0f);
    }
}

static void test_point_errors(const DsModel *m) {
    const float x[3] = {1.0f, 2.0f, 3.0f};
    float f[REF_K + 1], g[3 * REF_K], d[REF_K];
    uint32_t label;
    CHECK_RC(ds_eval(NULL, x, 0.5f, f, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval(m, NULL, 0.5f, f, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval(m, x, 0.5f, NULL, REF_K), DS_E_NULL_POINTER);
    f[REF_K - 1] = 42.0f;
    CHECK_RC(ds_eval(m, x, 0.5f, f, REF_K - 1), DS_E_BUFFER_TOO_SMALL);
    CHECK(f[REF_K - 1] == 42.0f);
    CHECK(last_error_contains("sdf_len is 2, the model has 3 classes"));
    CHECK_RC(ds_eval(m, x, 0.5f, f, 0), DS_E_BUFFER_TOO_SMALL);
    CHECK_RC(ds_eval_grad(NULL, x, 0.5f, f, g, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_grad(m, NULL, 0.5f, f, g, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_grad(m, x, 0.5f, NULL, g, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_grad(m, x, 0.5f, f, NULL, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_grad(m, x, 0.5f, f, g, REF_K - 1), DS_E_BUFFER_TOO_SMALL);
    CHECK_RC(ds_eval_grad(m, x, 0.5f, g + 6, g, REF_K), DS_E_INVALID_ARGUMENT); /* overlap */
    /* An output over the query point is refused as documented, in every single-point call. */
    float xf[3 * REF_K] = {1.0f, 2.0f, 3.0f};
    CHECK_RC(ds_eval(m, xf, 0.5f, xf, REF_K), DS_E_INVALID_ARGUMENT);
    CHECK(xf[0] == 1.0f && last_error_contains("overlap"));
    CHECK_RC(ds_eval_grad(m, xf, 0.5f, f, xf, REF_K), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_eval_jacobian(m, xf, 0.5f, f, g, xf, REF_K), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_label(m, xf, 0.5f, (uint32_t *)(void *)(xf + 2)), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_eval_jacobian(m, x, 0.5f, f, g, NULL, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_jacobian(m, x, 0.5f, f, g, f, REF_K), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_eval_jacobian(NULL, x, 0.5f, f, g, d, REF_K), DS_E_NULL_POINTER);
    CHECK_RC(ds_label(NULL, x, 0.5f, &label), DS_E_NULL_POINTER);
    CHECK_RC(ds_label(m, NULL, 0.5f, &label), DS_E_NULL_POINTER);
    CHECK_RC(ds_label(m, x, 0.5f, NULL), DS_E_NULL_POINTER);
    float u[3];
    CHECK_RC(ds_displacement(NULL, x, 0.5f, u), DS_E_NULL_POINTER);
    CHECK_RC(ds_displacement(m, NULL, 0.5f, u), DS_E_NULL_POINTER);
    CHECK_RC(ds_displacement(m, x, 0.5f, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_displacement(m, xf, 0.5f, xf + 1), DS_E_INVALID_ARGUMENT);
    CHECK(last_error_contains("ds_displacement") && last_error_contains("overlap"));

    /* NaN and infinite points (at a time in range) are answered, not errors: NaN distances,
     * undefined label. */
    const float nan_x[3] = {NAN, 0.0f, 0.0f};
    const float inf_x[3] = {0.0f, -INFINITY, 0.0f};
    const float *bad[] = {nan_x, inf_x};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        CHECK_RC(ds_eval_jacobian(m, bad[i], 0.5f, f, g, d, REF_K), DS_OK);
        for (int k = 0; k < REF_K; k++) CHECK(isnan(f[k]) && isnan(d[k]));
        for (int j = 0; j < 3 * REF_K; j++) CHECK(isnan(g[j]));
        label = 0;
        CHECK_RC(ds_label(m, bad[i], 0.5f, &label), DS_OK);
        CHECK(label == DS_LABEL_UNDEFINED);
        CHECK_RC(ds_displacement(m, bad[i], 0.5f, u), DS_OK);
        for (int j = 0; j < 3; j++) CHECK(isnan(u[j]));
    }

    /* Finite points far outside the bounds are answered with finite values and a label. */
    const float far_x[3][3] = {{1e9f, 0.0f, 0.0f}, {3.4e38f, -3.4e38f, 1e30f}};
    for (size_t i = 0; i < 2; i++) {
        CHECK_RC(ds_eval_jacobian(m, far_x[i], 0.5f, f, g, d, REF_K), DS_OK);
        for (int k = 0; k < REF_K; k++) CHECK(isfinite(f[k]) && isfinite(d[k]));
        for (int j = 0; j < 3 * REF_K; j++) CHECK(isfinite(g[j]));
        CHECK_RC(ds_label(m, far_x[i], 0.5f, &label), DS_OK);
        CHECK(label <= REF_K);
        CHECK_RC(ds_displacement(m, far_x[i], 0.5f, u), DS_OK);
        for (int j = 0; j < 3; j++) CHECK(isfinite(u[j]));
    }
}

/* Every call taking a time answers on both edges of the model's time range and refuses a time
 * outside it (NaN and infinities included) with DS_E_TIME_OUT_OF_RANGE, writing nothing. */
static void test_time_range(const DsModel *m) {
    float t0, t1;
    CHECK_RC(ds_time_range(m, &t0, &t1), DS_OK);
    const float span = t1 - t0;
    const float x[3] = {10.0f, -5.0f, 3.0f};
    float f[REF_K], g[3 * REF_K], d[REF_K], u[3];
    uint32_t label;

    /* The edges, and just inside the rounding slack of 1e-4 of the range. */
    const float inside[] = {t0, t1, t0 - 5e-5f * span, t1 + 5e-5f * span, 0.5f * (t0 + t1)};
    for (size_t i = 0; i < sizeof inside / sizeof inside[0]; i++) {
        const float t = inside[i];
        CHECK_RC(ds_check_time(m, t), DS_OK);
        CHECK_RC(ds_eval(m, x, t, f, REF_K), DS_OK);
        CHECK_RC(ds_eval_grad(m, x, t, f, g, REF_K), DS_OK);
        CHECK_RC(ds_eval_jacobian(m, x, t, f, g, d, REF_K), DS_OK);
        for (int k = 0; k < REF_K; k++) CHECK(isfinite(f[k]) && isfinite(d[k]));
        label = 12345;
        CHECK_RC(ds_label(m, x, t, &label), DS_OK);
        CHECK(label <= REF_K);
        CHECK_RC(ds_displacement(m, x, t, u), DS_OK);
        for (int j = 0; j < 3; j++) CHECK(isfinite(u[j]));
    }

    const float outside[] = {t0 - 2e-4f * span, t1 + 2e-4f * span, t1 + span, -1e30f, 1e30f,
                             -3.4e38f, NAN, INFINITY, -INFINITY};
    for (size_t i = 0; i < sizeof outside / sizeof outside[0]; i++) {
        const float t = outside[i];
        CHECK_RC(ds_check_time(m, t), DS_E_TIME_OUT_OF_RANGE);
        CHECK(last_error_contains("ds_check_time: t = "));
        CHECK(last_error_contains("is outside the model's time range"));
        for (int j = 0; j < 3 * REF_K; j++) g[j] = 42.0f;
        for (int k = 0; k < REF_K; k++) f[k] = d[k] = 42.0f;
        label = 12345;
        CHECK_RC(ds_eval(m, x, t, f, REF_K), DS_E_TIME_OUT_OF_RANGE);
        CHECK(last_error_contains("ds_eval: t = "));
        CHECK_RC(ds_eval_grad(m, x, t, f, g, REF_K), DS_E_TIME_OUT_OF_RANGE);
        CHECK_RC(ds_eval_jacobian(m, x, t, f, g, d, REF_K), DS_E_TIME_OUT_OF_RANGE);
        CHECK_RC(ds_label(m, x, t, &label), DS_E_TIME_OUT_OF_RANGE);
        u[0] = u[1] = u[2] = 42.0f;
        CHECK_RC(ds_displacement(m, x, t, u), DS_E_TIME_OUT_OF_RANGE);
        CHECK(last_error_contains("ds_displacement: t = "));
        for (int k = 0; k < REF_K; k++) CHECK(f[k] == 42.0f && d[k] == 42.0f);
        for (int j = 0; j < 3 * REF_K; j++) CHECK(g[j] == 42.0f);
        for (int j = 0; j < 3; j++) CHECK(u[j] == 42.0f);
        CHECK(label == 12345);
    }
    /* Pointer errors come before the time. */
    CHECK_RC(ds_check_time(NULL, t0), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval(m, x, NAN, NULL, REF_K), DS_E_NULL_POINTER);

    /* Batches: the edges are answered; one time outside refuses the whole call, nothing
     * written, and the message names the first such point. */
    enum { N = 6 };
    float xyz[3 * N], t[N] = {t0, t1, t0, 0.5f * (t0 + t1), t1, t0};
    float bf[N * REF_K], bg[3 * N * REF_K], bu[3 * N];
    uint32_t bl[N];
    for (int i = 0; i < 3 * N; i++) xyz[i] = x[i % 3];
    CHECK_RC(ds_eval_batch(m, N, xyz, t, bf), DS_OK);
    CHECK_RC(ds_eval_grad_batch(m, N, xyz, t, bf, bg), DS_OK);
    CHECK_RC(ds_label_batch(m, N, xyz, t, bl), DS_OK);
    CHECK_RC(ds_displacement_batch(m, N, xyz, t, bu), DS_OK);
    for (int i = 0; i < N; i++) CHECK(bl[i] <= REF_K);
    const float bad_times[] = {NAN, t1 + span, -INFINITY};
    for (size_t b = 0; b < sizeof bad_times / sizeof bad_times[0]; b++) {
        t[2] = bad_times[b];
        t[4] = t0 - span;
        for (int i = 0; i < N * REF_K; i++) bf[i] = 42.0f;
        for (int i = 0; i < 3 * N * REF_K; i++) bg[i] = 42.0f;
        for (int i = 0; i < N; i++) bl[i] = 42;
        for (int i = 0; i < 3 * N; i++) bu[i] = 42.0f;
        CHECK_RC(ds_displacement_batch(m, N, xyz, t, bu), DS_E_TIME_OUT_OF_RANGE);
        CHECK(last_error_contains("ds_displacement_batch: t[2] = "));
        for (int i = 0; i < 3 * N; i++) CHECK(bu[i] == 42.0f);
        CHECK_RC(ds_eval_batch(m, N, xyz, t, bf), DS_E_TIME_OUT_OF_RANGE);
        CHECK(last_error_contains("ds_eval_batch: t[2] = "));
        CHECK(last_error_contains("(and 1 more time)"));
        CHECK_RC(ds_eval_grad_batch(m, N, xyz, t, bf, bg), DS_E_TIME_OUT_OF_RANGE);
        CHECK_RC(ds_label_batch(m, N, xyz, t, bl), DS_E_TIME_OUT_OF_RANGE);
        for (int i = 0; i < N * REF_K; i++) CHECK(bf[i] == 42.0f);
        for (int i = 0; i < 3 * N * REF_K; i++) CHECK(bg[i] == 42.0f);
        for (int i = 0; i < N; i++) CHECK(bl[i] == 42);
    }
}

static void test_batch(const DsModel *m, int exact) {
    static float xyz[REF_N * 3], t[REF_N], f[REF_N * REF_K + 1], g[REF_N * REF_K * 3 + 1];
    static float u[REF_N * 3 + 1];
    static uint32_t labels[REF_N + 1];
    for (int i = 0; i < REF_N; i++) {
        for (int d = 0; d < 3; d++) xyz[3 * i + d] = from_bits(REF_XYZT[i][d]);
        t[i] = from_bits(REF_XYZT[i][3]);
    }
    f[REF_N * REF_K] = g[REF_N * REF_K * 3] = 42.0f;
    labels[REF_N] = 42;
    CHECK_RC(ds_eval_batch(m, REF_N, xyz, t, f), DS_OK);
    CHECK_RC(ds_label_batch(m, REF_N, xyz, t, labels), DS_OK);
    for (int i = 0; i < REF_N; i++) {
        int argmin = 0;
        float best = 0.0f;
        for (int k = 0; k < REF_K; k++) {
            float v = f[i * REF_K + k];
            CHECK(exact ? same_bits(v, REF_BATCH_F[i][k]) : close_to(v, REF_BATCH_F[i][k]));
            if (v < best) {
                best = v;
                argmin = k + 1;
            }
        }
        /* Labels agree with this run's batch distances, and natively with Rust's. */
        CHECK(labels[i] == (uint32_t)argmin);
        if (exact) CHECK(labels[i] == REF_BATCH_LABEL[i]);
    }
    CHECK_RC(ds_eval_grad_batch(m, REF_N, xyz, t, f, g), DS_OK);
    for (int i = 0; i < REF_N; i++)
        for (int j = 0; j < 3 * REF_K; j++) {
            float v = g[i * 3 * REF_K + j];
            CHECK(exact ? same_bits(v, REF_BATCH_GRAD[i][j]) : close_to(v, REF_BATCH_GRAD[i][j]));
        }
    CHECK(f[REF_N * REF_K] == 42.0f && g[REF_N * REF_K * 3] == 42.0f && labels[REF_N] == 42);
    u[REF_N * 3] = 42.0f;
    CHECK_RC(ds_displacement_batch(m, REF_N, xyz, t, u), DS_OK);
    for (int i = 0; i < REF_N; i++)
        for (int d = 0; d < 3; d++) {
            float v = u[3 * i + d];
            CHECK(exact ? same_bits(v, REF_BATCH_DISP[i][d]) : close_to(v, REF_BATCH_DISP[i][d]));
            if (!REF_MOTION) CHECK(v == 0.0f);
        }
    CHECK(u[REF_N * 3] == 42.0f);

    /* One NaN or infinite point spoils only its own row (a bad time refuses the whole call:
     * test_time_range). */
    xyz[3 * 7 + 1] = NAN;
    xyz[3 * 9] = INFINITY;
    CHECK_RC(ds_eval_batch(m, REF_N, xyz, t, f), DS_OK);
    CHECK_RC(ds_label_batch(m, REF_N, xyz, t, labels), DS_OK);
    for (int i = 0; i < REF_N; i++) {
        int spoiled = i == 7 || i == 9;
        for (int k = 0; k < REF_K; k++) CHECK(spoiled ? isnan(f[i * REF_K + k]) : !isnan(f[i * REF_K + k]));
        CHECK(spoiled ? labels[i] == DS_LABEL_UNDEFINED : labels[i] <= REF_K);
    }

    /* Errors: NULLs, overlapping buffers, sizes that overflow; nothing written. */
    CHECK_RC(ds_eval_batch(NULL, REF_N, xyz, t, f), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_batch(m, REF_N, NULL, t, f), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_batch(m, REF_N, xyz, NULL, f), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_batch(m, REF_N, xyz, t, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_batch(m, REF_N, xyz, t, xyz), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_eval_batch(m, REF_N, xyz, t, t), DS_E_INVALID_ARGUMENT);
    CHECK(last_error_contains("overlap"));
    CHECK_RC(ds_eval_batch(m, SIZE_MAX / 2, xyz, t, f), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_eval_batch(m, 0, xyz, t, f), DS_OK);
    CHECK_RC(ds_eval_grad_batch(m, REF_N, xyz, t, f, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_eval_grad_batch(m, REF_N, xyz, t, g, g), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_eval_grad_batch(m, SIZE_MAX / 4, xyz, t, f, g), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_label_batch(NULL, REF_N, xyz, t, labels), DS_E_NULL_POINTER);
    CHECK_RC(ds_label_batch(m, REF_N, xyz, t, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_label_batch(m, REF_N, xyz, t, (uint32_t *)xyz), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_displacement_batch(NULL, REF_N, xyz, t, u), DS_E_NULL_POINTER);
    CHECK_RC(ds_displacement_batch(m, REF_N, NULL, t, u), DS_E_NULL_POINTER);
    CHECK_RC(ds_displacement_batch(m, REF_N, xyz, NULL, u), DS_E_NULL_POINTER);
    CHECK_RC(ds_displacement_batch(m, REF_N, xyz, t, NULL), DS_E_NULL_POINTER);
    CHECK_RC(ds_displacement_batch(m, REF_N, xyz, t, xyz + 3), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_displacement_batch(m, REF_N, xyz, t, t), DS_E_INVALID_ARGUMENT);
    CHECK(last_error_contains("ds_displacement_batch") && last_error_contains("overlap"));
    CHECK_RC(ds_displacement_batch(m, SIZE_MAX / 4, xyz, t, u), DS_E_INVALID_ARGUMENT);
    CHECK_RC(ds_displacement_batch(m, 0, xyz, t, u), DS_OK);
    /* The NaN and infinite points above spoil only their own rows. */
    CHECK_RC(ds_displacement_batch(m, REF_N, xyz, t, u), DS_OK);
    for (int i = 0; i < REF_N; i++)
        for (int d = 0; d < 3; d++) {
            int spoiled = i == 7 || i == 9;
            CHECK(spoiled ? isnan(u[3 * i + d]) : isfinite(u[3 * i + d]));
        }
}

static void test_error_strings(void) {
    const int codes[] = {DS_OK,          DS_E_NULL_POINTER,     DS_E_IO,
                         DS_E_TRUNCATED, DS_E_BAD_FORMAT,       DS_E_CHECKSUM,
                         DS_E_UNSUPPORTED, DS_E_BUFFER_TOO_SMALL, DS_E_NO_SUCH_CLASS,
                         DS_E_INVALID_ARGUMENT, DS_E_INTERNAL, DS_E_TIME_OUT_OF_RANGE};
    const int n = (int)(sizeof codes / sizeof codes[0]);
    const char *unknown = ds_error_string(12345);
    CHECK(unknown != NULL && strcmp(unknown, "unknown error code") == 0);
    CHECK(ds_error_string(-12) != NULL && strcmp(ds_error_string(-12), unknown) == 0);
    /* The codes' values are part of the ABI: appended, never renumbered. */
    CHECK(DS_E_INTERNAL == -10 && DS_E_TIME_OUT_OF_RANGE == -11);
    for (int i = 0; i < n; i++) {
        const char *s = ds_error_string(codes[i]);
        CHECK(s != NULL && *s != '\0' && strcmp(s, unknown) != 0);
        for (int j = 0; j < i; j++) CHECK(strcmp(s, ds_error_string(codes[j])) != 0);
    }
    CHECK(ds_version() != NULL && strchr(ds_version(), '.') != NULL);
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: %s MODEL.dsm SCRATCH_DIR exact|approx\n", argv[0]);
        return 2;
    }
    /* Nothing has failed on this thread yet. */
    CHECK(ds_last_error_message() != NULL && *ds_last_error_message() == '\0');
    test_error_strings();
    test_load_errors(argv[1], argv[2]);

    DsModel *m = NULL;
    CHECK_RC(ds_model_open(argv[1], &m), DS_OK);
    if (m) {
        /* Success leaves the last failure's message alone. */
        CHECK(last_error_contains("ds_model_from_bytes"));
        test_metadata(m);
        test_points(m);
        test_point_errors(m);
        test_time_range(m);
        test_batch(m, strcmp(argv[3], "exact") == 0);
    }
    ds_model_free(m);
    ds_model_free(NULL);
    printf("C API test (%s): %d passed, %d failed\n", argv[3], checks - failures, failures);
    return failures == 0 ? 0 : 1;
}
