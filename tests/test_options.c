/* The option list of src/render/render_options.h: every option that changes the
 * image changes the checkpoint key (a resume with another value is refused), and
 * the others leave it alone; the command line parses each example value into
 * the field the list names. */
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "api/render_args.h"
#include "io/exr.h"
#include "io/image_out.h"
#include "render/checkpoint.h"
#include "render/render.h"
#include "scene/sky.h"

#define SCENE "scenes/cornell_box.gltf"

static char env_map[64];

/* A value for each option that takes one, other than its default. A new option
 * of the list needs one here: the test fails until it has. */
static const struct {
    const char *option, *value;
} examples[] = {
    {"output", "x.png"},        {"spp", "64"},
    {"time", "5"},              {"width", "100"},
    {"height", "60"},           {"max-depth", "3"},
    {"seed", "9"},              {"sampler", "independent"},
    {"device", "0"},
    {"exposure", "1.5"},        {"tonemap", "neutral"},
    {"env", env_map},           {"env-rotation", "30"},
    {"env-intensity", "2"},     {"background", "0.5,0.25,1"},
    {"aperture", "0.1"},        {"focus-distance", "2"},
    {"checkpoint", "ck.exr"},   {"checkpoint-every", "5"},
    {"resume", "ck.exr"},       {"caustics", "on"},
    {"aov", "albedo,N"},        {"spectral", "47"},
    {"light-paths", "0.5"},     {"light-tree", "off"},      {"merge", "on"},
    {"adaptive", "on"},
    {"at", "1.25"},             {"animation", "walk"},
    {"camera", "1"},            {"instancing", "off"},
    {"frames", "0:23"},         {"fps", "30"},
};

/* What the list says of each option. */
static const struct {
    const char *option;
    int takes_value;
    unsigned flags;
} rows[] = {
#define ROW(where, kind, type, name, option, short_name, metavar, def, lo, hi, flags, ...) \
    {option, metavar[0] != 0, flags},
    SPT_RENDER_OPTIONS(ROW)
#undef ROW
};

static int setup(void **state)
{
    (void)state;
    snprintf(env_map, sizeof env_map, "/tmp/spectrace_options_%d.exr", (int)getpid());
    float px[4 * 2 * 3];
    for (int i = 0; i < 24; i++)
        px[i] = 0.1f * (float)(i % 7);
    SptError e = {0};
    return exr_write_rgb(env_map, px, 4, 2, NULL, 0, &e) ? -1 : 0;
}

static int teardown(void **state)
{
    (void)state;
    unlink(env_map);
    return 0;
}

static const char *example_of(const char *option)
{
    for (size_t i = 0; i < sizeof examples / sizeof examples[0]; i++)
        if (!strcmp(examples[i].option, option))
            return examples[i].value;
    return NULL;
}

/* The checkpoint key of `spectrace render SCENE` with one more option (NULL:
 * none); the parse must succeed. */
static void key_of(const char *option, const char *value, CheckpointKey *k)
{
    char flag[64];
    char *argv[5] = {"render", SCENE, NULL, NULL, NULL};
    int argc = 2;
    if (option) {
        snprintf(flag, sizeof flag, "--%s", option);
        argv[argc++] = flag;
        if (value)
            argv[argc++] = (char *)value;
    }
    RenderArgs a;
    assert_int_equal(render_args_parse(&a, argc, argv), SPT_EXIT_OK);
    SptError e = {0};
    Sky sky;
    if (sky_from_args(&sky, a.env, a.background, &e))
        fail_msg("--%s %s: %s", option, value ? value : "", e.msg);
    a.rs.sky = &sky;
    if (checkpoint_key(k, SCENE, &a.rs, &e))
        fail_msg("--%s: %s", option, e.msg);
    sky_free(&sky);
}

TEST(test_image_options_are_in_the_key)
{
    CheckpointKey base, k;
    key_of(NULL, NULL, &base);
    int image = 0, other = 0;
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        if (!strcmp(rows[i].option, "help"))
            continue;
        const char *value = rows[i].takes_value ? example_of(rows[i].option) : NULL;
        if (rows[i].takes_value && !value)
            fail_msg("--%s has no example value in tests/test_options.c", rows[i].option);
        key_of(rows[i].option, value, &k);
        int changed = strcmp(k.settings, base.settings) != 0;
        printf("--%s %s: key %s\n", rows[i].option, value ? value : "",
               changed ? "changed" : "unchanged");
        if (rows[i].flags & SPT_OPT_IMAGE) {
            image++;
            if (!changed)
                fail_msg("--%s changes the image but not the checkpoint key", rows[i].option);
        } else {
            other++;
            if (changed)
                fail_msg("--%s does not change the image but changes the checkpoint key: %s",
                         rows[i].option, k.settings);
        }
    }
    assert_true(image >= 10);
    assert_true(other >= 10);
    /* --light-paths at its default gives the key of no option: the key holds
     * the value rendered with (a RenderSettings' 0 is the default too). */
    key_of("light-paths", "2", &k);
    assert_string_equal(k.settings, base.settings);
}

/* Each example lands in the field of its row, by the row's kind. */
TEST(test_values_reach_their_fields)
{
    char *argv[] = {"render", "--spp", "64", "--width", "100", "--seed", "4294967295",
                    "--env-rotation", "-30", "--max-depth", "-1", "--tonemap", "neutral",
                    "--sampler", "Independent", "-o", "a.png", "-o", "b.exr", "--profile", "-q", SCENE};
    RenderArgs a;
    assert_int_equal(render_args_parse(&a, sizeof argv / sizeof argv[0], argv), SPT_EXIT_OK);
    assert_int_equal(a.rs.spp, 64);
    assert_int_equal(a.rs.width, 100);
    assert_int_equal(a.rs.height, 0); /* from the camera, later */
    assert_true(a.rs.seed == 4294967295u);
    assert_true(a.rs.env_rotation == -30.0f);
    assert_true(a.rs.env_intensity == 1.0f); /* the default */
    assert_int_equal(a.rs.max_depth, -1);
    assert_int_equal(a.tonemap, SPT_TONEMAP_NEUTRAL);
    assert_int_equal(a.rs.sampler, SPT_SAMPLER_INDEPENDENT);
    assert_int_equal(a.outputs_count, 2);
    assert_string_equal(a.outputs[1], "b.exr");
    assert_int_equal(a.rs.profile, 1);
    assert_int_equal(a.quiet, 1);
    assert_true(a.checkpoint_every == 60.0);
    assert_string_equal(a.scene, SCENE);
    /* --time without --spp: as many samples as fit. */
    char *timed[] = {"render", "--time", "2", SCENE};
    assert_int_equal(render_args_parse(&a, 4, timed), SPT_EXIT_OK);
    assert_int_equal(a.rs.spp, 1 << 24);
    assert_true(a.rs.time_limit == 2.0);
    assert_int_equal(a.rs.sampler, SPT_SAMPLER_SOBOL); /* the default */
    char *zs[] = {"render", "--sampler", "ZSobol", SCENE};
    assert_int_equal(render_args_parse(&a, 4, zs), SPT_EXIT_OK);
    assert_int_equal(a.rs.sampler, SPT_SAMPLER_ZSOBOL);
}

/* Values outside a row's range are refused with a usage error. */
TEST(test_bad_values)
{
    static const char *bad[][2] = {
        {"--spp", "0"},          {"--spp", "16777217"},  {"--width", "x"},
        {"--max-depth", "0"},    {"--max-depth", "-2"},  {"--seed", "-1"},
        {"--time", "0"},         {"--exposure", "65"},   {"--env-intensity", "-1"},
        {"--aperture", "inf"},   {"--env-rotation", "nan"}, {"--checkpoint-every", "-1"},
        {"--tonemap", "aces"},   {"--aov", "albedo,alpha"}, {"--spectral", "0"},
                                 {"--sampler", "zsobolx"}, {"--sampler", ""},
        {"--light-paths", "0"},  {"--light-paths", "-1"}, {"--light-paths", "8.5"},
        {"--light-paths", "nan"}, {"--light-paths", "inf"}, {"--light-paths", "1/2"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char *argv[] = {"render", (char *)bad[i][0], (char *)bad[i][1], SCENE};
        RenderArgs a;
        if (render_args_parse(&a, 4, argv) != SPT_EXIT_USAGE)
            fail_msg("%s %s was accepted", bad[i][0], bad[i][1]);
    }
}

/* A parse that fails inside a group of short options ("-zq": z is unknown) must
 * not leave getopt pointing into that group: the next parse (another argv; the
 * first one freed) starts afresh. A libFuzzer run of the command line found this
 * (a read of freed memory); here the stale 'q' would set quiet. Unknown options
 * and missing values give one error line, not getopt's line and the usage. */
TEST(test_parse_after_failed_group)
{
    char *group = strdup("-zq");
    char *argv1[] = {"render", group, SCENE};
    RenderArgs a;
    assert_int_equal(render_args_parse(&a, 3, argv1), SPT_EXIT_USAGE);
    free(group);
    char *argv2[] = {"render", SCENE};
    assert_int_equal(render_args_parse(&a, 2, argv2), SPT_EXIT_OK);
    assert_int_equal(a.quiet, 0);
    char *argv3[] = {"render", SCENE, "--spp"};
    assert_int_equal(render_args_parse(&a, 3, argv3), SPT_EXIT_USAGE);
}

/* --time's chunk sizes (render_deadline_chunk) with synthetic times: a device
 * of r seconds per sample (scaled by load(k) in its chunk k) that starts
 * `start` seconds into a limit of T seconds, chunks of at most 16 samples.
 * Returns the seconds at which its last chunk ends; *samples and *chunks
 * receive the totals. */
static double simulate_deadline(double T, double start, double r, double swing, uint32_t *samples,
                                int *chunks)
{
    double t = start, per = 0.0;
    *samples = 0;
    *chunks = 0;
    uint32_t n;
    while ((n = render_deadline_chunk(16, T - t, per)) > 0) {
        assert_true(n <= 16);
        double rate = r * (1.0 + swing * sin(1.7 * *chunks));
        t += n * rate;
        per = rate;
        *samples += n;
        (*chunks)++;
        assert_true(*chunks < 100);
    }
    return t;
}

TEST(test_deadline_chunks)
{
    /* The cases of the rule. */
    assert_int_equal(render_deadline_chunk(0, 10.0, 0.1), 0);   /* nothing wanted */
    assert_int_equal(render_deadline_chunk(16, 0.0, 0.1), 0);   /* time is up */
    assert_int_equal(render_deadline_chunk(16, -1.0, 0.0), 0);
    assert_int_equal(render_deadline_chunk(16, 5.0, 0.0), 1);   /* no rate yet: one sample */
    assert_int_equal(render_deadline_chunk(16, 0.09, 0.1), 0);  /* one sample does not fit */
    assert_int_equal(render_deadline_chunk(16, 0.15, 0.1), 1);  /* one fits: at least one */
    assert_int_equal(render_deadline_chunk(16, 1.0, 0.1), 5);   /* half of the 10 that fit */
    assert_int_equal(render_deadline_chunk(16, 100.0, 0.1), 16); /* capped */
    /* A steady device ends before T, within one sample's time of it, where
     * whole 16-sample chunks from the start would end at 0.5 + 16 k 0.37 s, up
     * to 16 samples' time (5.9 s) past T. */
    uint32_t samples;
    int chunks;
    double end = simulate_deadline(5.0, 0.5, 0.37, 0.0, &samples, &chunks);
    assert_true(end <= 5.0);
    assert_true(5.0 - end < 0.37);
    assert_int_equal(samples, 12); /* floor((5 - 0.5) / 0.37) */
    assert_true(chunks <= 8);
    /* 20 s at 1/16 s a sample (exact in binary): the chunks grow to 16 and
     * shrink at the end. */
    end = simulate_deadline(20.0, 0.25, 0.0625, 0.0, &samples, &chunks);
    assert_true(end <= 20.0 && 20.0 - end < 0.0625);
    assert_int_equal(samples, 316); /* (20 - 0.25) / 0.0625 */
    assert_true(chunks < 40);
    /* A load that changes the rate by up to 30% from chunk to chunk: past T
     * by less than two samples' time. */
    end = simulate_deadline(5.0, 0.5, 0.37, 0.3, &samples, &chunks);
    assert_true(end < 5.0 + 2.0 * 0.37);
    assert_true(samples >= 9);
}

TEST_MAIN("options", setup, teardown)
