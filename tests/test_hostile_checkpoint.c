/* Hostile checkpoints (issue 35, case 5): a checkpoint edited after it was
 * written must be refused, never resumed into a wrong image. Each attack takes a
 * real checkpoint of a tiny render, changes it with the project's own EXR reader
 * and writer (src/io/exr.h) the way a hand edit would, and resumes from it: the
 * run must exit 3 with one error line naming the file. The cross-checks behind
 * the checksum are tried through checkpoint_write, which gives an implausible
 * film a valid checksum. A resume mismatch names the option as typed (case 15).
 * Runs $SPECTRACE_EXE (set by tests/run_tests.sh) on PoCL's CPU device. */
#include "test_util.h"

#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/exr.h"
#include "render/checkpoint.h"
#include "render/film.h"

#define SCENE "scenes/cornell_box.gltf"
/* The renders of these tests: 8x8 pixels, 4 samples per pixel in the
 * checkpoint; the spectral bands and the albedo sums give the attacks their
 * channels. */
#define ARGS "render " SCENE " --width 8 --height 8 --seed 3 -q --device 0 --spectral 2 --aov albedo"

#include "ckpt_test.h"
#include "denoise_test.h"
#include "render_fixture.h"

static char base[256]; /* the untouched checkpoint (4 spp) */

/* `prefix timeout 120 spectrace<exe_suffix> args` (prefix: environment
 * variables or mpirun), stderr into err; the exit status (-1: killed). */
static int run_exe(const char *prefix, const char *exe_suffix, const char *args, char *err,
                   size_t cap)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "%s timeout -s KILL 120 '%s%s' %s", prefix, test_exe(), exe_suffix,
             args);
    return test_sh(cmd, TEST_STDERR, err, cap);
}

/* Resumes ckpt to 8 spp (prefix and exe_suffix as run_exe): exit 3, one line
 * "error: ..." naming ckpt and containing says, and no image written. */
static void refused_via(const char *prefix, const char *exe_suffix, const char *ckpt,
                        const char *says)
{
    char args[1024], err[8192];
    const char *img = test_path("refused.exr");
    unlink(img);
    snprintf(args, sizeof args, ARGS " --spp 8 -o %s --resume %s", img, ckpt);
    int rc = run_exe(prefix, exe_suffix, args, err, sizeof err);
    printf("%s", err);
    /* mpirun adds its own lines after the program's: there, the one error line
     * is the first. */
    const char *first = *prefix ? strstr(err, "error: ") : err;
    const char *nl = first ? strchr(first, '\n') : NULL;
    if (rc != SPT_EXIT_INPUT || !first || strncmp(first, "error: ", 7) || !nl ||
        (*prefix ? strstr(nl, "error: ") != NULL : nl[1] != 0) || !strstr(first, ckpt) ||
        !strstr(first, says) || strstr(first, says) > nl)
        fail_msg("resume from %s: exit %d, expected 3 with one error line naming the file and "
                 "saying '%s'; got:\n%s", ckpt, rc, says, err);
    assert_false(test_exists(img));
}

static void refused(const char *ckpt, const char *says)
{
    refused_via("", "", ckpt, says);
}

/* The channel's values as floats (the ExrLayers owns them; edits go there). */
static float *chan_f(ExrLayers *L, const char *name)
{
    const ExrChannel *c = exr_layers_channel(L, name);
    if (!c || c->type != SPT_EXR_FLOAT)
        fail_msg("%s: no float channel %s", base, name);
    return (float *)c->data;
}

/* Reads the base checkpoint for an edit. */
static void edit_begin(ExrLayers *L)
{
    SptError e = {0};
    if (exr_read_layers(base, NULL, 0, L, &e))
        fail_msg("%s", e.msg);
}

/* Writes the edited file to name in the test folder, without channel `drop`
 * (NULL: all), keeping the spectrace:* attributes (OpenEXR writes the standard
 * ones itself); returns its path. */
static const char *edit_end(ExrLayers *L, const char *name, const char *drop)
{
    ExrChannel *ch = malloc((size_t)L->channel_count * sizeof *ch);
    int n = 0;
    for (int i = 0; i < L->channel_count; i++)
        if (!drop || strcmp(L->channels[i].name, drop))
            ch[n++] = L->channels[i];
    ExrAttr *at = malloc((size_t)L->attr_count * sizeof *at + 1);
    int na = 0;
    for (int i = 0; i < L->attr_count; i++)
        if (!strncmp(L->attrs[i].name, "spectrace:", 10))
            at[na++] = L->attrs[i];
    const char *p = test_path(name);
    SptError e = {0};
    if (exr_write_layers(p, L->width, L->height, ch, n, at, na, &e))
        fail_msg("%s", e.msg);
    free(ch);
    free(at);
    exr_layers_free(L);
    return p;
}

static int setup(void **state)
{
    (void)state;
    if (test_dir_make("spt-hckpt"))
        return -1;
    snprintf(base, sizeof base, "%s/base_ck.exr", test_dir());
    char args[1024], err[8192];
    snprintf(args, sizeof args, ARGS " --spp 4 -o %s/base.exr --checkpoint %s", test_dir(), base);
    int rc = run_exe("", "", args, err, sizeof err);
    if (rc)
        fprintf(stderr, "setup: exit %d: %s\n", rc, err);
    return rc ? -1 : 0;
}

/* The control: the file read and written again unchanged resumes, to the image
 * of the render of 8 spp in one go, so the refusals below come from the edits
 * and not from the rewriting. */
TEST(test_rewritten_unchanged_resumes)
{
    ExrLayers L;
    edit_begin(&L);
    const char *p = edit_end(&L, "same_ck.exr", NULL);
    char args[1024], err[8192];
    snprintf(args, sizeof args, ARGS " --spp 8 -o %s --resume %s", test_path("resumed.exr"), p);
    if (run_exe("", "", args, err, sizeof err))
        fail_msg("resume from the rewritten checkpoint failed:\n%s", err);
    snprintf(args, sizeof args, ARGS " --spp 8 -o %s", test_path("straight.exr"));
    if (run_exe("", "", args, err, sizeof err))
        fail_msg("render failed:\n%s", err);
    assert_same_exr(test_path("straight.exr"), test_path("resumed.exr"));
}

/* A render whose pixel (0, 0) drops every sample (the test hook
 * SPECTRACE_TEST_INJECT_NAN makes its radiance NaN) writes a checkpoint with a
 * count of 0 there, which the cross-checks must accept: it resumes. */
TEST(test_dropped_samples_resume)
{
    char args[1024], err[8192];
    const char *ck = test_path("nan_ck.exr");
    snprintf(args, sizeof args, ARGS " --spp 4 -o %s --checkpoint %s", test_path("nan.exr"), ck);
    if (run_exe("SPECTRACE_TEST_INJECT_NAN=1", "", args, err, sizeof err))
        fail_msg("render failed:\n%s", err);
    ExrLayers L;
    SptError e = {0};
    if (exr_read_layers(ck, NULL, 0, &L, &e))
        fail_msg("%s", e.msg);
    assert_int_equal(((const uint32_t *)exr_layers_channel(&L, "count")->data)[0], 0);
    assert_int_equal(((const uint32_t *)exr_layers_channel(&L, "count")->data)[1], 4);
    exr_layers_free(&L);
    snprintf(args, sizeof args, ARGS " --spp 8 -o %s --resume %s", test_path("nan8.exr"), ck);
    if (run_exe("SPECTRACE_TEST_INJECT_NAN=1", "", args, err, sizeof err))
        fail_msg("resume of a checkpoint with a pixel of no samples failed:\n%s", err);
}

/* Every pixel's sample count set to 0, the sums kept: resumed, it would add the
 * old sums to the new samples' count (an image 2x too bright), or to the same
 * spp give a black image. Single process and over MPI (the ranks' rank 0 reads
 * the checkpoint through the same code). */
TEST(test_count_zero)
{
    ExrLayers L;
    edit_begin(&L);
    const ExrChannel *c = exr_layers_channel(&L, "count");
    assert_non_null(c);
    memset((void *)c->data, 0, (size_t)L.width * L.height * sizeof(uint32_t));
    const char *p = edit_end(&L, "count0_ck.exr", NULL);
    refused(p, "count is 0");
    /* A count of 3 of the 4 samples: plausible (a dropped sample), so only the
     * checksum sees it. */
    edit_begin(&L);
    c = exr_layers_channel(&L, "count");
    for (int i = 0; i < L.width * L.height; i++)
        ((uint32_t *)c->data)[i] = 3;
    refused(edit_end(&L, "count3_ck.exr", NULL), "checksum");
    char mpi[1024];
    snprintf(mpi, sizeof mpi, "%s-mpi", test_exe());
    if (!test_exists(mpi) || system("command -v mpirun >/dev/null 2>&1")) {
        print_message("  the MPI case left out: %s or mpirun missing (make mpi)\n", mpi);
        skip();
    }
    refused_via("mpirun --allow-run-as-root --oversubscribe -n 2", "-mpi", p, "count is 0");
}

/* One spectral band's channels deleted from a --spectral 2 checkpoint. */
TEST(test_band_removed)
{
    ExrLayers L;
    edit_begin(&L);
    const char *p = edit_end(&L, "band_ck.exr", "band_sum.001");
    refused(p, "band_sum.001");
}

/* Sums of 1e38: a float the file can hold, far beyond what 4 samples give. */
TEST(test_huge_sums)
{
    ExrLayers L;
    edit_begin(&L);
    size_t n = (size_t)L.width * L.height;
    float *x = chan_f(&L, "sum.X"), *y = chan_f(&L, "sum.Y"), *z = chan_f(&L, "sum.Z");
    for (size_t i = 0; i < n; i++)
        x[i] = y[i] = z[i] = 1e38f;
    refused(edit_end(&L, "huge_ck.exr", NULL), "damaged checkpoint");
}

/* A negative band sum (radiance is never negative), and an albedo sum of -100
 * over 4 samples (no reflectance in [0, 1] gives a linear sRGB component below
 * -0.484). */
TEST(test_negative_sums)
{
    ExrLayers L;
    edit_begin(&L);
    chan_f(&L, "band_sum.000")[5] = -1.0f;
    refused(edit_end(&L, "negband_ck.exr", NULL), "negative");
    edit_begin(&L);
    chan_f(&L, "aov_sum.albedo.G")[9] = -100.0f;
    refused(edit_end(&L, "negalbedo_ck.exr", NULL), "albedo.G is below what any reflectance gives");
}

/* One value changed in one bit, everything else plausible: only the checksum
 * sees it. */
TEST(test_one_flipped_bit)
{
    ExrLayers L;
    edit_begin(&L);
    float *y = chan_f(&L, "sum.Y");
    uint32_t bits;
    memcpy(&bits, &y[27], 4);
    bits ^= 1u;
    memcpy(&y[27], &bits, 4);
    refused(edit_end(&L, "flip_ck.exr", NULL), "checksum");
    /* The sign bit (the top bit of its word) of a normal's sum, which may be
     * negative. */
    edit_begin(&L);
    float *nx = chan_f(&L, "aov_sum.N.X");
    nx[12] = -nx[12];
    refused(edit_end(&L, "flip_sign_ck.exr", NULL), "checksum");
}

/* A checkpoint of the format before the checksum (version 1): refused, saying
 * to render again (docs/outputs.md, "Checkpoints"). */
TEST(test_old_format)
{
    ExrLayers L;
    edit_begin(&L);
    int found = 0;
    for (int i = 0; i < L.attr_count; i++)
        if (!strcmp(L.attrs[i].name, "spectrace:checkpoint")) {
            L.attrs[i].i = 1;
            found = 1;
        }
    assert_true(found);
    refused(edit_end(&L, "v1_ck.exr", NULL), "render it again");
}

/* The cross-checks hold where the checksum is right: checkpoint_write gives
 * these implausible films a valid checksum, and checkpoint_read refuses them. */
TEST(test_cross_checks)
{
    RenderSettings rs = test_settings(2, 2, 0, -1, 0);
    rs.aov = SPT_AOV_ALBEDO;
    rs.spectral = 2;
    CheckpointKey k;
    SptError e = {0};
    assert_int_equal(checkpoint_key(&k, SCENE, &rs, &e), 0);
    /* The same without AOVs: a count of 0 shows in the band sums. */
    CheckpointKey k_bands;
    rs.aov = 0;
    assert_int_equal(checkpoint_key(&k_bands, SCENE, &rs, &e), 0);
    unsigned char done[4] = {1, 1, 1, 1};
    const char *p = test_path("api_ck.exr");
    static const char *const says[5] = {NULL, "band_sum.001 is negative", "count is 0",
                                        "band_sum.001 missing", "count is 0"};
    for (int attack = 0; attack < 5; attack++) {
        const CheckpointKey *key = attack == 4 ? &k_bands : &k;
        Film f;
        film_init_full(&f, 2, 2, attack != 4, attack == 3 ? 1 : 2);
        for (int i = 0; i < 4; i++) {
            f.count[i] = 4;
            for (int c = 0; c < 3; c++) {
                f.xyz[3 * i + c] = 1.0 + i;
                if (f.aov)
                    f.aov[SPT_AOV_SUMS * i + c] = 1.0 + i;
            }
            for (int b = 0; b < f.bands; b++)
                f.spec[f.bands * i + b] = 0.5;
        }
        if (attack == 1)
            f.spec[2 * 3 + 1] = -0.25;
        if (attack == 2 || attack == 4)
            f.count[2] = 0;
        assert_int_equal(checkpoint_write(p, key, &f, done, 4, &e), 0);
        film_free(&f);
        Film g;
        unsigned char *d = NULL;
        int rc = checkpoint_read(p, key, 4, &g, &d, &e);
        if (!says[attack]) {
            if (rc)
                fail_msg("the plausible film is refused: %s", e.msg);
            film_free(&g);
            free(d);
            continue;
        }
        printf("%s\n", e.msg);
        assert_int_equal(rc, SPT_EXIT_INPUT);
        assert_non_null(strstr(e.msg, p));
        assert_non_null(strstr(e.msg, says[attack]));
        assert_null(g.xyz);
        assert_null(d);
    }
}

/* Case 15: a resume with other settings names each option and both values as
 * the user types them, never the numbers the key stores. */
TEST(test_mismatch_names_values)
{
    static const char *const extra[4] = {"--caustics on", "--sampler independent",
                                         "--aov albedo,N", "--denoise"};
    static const char *const says[4] = {
        "--caustics on here, auto in the checkpoint",
        "--sampler independent here, sobol in the checkpoint",
        "--aov albedo,N here, albedo in the checkpoint",
        "--denoise given here, not given in the checkpoint"};
    /* Where Open Image Denoise cannot load, --denoise is refused for that
     * (exit 2) before the checkpoint is read: that case needs it. */
    Denoiser d;
    oidn_probe(&d);
    if (have_oidn)
        denoiser_close(&d);
    for (int i = 0; i < 4; i++) {
        char args[1024], err[8192];
        if (i == 3 && !have_oidn) {
            print_message("  --denoise case skipped: Open Image Denoise not installed\n");
            continue;
        }
        snprintf(args, sizeof args, ARGS " %s --spp 8 -o %s --resume %s", extra[i],
                 test_path("refused.exr"), base);
        int rc = run_exe("", "", args, err, sizeof err);
        printf("%s", err);
        const char *nl = strchr(err, '\n');
        if (rc != SPT_EXIT_INPUT || strncmp(err, "error: ", 7) || !nl || nl[1] ||
            !strstr(err, says[i]))
            fail_msg("`%s`: exit %d, expected 3 and one error line saying '%s'; got:\n%s",
                     extra[i], rc, says[i], err);
    }
}

TEST_MAIN_ENV("hostile_checkpoint", setup, test_dir_teardown,
              "POCL_DEVICES=pthread", "POCL_MAX_PTHREAD_COUNT=1",
              "SPECTRACE_POOL=512")
