/* Helpers shared by the checkpoint and MPI tests (tests/test_checkpoint.c,
 * tests/test_mpi.c): paths in the test's temporary folder `dir` (each file
 * defines it), checkpoint keys and reads, and film/image comparisons within
 * 1e-4 of each pixel's largest channel. Include after test_util.h, with SCENE
 * defined. */
#ifndef SPT_CKPT_TEST_H
#define SPT_CKPT_TEST_H

#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "render/checkpoint.h"
#include "io/exr.h"
#include "render/film.h"
#include "film_test.h"


/* The key of path's render: ours, with the file's kernel-source hash, so a test
 * binary and a program built from different kernel sources (another build) still
 * read each other's checkpoints; everything else must match. */
static inline void key_for(const char *path, CheckpointKey *k)
{
    ExrLayers L;
    SptError e = {0};
    if (exr_read_layers(path, NULL, 0, &L, &e))
        fail_msg("%s", e.msg);
    const ExrAttr *a = exr_layers_attr(&L, "spectrace:settings", SPT_EXR_ATTR_STRING);
    assert_non_null(a);
    const char *mine = strstr(k->settings, ";kernels="), *theirs = strstr(a->s, ";kernels=");
    assert_non_null(mine);
    assert_non_null(theirs);
    if (mine - k->settings != theirs - a->s || strncmp(k->settings, a->s, (size_t)(mine - k->settings)))
        fail_msg("settings differ: %s vs %s", k->settings, a->s);
    snprintf(k->settings, sizeof k->settings, "%s", a->s);
    exr_layers_free(&L);
}

/* The --aov and --spectral of the renders whose checkpoints load_checkpoint reads. */
static unsigned ckpt_aov;
static int ckpt_spectral;

/* Reads a checkpoint of a test render (32x32, seed, SCENE, --aov ckpt_aov) into
 * film; returns the samples per pixel it holds. */
static inline uint32_t load_checkpoint(const char *path, uint32_t seed, uint32_t spp, Film *film)
{
    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
    rs.width = rs.height = 32;
    rs.max_depth = -1;
    rs.seed = seed;
    rs.env_intensity = 1;
    rs.aov = ckpt_aov;
    rs.spectral = ckpt_spectral;
    CheckpointKey k;
    SptError e = {0};
    if (checkpoint_key(&k, SCENE, &rs, &e))
        fail_msg("%s", e.msg);
    key_for(path, &k);
    unsigned char *done;
    if (checkpoint_read(path, &k, spp, film, &done, &e))
        fail_msg("%s", e.msg);
    uint32_t n = 0;
    for (uint32_t i = 0; i < spp; i++)
        n += done[i];
    free(done);
    return n;
}

/* The R, G, B channels of two EXR images agree within 1e-4 of each pixel's
 * largest channel. */
static inline void assert_same_exr(const char *pa, const char *pb)
{
    static const char *rgb[3] = {"R", "G", "B"};
    ExrLayers a, b;
    SptError e = {0};
    if (exr_read_layers(pa, rgb, 3, &a, &e) || exr_read_layers(pb, rgb, 3, &b, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(a.width * a.height, b.width * b.height);
    size_t n = (size_t)a.width * a.height;
    for (size_t i = 0; i < n; i++) {
        double m = 1e-12;
        for (int c = 0; c < 3; c++)
            m = fmax(m, fabs(((const float *)exr_layers_channel(&a, rgb[c])->data)[i]));
        for (int c = 0; c < 3; c++) {
            double x = ((const float *)exr_layers_channel(&a, rgb[c])->data)[i];
            double y = ((const float *)exr_layers_channel(&b, rgb[c])->data)[i];
            if (fabs(x - y) > 1e-4 * m)
                fail_msg("%s vs %s: pixel %zu %s: %.9g vs %.9g", pa, pb, i, rgb[c], x, y);
        }
    }
    /* Every other channel (AOV layers) of a is in b and agrees within 1e-4
     * relative (1e-3 for the variance, a difference of sums). */
    for (int c = 0; c < a.channel_count; c++) {
        const ExrChannel *ca = &a.channels[c], *cb = exr_layers_channel(&b, ca->name);
        if (!cb)
            fail_msg("%s has channel %s, %s has not", pa, ca->name, pb);
        /* R, G and B were compared above, against the pixel's largest: a
         * channel of a bright pixel near 0 (a colour at the gamut's edge, B
         * -4e-8 beside G 0.92) differs there by float rounding of X, Y, Z. */
        if (ca->type != SPT_EXR_FLOAT || !strcmp(ca->name, "R") || !strcmp(ca->name, "G") ||
            !strcmp(ca->name, "B"))
            continue;
        double tol = strncmp(ca->name, "variance.", 9) ? 1e-4 : 1e-3;
        for (size_t i = 0; i < n; i++) {
            double x = ((const float *)ca->data)[i], y = ((const float *)cb->data)[i];
            if (fabs(x - y) > tol * fmax(fmax(fabs(x), fabs(y)), 1e-6))
                fail_msg("%s vs %s: pixel %zu %s: %.9g vs %.9g", pa, pb, i, ca->name, x, y);
        }
    }
    assert_int_equal(a.channel_count, b.channel_count);
    exr_layers_free(&a);
    exr_layers_free(&b);
}

/* The checkpoints ck_a and ck_b of seed, with all spp samples done, hold the
 * same film, and the images exr_a and exr_b agree (assert_same_film,
 * assert_same_exr). */
static inline void assert_same_render(const char *ck_a, const char *ck_b, uint32_t seed, uint32_t spp,
                                      const char *exr_a, const char *exr_b)
{
    Film a, b;
    assert_int_equal(load_checkpoint(ck_a, seed, spp, &a), spp);
    assert_int_equal(load_checkpoint(ck_b, seed, spp, &b), spp);
    assert_same_film(&a, &b);
    assert_same_exr(exr_a, exr_b);
    film_free(&a);
    film_free(&b);
}

/* Waits (up to 30 s) for the first checkpoint ck of the render pid, so that it
 * has made progress, sends it sig and requires that it stopped cleanly: exit
 * status 0 and "stopped by a signal" in its log. */
static inline void stop_after_checkpoint(pid_t pid, const char *ck, int sig, const char *log)
{
    for (int i = 0; i < 3000 && !test_exists(ck); i++)
        usleep(10000);
    assert_true(test_exists(ck));
    kill(pid, sig);
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    char *text = test_slurp(log, NULL);
    printf("%s", text);
    assert_true(WIFEXITED(st));
    assert_int_equal(WEXITSTATUS(st), 0);
    assert_non_null(strstr(text, "stopped by a signal"));
    free(text);
}

#endif
