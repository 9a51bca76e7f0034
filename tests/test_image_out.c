/* src/io/image_out.c, src/io/exr.c, src/io/image_io.cpp: image files, display transforms,
 * atomic writes and their failures. Files are read back with OpenImageIO (an
 * independent reader of what OpenEXRCore and our display transform wrote). */
#include "test_util.h"

#include <dirent.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/atomic_file.h"
#include "io/exr.h"
#include "io/image_io.h"
#include "io/image_out.h"
#include "io/image_in.h"

/* A fresh folder per test (test_dir()), removed (with its files) afterwards. */
static int setup(void **state)
{
    atomic_test_fail_commits = 0;
    return test_dir_setup(state);
}

static int teardown(void **state)
{
    atomic_test_fail_commits = 0;
    return test_dir_teardown(state);
}

/* Number of entries of test_dir() whose name contains the temporary-file mark. */
static int temp_files_left(void)
{
    DIR *d = opendir(test_dir());
    assert_non_null(d);
    int n = 0;
    struct dirent *de;
    while ((de = readdir(d)))
        if (strstr(de->d_name, SPT_ATOMIC_TEMP_MARK)) {
            print_message("left behind: %s\n", de->d_name);
            n++;
        }
    closedir(d);
    return n;
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

static void assert_attr(const char *path, const char *name, const char *want)
{
    char got[512];
    SptError e = {0};
    int found = image_io_attr(path, name, got, sizeof got, &e);
    if (found != 1)
        fail_msg("%s: attribute %s missing (%d) %s", path, name, found, e.msg);
    if (strcmp(got, want))
        fail_msg("%s: attribute %s = '%s', expected '%s'", path, name, got, want);
}

/* Writes rgb (w x h) to path with meta and reads its description back, which
 * must name the file format format_name and the pixel format format (when not
 * NULL). */
static ImageIoInfo write_image(const char *path, const float *rgb, int w, int h,
                               const ImageMeta *meta, const char *format_name, const char *format)
{
    SptError e = {0};
    if (image_write(path, rgb, w, h, meta, NULL, &e))
        fail_msg("%s", e.msg);
    ImageIoInfo info;
    assert_int_equal(image_io_info(path, &info, &e), SPT_EXIT_OK);
    assert_string_equal(info.format_name, format_name);
    if (format)
        assert_string_equal(info.format, format);
    return info;
}

/* ------------------------------------------------------------------------- */

TEST_FIXTURE(test_exr_roundtrip_read_by_oiio, setup, teardown)
{
    enum { W = 4, H = 3 };
    float rgb[W * H * 3];
    /* Values that a half-float or lossy path would change. */
    for (int i = 0; i < W * H * 3; ++i)
        rgb[i] = (float)(i + 1) * 0.1234567f - 1.0f;
    rgb[0] = 1e-8f;
    rgb[5] = 123456.7f;
    ImageMeta meta = {.spp = 64, .render_seconds = 1.5, .device = "test device",
                      .seed = 4000000000u, .scene = "scenes/box.gltf"};
    assert_int_equal(image_meta_add(&meta, "integrator", "path"), 0);
    const char *path = test_path("out.exr");
    SptError e = {0};
    ImageIoInfo info = write_image(path, rgb, W, H, &meta, "openexr", "float");
    assert_int_equal(info.width, W);
    assert_int_equal(info.height, H);
    assert_int_equal(info.channels, 3);
    assert_string_equal(info.channel_names[0], "R");
    assert_string_equal(info.channel_names[1], "G");
    assert_string_equal(info.channel_names[2], "B");

    float *back = NULL;
    int w, h, ch;
    assert_int_equal(image_io_read(path, &back, &w, &h, &ch, &e), SPT_EXIT_OK);
    assert_int_equal(w * h * ch, W * H * 3);
    for (int i = 0; i < W * H * 3; ++i)
        if (back[i] != rgb[i])
            fail_msg("value %d: read %.9g, wrote %.9g", i, back[i], rgb[i]);
    free(back);

    assert_attr(path, "spectrace:spp", "64");
    assert_attr(path, "spectrace:renderSeconds", "1.5");
    assert_attr(path, "spectrace:device", "test device");
    assert_attr(path, "spectrace:seed", "4000000000");
    assert_attr(path, "spectrace:scene", "scenes/box.gltf");
    assert_attr(path, "spectrace:integrator", "path");
    assert_int_equal(temp_files_left(), 0);
}

/* Linear values and their 8-bit sRGB codes, computed by hand from docs/architecture.md:
 * C <= 0.0031308 -> 12.92 C, else 1.055 C^(1/2.4) - 0.055; code = round(255 clamp).
 *   0          -> 0
 *   0.001      -> 255 * 0.01292 = 3.29                      -> 3
 *   0.0031308  -> 255 * 0.040450 = 10.31                    -> 10
 *   0.18       -> 255 * (1.055 * 0.18^0.41667 - 0.055) = 117.65  -> 118
 *   0.25       -> 255 * 0.53710 = 136.96                    -> 137
 *   0.5        -> 255 * 0.73536 = 187.52                    -> 188
 *   1          -> 255;  2 -> 255 (clamped);  NaN -> 0;  -0.5 -> 0 */
static const float k_lin[] = {0.0f, 0.001f, 0.0031308f, 0.18f, 0.25f, 0.5f, 1.0f, 2.0f, NAN,
                              -0.5f, 0.5f, 0.25f};
static const int k_code[] = {0, 3, 10, 118, 137, 188, 255, 255, 0, 0, 188, 137};

TEST_FIXTURE(test_png_srgb_codes, setup, teardown)
{
    enum { W = 2, H = 2 }; /* 4 pixels = the 12 values above */
    const char *path = test_path("codes.png");
    SptError e = {0};
    ImageMeta meta = {.spp = 4, .seed = 7};
    write_image(path, k_lin, W, H, &meta, "png", "uint8");
    assert_attr(path, "spectrace:spp", "4");
    /* Tagged sRGB: the PNG specification's sRGB chunk (length 1, type "sRGB") is
     * present in the bytes, before the image data. */
    size_t size;
    unsigned char *png = (unsigned char *)test_slurp(path, &size);
    const unsigned char *srgb = memmem(png, size, "\0\0\0\1sRGB", 8);
    const unsigned char *idat = memmem(png, size, "IDAT", 4);
    assert_non_null(srgb);
    assert_non_null(idat);
    assert_true(srgb < idat);
    free(png);

    float *back = NULL;
    int w, h, ch;
    assert_int_equal(image_io_read(path, &back, &w, &h, &ch, &e), SPT_EXIT_OK);
    assert_int_equal(ch, 3);
    for (int i = 0; i < W * H * 3; ++i) {
        int code = (int)lroundf(back[i] * 255.0f);
        if (code != k_code[i])
            fail_msg("linear %g: 8-bit %d, expected %d", k_lin[i], code, k_code[i]);
    }
    free(back);
}

TEST_FIXTURE(test_exposure_doubles_linear, setup, teardown)
{
    DisplayOptions plus1 = {1.0f, SPT_TONEMAP_NONE}, minus1 = {-1.0f, SPT_TONEMAP_NONE};
    uint8_t out[3];
    float quarter[3] = {0.25f, 0.25f, 0.25f}, one[3] = {1, 1, 1}, zero[3] = {0, 0, 0};
    image_display_pixel(quarter, NULL, out);
    assert_int_equal(out[0], 137); /* 0.25 as is (see the table above) */
    image_display_pixel(quarter, &plus1, out);
    assert_int_equal(out[0], 188); /* 0.25 * 2 = 0.5 */
    image_display_pixel(one, &minus1, out);
    assert_int_equal(out[1], 188); /* 1 / 2 = 0.5 */
    image_display_pixel(zero, &plus1, out);
    assert_int_equal(out[2], 0);

    /* Through a file: an image of 0.25 written at +1 EV reads back as 0.5's code. */
    const char *path = test_path("ev.png");
    float img[4 * 3];
    for (int i = 0; i < 12; ++i)
        img[i] = 0.25f;
    SptError e = {0};
    assert_int_equal(image_write(path, img, 2, 2, NULL, &plus1, &e), SPT_EXIT_OK);
    float *back = NULL;
    int w, h;
    assert_int_equal(image_read_rgb(path, &back, &w, &h, &e), SPT_EXIT_OK);
    assert_int_equal((int)lroundf(back[0] * 255.0f), 188);
    free(back);

    /* Linear formats ignore exposure and tone map. */
    const char *exr = test_path("ev.exr");
    DisplayOptions both = {3.0f, SPT_TONEMAP_NEUTRAL};
    assert_int_equal(image_write(exr, img, 2, 2, NULL, &both, &e), SPT_EXIT_OK);
    assert_int_equal(image_read_rgb(exr, &back, &w, &h, &e), SPT_EXIT_OK);
    assert_true(back[0] == 0.25f && back[11] == 0.25f);
    free(back);
}

/* Khronos PBR Neutral at a few points, evaluated separately (Python, from the
 * specification's equations in the KhronosGroup/ToneMapping README):
 *   (0,0,0)          -> (0,0,0)
 *   (0.5,0.5,0.5)    -> (0.46,0.46,0.46)           p <= Ks: c - 0.04
 *   (0.04,0.2,0.6)   -> (0.01,0.17,0.57)           f = 0.04 - 0.04^2/0.16 = 0.03
 *   (1,1,1)          -> 1 - 0.0576/0.44 = 0.869090909 (grey stays grey at pn)
 *   (2,0.5,0.05)     -> (0.960155642, 0.323470556, 0.132465030)
 *   (10,1,0.1)       -> (0.993898305, 0.610899015, 0.572599086) */
TEST_FIXTURE(test_tonemap_neutral_values, setup, teardown)
{
    static const float in[][3] = {{0, 0, 0}, {0.5f, 0.5f, 0.5f}, {0.04f, 0.2f, 0.6f},
                                  {1, 1, 1}, {2, 0.5f, 0.05f},   {10, 1, 0.1f}};
    static const double want[][3] = {{0, 0, 0},
                                     {0.46, 0.46, 0.46},
                                     {0.01, 0.17, 0.57},
                                     {0.869090909, 0.869090909, 0.869090909},
                                     {0.960155642, 0.323470556, 0.132465030},
                                     {0.993898305, 0.610899015, 0.572599086}};
    for (size_t k = 0; k < sizeof in / sizeof in[0]; ++k) {
        float out[3];
        image_tonemap_neutral(in[k], out);
        for (int c = 0; c < 3; ++c)
            assert_close(out[c], want[k][c], 2e-6);
    }
    /* Out-of-domain input stays defined: NaN and negatives count as 0, inf -> white. */
    float odd[3] = {NAN, -1.0f, INFINITY}, out[3];
    image_tonemap_neutral(odd, out);
    assert_true(out[0] == 1.0f && out[1] == 1.0f && out[2] == 1.0f);
    float neg[3] = {-1.0f, NAN, 0.0f};
    image_tonemap_neutral(neg, out);
    assert_true(out[0] == 0.0f && out[1] == 0.0f && out[2] == 0.0f);

    /* Display path: exposure, then tone map, then sRGB. (0.5,0.5,0.5) at +1 EV is
     * (1,1,1) -> 0.869090909 -> 255 * (1.055 * 0.86909^(1/2.4) - 0.055) = 239.6 -> 240. */
    DisplayOptions d = {1.0f, SPT_TONEMAP_NEUTRAL};
    float half[3] = {0.5f, 0.5f, 0.5f};
    uint8_t px[3];
    image_display_pixel(half, &d, px);
    assert_int_equal(px[0], 240);

    int t = -1;
    assert_int_equal(image_tonemap_parse("Neutral", &t), 0);
    assert_int_equal(t, SPT_TONEMAP_NEUTRAL);
    assert_int_equal(image_tonemap_parse("none", &t), 0);
    assert_int_equal(t, SPT_TONEMAP_NONE);
    assert_int_equal(image_tonemap_parse("aces", &t), -1);
}

TEST_FIXTURE(test_tiff_float_and_hdr, setup, teardown)
{
    float rgb[2 * 2 * 3] = {0.1f, 0.2f, 0.3f, 1.5f, 2.5f, 3.5f, 100.0f, 0.01f, 0.5f,
                            0.0f, 0.75f, 7.0f};
    SptError e = {0};
    const char *tif = test_path("out.tif");
    write_image(tif, rgb, 2, 2, NULL, "tiff", "float");
    float *back = NULL;
    int w, h;
    assert_int_equal(image_read_rgb(tif, &back, &w, &h, &e), SPT_EXIT_OK);
    assert_memory_equal(back, rgb, sizeof rgb);
    free(back);

    const char *hdr = test_path("out.HDR"); /* extensions are case-insensitive */
    write_image(hdr, rgb, 2, 2, NULL, "hdr", NULL);
    assert_int_equal(image_read_rgb(hdr, &back, &w, &h, &e), SPT_EXIT_OK);
    /* RGBE: an 8-bit mantissa (>= 128 for the largest channel) and a shared exponent:
     * truncation error below one step, at most max / 128. */
    for (int p = 0; p < 4; ++p) {
        float m = fmaxf(rgb[3 * p], fmaxf(rgb[3 * p + 1], rgb[3 * p + 2]));
        for (int c = 0; c < 3; ++c)
            assert_close(back[3 * p + c], rgb[3 * p + c], m / 128.0f);
    }
    free(back);

    const char *jpg = test_path("out.jpeg");
    float grey[8 * 8 * 3];
    for (int i = 0; i < 8 * 8 * 3; ++i)
        grey[i] = 0.5f;
    assert_int_equal(image_write(jpg, grey, 8, 8, NULL, NULL, &e), SPT_EXIT_OK);
    assert_int_equal(image_read_rgb(jpg, &back, &w, &h, &e), SPT_EXIT_OK);
    assert_close(back[0] * 255.0f, 188, 2.0); /* lossy, but flat grey survives */
    free(back);
    assert_int_equal(temp_files_left(), 0);
}

TEST_FIXTURE(test_output_check_failures, setup, teardown)
{
    SptError e = {0};
    assert_int_equal(image_output_check(test_path("ok.exr"), &e), SPT_EXIT_OK);
    assert_int_equal(image_output_check(test_path("ok.JPG"), &e), SPT_EXIT_OK);

    const char *unknown = test_path("out.bmp");
    assert_int_equal(image_output_check(unknown, &e), SPT_EXIT_USAGE);
    assert_non_null(strstr(e.msg, unknown));
    assert_int_equal(image_output_check(test_path("noextension"), &e), SPT_EXIT_USAGE);
    float px[3] = {0, 0, 0};
    assert_int_equal(image_write(unknown, px, 1, 1, NULL, NULL, &e), SPT_EXIT_USAGE);

    const char *missing = test_path("no/such/folder/out.png");
    assert_int_equal(image_output_check(missing, &e), SPT_EXIT_OUTPUT);
    assert_non_null(strstr(e.msg, missing));
    assert_non_null(strstr(e.msg, "does not exist"));
    assert_int_equal(image_write(missing, px, 1, 1, NULL, NULL, &e), SPT_EXIT_OUTPUT);
    assert_non_null(strstr(e.msg, missing));
    assert_int_equal(image_write(test_path("no/out.exr"), px, 1, 1, NULL, NULL, &e),
                     SPT_EXIT_OUTPUT);

    write_bytes(test_path("plainfile"), "x", 1);
    const char *under_file = test_path("plainfile/out.png");
    assert_int_equal(image_output_check(under_file, &e), SPT_EXIT_OUTPUT);
    assert_non_null(strstr(e.msg, under_file));
    assert_non_null(strstr(e.msg, "not a folder"));

    /* Sizes, once the resolution is known. */
    assert_int_equal(image_output_check_size(test_path("a.exr"), 100000, 2, &e), SPT_EXIT_OK);
    assert_int_equal(image_output_check_size(test_path("a.jpg"), 65500, 65500, &e), SPT_EXIT_OK);
    assert_int_equal(image_output_check_size(test_path("a.jpg"), 65501, 1, &e), SPT_EXIT_OUTPUT);
    assert_int_equal(image_output_check_size(test_path("a.png"), 0, 5, &e), SPT_EXIT_OUTPUT);
    assert_int_equal(image_output_check_size(test_path("a.gif"), 5, 5, &e), SPT_EXIT_USAGE);

    /* Bad checkpoint definitions are refused before any file is made. */
    float one = 1.0f;
    ExrChannel twice[2] = {{"n", SPT_EXR_FLOAT, &one, 1}, {"n", SPT_EXR_FLOAT, &one, 1}};
    assert_int_equal(exr_write_layers(test_path("twice.exr"), 1, 1, twice, 2, NULL, 0, &e),
                     SPT_EXIT_OUTPUT);
    assert_non_null(strstr(e.msg, "given twice"));

    ImageMeta meta = {0};
    for (int i = 0; i < SPT_IMAGE_META_MAX_EXTRA; ++i)
        assert_int_equal(image_meta_add(&meta, "k", "v"), 0);
    assert_int_equal(image_meta_add(&meta, "k", "v"), -1);

    assert_int_equal(mkdir(test_path("folder.png"), 0755), 0);
    assert_int_equal(image_output_check(test_path("folder.png"), &e), SPT_EXIT_OUTPUT);
    assert_non_null(strstr(e.msg, "is a folder"));
    assert_int_equal(image_write(test_path("folder.png"), px, 1, 1, NULL, NULL, &e),
                     SPT_EXIT_OUTPUT);

    assert_int_equal(temp_files_left(), 0);
}

TEST_FIXTURE(test_read_only_folder, setup, teardown)
{
    if (geteuid() == 0) {
        print_message("  run as root, which writes into a read-only folder anyway: skipped\n");
        skip();
    }
    assert_int_equal(mkdir(test_path("ro"), 0555), 0);
    SptError e = {0};
    const char *path = test_path("ro/out.png");
    assert_int_equal(image_output_check(path, &e), SPT_EXIT_OUTPUT);
    assert_non_null(strstr(e.msg, path));
    chmod(test_path("ro"), 0755);
}

/* Writes the w x h image px to path, which must succeed, and returns the
 * file's bytes (*n of them): the output a failed write must keep. */
static char *write_and_slurp(const char *path, const float *px, int w, int h, size_t *n)
{
    SptError e = {0};
    assert_int_equal(image_write(path, px, w, h, NULL, NULL, &e), SPT_EXIT_OK);
    return test_slurp(path, n);
}

/* A failed write leaves an existing output byte for byte as it was and no
 * temporary file, for every writer. */
TEST_FIXTURE(test_failed_write_keeps_existing_output, setup, teardown)
{
    const char *names[] = {"keep.png", "keep.exr", "keep.tif", "keep.hdr", "keep.jpg"};
    float a[4 * 3], b[4 * 3];
    for (int i = 0; i < 12; ++i)
        a[i] = 0.2f, b[i] = 0.9f;
    for (size_t k = 0; k < sizeof names / sizeof names[0]; ++k) {
        const char *path = test_path(names[k]);
        SptError e = {0};
        size_t n0;
        char *before = write_and_slurp(path, a, 2, 2, &n0);

        atomic_test_fail_commits = 1;
        int rc = image_write(path, b, 2, 2, NULL, NULL, &e);
        atomic_test_fail_commits = 0;
        assert_int_equal(rc, SPT_EXIT_OUTPUT);
        assert_non_null(strstr(e.msg, path));
        assert_non_null(strstr(e.msg, "injected failure"));

        test_assert_file_is(path, before, n0);


        free(before);
        assert_int_equal(temp_files_left(), 0);
    }

    /* A JPEG wider than libjpeg allows is refused before libjpeg sees it (libjpeg
     * would end the process). */
    const char *jpg = test_path("keep.jpg");
    size_t n0;
    char *before = test_slurp(jpg, &n0);
    float *wide = calloc((size_t)70000 * 3, sizeof(float));
    SptError e = {0};
    assert_int_equal(image_write(jpg, wide, 70000, 1, NULL, NULL, &e), SPT_EXIT_OUTPUT);
    assert_non_null(strstr(e.msg, jpg));
    free(wide);
    test_assert_file_is(jpg, before, n0);

    free(before);
    assert_int_equal(temp_files_left(), 0);
}

/* A real write failure in every encoder, as on a full disk: the file size limit
 * (RLIMIT_FSIZE) makes write() fail with EFBIG once a file reaches 2 KiB. Noise
 * does not compress, so every format needs more than that. */
TEST_FIXTURE(test_disk_full_keeps_existing_output, setup, teardown)
{
    enum { W = 64, H = 64 };
    static float noise[W * H * 3];
    uint32_t x = 12345;
    for (int i = 0; i < W * H * 3; ++i) {
        x = x * 1664525u + 1013904223u;
        noise[i] = (float)(x >> 8) / 16777216.0f;
    }
    const char *names[] = {"full.png", "full.exr", "full.tif", "full.hdr", "full.jpg"};
    float small[3] = {0.5f, 0.5f, 0.5f};
    void (*old_handler)(int) = signal(SIGXFSZ, SIG_IGN);
    struct rlimit old_limit;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
    for (size_t k = 0; k < sizeof names / sizeof names[0]; ++k) {
        const char *path = test_path(names[k]);
        SptError e = {0};
        size_t n0;
        char *before = write_and_slurp(path, small, 1, 1, &n0);

        struct rlimit lim = old_limit;
        lim.rlim_cur = 2048;
        assert_int_equal(setrlimit(RLIMIT_FSIZE, &lim), 0);
        int rc = image_write(path, noise, W, H, NULL, NULL, &e);
        assert_int_equal(setrlimit(RLIMIT_FSIZE, &old_limit), 0);
        if (rc != SPT_EXIT_OUTPUT)
            fail_msg("%s: write beyond the file size limit returned %d", names[k], rc);
        assert_non_null(strstr(e.msg, path));
        print_message("%s: %s\n", names[k], e.msg);

        test_assert_file_is(path, before, n0);


        free(before);
        assert_int_equal(temp_files_left(), 0);
    }
    signal(SIGXFSZ, old_handler);
}

/* A checkpoint-like file: three interleaved float sums and an exact uint count. */
static void write_checkpoint(const char *path, int w, int h, float *sums, uint32_t *counts)
{
    for (int i = 0; i < w * h; ++i) {
        sums[3 * i + 0] = 0.5f * (float)i;
        sums[3 * i + 1] = 1e6f + (float)i; /* large sums must survive exactly */
        sums[3 * i + 2] = -0.25f * (float)i;
        counts[i] = 4000000000u - (uint32_t)i; /* beyond float's exact integers */
    }
    ExrChannel ch[4] = {
        {"sum.X", SPT_EXR_FLOAT, sums + 0, 3},
        {"sum.Y", SPT_EXR_FLOAT, sums + 1, 3},
        {"sum.Z", SPT_EXR_FLOAT, sums + 2, 3},
        {"count", SPT_EXR_UINT, counts, 0},
    };
    ExrAttr at[3] = {
        {"spectrace:scene", SPT_EXR_ATTR_STRING, "scenes/box.gltf", 0, 0},
        {"spectrace:samplesDone", SPT_EXR_ATTR_INT, NULL, 123, 0},
        {"spectrace:seconds", SPT_EXR_ATTR_DOUBLE, NULL, 0, 12.625},
    };
    SptError e = {0};
    int rc = exr_write_layers(path, w, h, ch, 4, at, 3, &e);
    if (rc)
        fail_msg("%s", e.msg);
}

TEST_FIXTURE(test_exr_layers_roundtrip, setup, teardown)
{
    enum { W = 5, H = 37 }; /* more rows than one ZIP chunk (16) */
    static float sums[W * H * 3];
    static uint32_t counts[W * H];
    const char *path = test_path("ckpt.exr");
    write_checkpoint(path, W, H, sums, counts);

    const char *req[] = {"sum.X", "sum.Y", "sum.Z", "count"};
    ExrLayers l;
    SptError e = {0};
    int rc = exr_read_layers(path, req, 4, &l, &e);
    if (rc)
        fail_msg("%s", e.msg);
    assert_int_equal(l.width, W);
    assert_int_equal(l.height, H);
    assert_int_equal(l.channel_count, 4);
    const char *xyz[3] = {"sum.X", "sum.Y", "sum.Z"};
    for (int c = 0; c < 3; ++c) {
        const ExrChannel *ch = exr_layers_channel(&l, xyz[c]);
        assert_non_null(ch);
        assert_int_equal(ch->type, SPT_EXR_FLOAT);
        const float *v = ch->data;
        for (int i = 0; i < W * H; ++i)
            if (v[i] != sums[3 * i + c])
                fail_msg("%s[%d] = %.9g, wrote %.9g", xyz[c], i, v[i], sums[3 * i + c]);
    }
    const ExrChannel *cnt = exr_layers_channel(&l, "count");
    assert_non_null(cnt);
    assert_int_equal(cnt->type, SPT_EXR_UINT);
    assert_memory_equal(cnt->data, counts, sizeof counts);
    const ExrAttr *a = exr_layers_attr(&l, "spectrace:scene", SPT_EXR_ATTR_STRING);
    assert_non_null(a);
    assert_string_equal(a->s, "scenes/box.gltf");
    a = exr_layers_attr(&l, "spectrace:samplesDone", SPT_EXR_ATTR_INT);
    assert_non_null(a);
    assert_int_equal(a->i, 123);
    a = exr_layers_attr(&l, "spectrace:seconds", SPT_EXR_ATTR_DOUBLE);
    assert_non_null(a);
    assert_true(a->d == 12.625);
    assert_null(exr_layers_attr(&l, "spectrace:seconds", SPT_EXR_ATTR_INT));
    exr_layers_free(&l);

    /* OpenImageIO sees the same channels and the uint type. */
    ImageIoInfo info;
    assert_int_equal(image_io_info(path, &info, &e), SPT_EXIT_OK);
    assert_int_equal(info.channels, 4);
    assert_int_equal(info.height, H);

    /* A file without an expected channel is refused, naming it. */
    const char *req2[] = {"sum.X", "weight"};
    assert_int_equal(exr_read_layers(path, req2, 2, &l, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "weight"));
    assert_non_null(strstr(e.msg, path));
    assert_int_equal(l.channel_count, 0);

    /* Injected failure: the checkpoint already there stays as it was. */
    size_t n0;
    char *before = test_slurp(path, &n0);
    atomic_test_fail_commits = 1;
    ExrChannel one = {"count", SPT_EXR_UINT, counts, 1};
    rc = exr_write_layers(path, W, H, &one, 1, NULL, 0, &e);
    atomic_test_fail_commits = 0;
    assert_int_equal(rc, SPT_EXIT_OUTPUT);
    test_assert_file_is(path, before, n0);

    free(before);
    assert_int_equal(temp_files_left(), 0);
}

/* Barely compressible pixels, as a render with few samples has: noise in
 * [0.25, 0.5) with a fraction f of the values in [0.5, 0.75) (another exponent, so
 * f sets how well the chunk compresses). Swept over f, the zlib stream of a chunk
 * comes out now shorter, now exactly as long as the pixels, now longer; a chunk of
 * exactly the pixels' size is read as uncompressed pixels, so that case must store
 * them. Every image must read back bit for bit, through our reader and through
 * OpenImageIO, from both writers. 64x16 RGB floats are one ZIP chunk of 12288
 * bytes (5 of these 80 images hit the equal size with Debian 12's zlib). */
TEST_FIXTURE(test_exr_noise_roundtrip, setup, teardown)
{
    enum { W = 64, H = 16, IMAGES = 80 };
    static float rgb[W * H * 3];
    static uint32_t counts[W * H];
    const char *path = test_path("noise.exr");
    uint32_t x = 12345u;
    for (int k = 0; k < IMAGES; k++) {
        float f = 0.09f + 0.0008f * (float)k;
        for (int i = 0; i < W * H * 3; i++) {
            x = x * 1664525u + 1013904223u;
            float u = (float)(x >> 8) * (1.0f / 16777216.0f);
            x = x * 1664525u + 1013904223u;
            float v = (float)(x >> 8) * (1.0f / 16777216.0f);
            rgb[i] = (v < f ? 0.5f : 0.25f) + 0.25f * u;
        }
        for (int i = 0; i < W * H; i++)
            counts[i] = (uint32_t)(rgb[3 * i] * 4096.0f) ^ (uint32_t)i;
        SptError e = {0};
        if (image_write(path, rgb, W, H, NULL, NULL, &e))
            fail_msg("%s", e.msg);
        ExrLayers l;
        if (exr_read_layers(path, NULL, 0, &l, &e))
            fail_msg("%s", e.msg);
        const char *names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; c++) {
            const float *r = exr_layers_channel(&l, names[c])->data;
            for (int i = 0; i < W * H; i++)
                if (memcmp(&r[i], &rgb[3 * i + c], 4))
                    fail_msg("image %d (f = %.4f): %s[%d] read %.9g, wrote %.9g", k, f,
                             names[c], i, r[i], rgb[3 * i + c]);
        }
        exr_layers_free(&l);
        float *back = NULL;
        int bw, bh, bc;
        assert_int_equal(image_io_read(path, &back, &bw, &bh, &bc, &e), SPT_EXIT_OK);
        for (int i = 0; i < W * H * 3; i++)
            if (memcmp(&back[i], &rgb[i], 4))
                fail_msg("image %d (f = %.4f): OpenImageIO read value %d as %.9g, wrote %.9g",
                         k, f, i, back[i], rgb[i]);
        free(back);
        /* The multi-channel writer of checkpoints, with a float and a uint channel. */
        ExrChannel ch[2] = {{"sum.X", SPT_EXR_FLOAT, rgb, 3}, {"count", SPT_EXR_UINT, counts, 1}};
        if (exr_write_layers(path, W, H, ch, 2, NULL, 0, &e))
            fail_msg("%s", e.msg);
        if (exr_read_layers(path, NULL, 0, &l, &e))
            fail_msg("%s", e.msg);
        const float *sx = exr_layers_channel(&l, "sum.X")->data;
        for (int i = 0; i < W * H; i++)
            if (memcmp(&sx[i], &rgb[3 * i], 4))
                fail_msg("layers %d (f = %.4f): sum.X[%d] read %.9g, wrote %.9g", k, f, i, sx[i],
                         rgb[3 * i]);
        assert_memory_equal(exr_layers_channel(&l, "count")->data, counts, sizeof counts);
        exr_layers_free(&l);
    }
    assert_int_equal(temp_files_left(), 0);
}

TEST_FIXTURE(test_exr_damaged_files_refused, setup, teardown)
{
    enum { W = 16, H = 40 };
    static float sums[W * H * 3];
    static uint32_t counts[W * H];
    const char *path = test_path("full.exr");
    write_checkpoint(path, W, H, sums, counts);
    size_t n;
    unsigned char *bytes = (unsigned char *)test_slurp(path, &n);

    /* Cut at several places: inside the header, inside the offset table, and in
     * the pixel data (half, and all but the last byte). */
    size_t cuts[] = {3, 40, n / 2, n - 1};
    for (size_t k = 0; k < sizeof cuts / sizeof cuts[0]; ++k) {
        const char *cut = test_path("cut.exr");
        write_bytes(cut, bytes, cuts[k]);
        ExrLayers l;
        SptError e = {0};
        int rc = exr_read_layers(cut, NULL, 0, &l, &e);
        if (rc != SPT_EXIT_INPUT)
            fail_msg("file cut to %zu of %zu bytes: rc %d, expected refusal", cuts[k], n, rc);
        assert_non_null(strstr(e.msg, cut));
        print_message("cut to %zu bytes: %s\n", cuts[k], e.msg);
    }

    /* Overwrite pixel data in the middle with garbage: ZIP decoding must fail. */
    unsigned char *bad = malloc(n);
    memcpy(bad, bytes, n);
    for (size_t i = n / 2; i < n / 2 + 64 && i < n; ++i)
        bad[i] ^= 0x5a;
    write_bytes(test_path("bad.exr"), bad, n);
    ExrLayers l;
    SptError e = {0};
    int rc = exr_read_layers(test_path("bad.exr"), NULL, 0, &l, &e);
    if (rc == SPT_EXIT_OK)
        exr_layers_free(&l);
    assert_int_equal(rc, SPT_EXIT_INPUT);
    free(bad);
    free(bytes);

    write_bytes(test_path("text.exr"), "not an exr file at all\n", 23);
    assert_int_equal(exr_read_layers(test_path("text.exr"), NULL, 0, &l, &e), SPT_EXIT_INPUT);
    assert_int_equal(exr_read_layers(test_path("absent.exr"), NULL, 0, &l, &e), SPT_EXIT_INPUT);
    assert_non_null(strstr(e.msg, "absent.exr"));
}

TEST_MAIN("image_out", NULL, NULL)
