/* build/spectrace-mpi under mpirun on this machine (issue "Scale", several
 * machines): two ranks give the image of one process, also when resuming a
 * checkpoint; only rank 0 needs the scene files and writes; a failing rank fails
 * the run with one error line naming it. Two ranks of one PoCL compute unit each;
 * the program is $SPECTRACE_EXE with "-mpi" appended (tests/run_tests.sh). */
#include "test_util.h"

#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "scene/scene_pack.h"

#define SCENE "scenes/cornell_box.gltf"
/* Every AOV layer and 47 spectral bands too: the ranks' films carry their sums. */
#define COMMON "--width 32 --height 32 --seed 5 --device 0 --aov all --spectral 47"
/* mpirun on one machine: as root (CI), more ranks than cores. Each rank's chunks
 * are slowed a little so both ranks take a share of a render this small. */
#define MPIRUN "mpirun --allow-run-as-root --oversubscribe -x SPECTRACE_TEST_SLOW_DEVICE=0:25"
/* -x applies to its own program context only (the first, here: rank 0). */
#define RANKS_FIRST "-x SPECTRACE_TEST_RANKS_FIRST=1"

#include "ckpt_test.h"

static char exe[512], mpi_exe[512];

/* Runs cmd (a shell command line) with stderr captured into out; returns the exit status. */
static int run(const char *cmd, char *out, size_t cap)
{
    return test_sh(cmd, TEST_STDERR, out, cap);
}

/* run() that must succeed; prints the program's messages when it does not. */
static void run_ok(const char *cmd, char *out, size_t cap)
{
    int rc = run(cmd, out, cap);
    if (rc)
        fail_msg("exit code %d from %s:\n%s", rc, cmd, out);
}

/* The one-process reference: 64 spp with its checkpoint (rendered once). */
static void reference(void)
{
    static int done;
    if (done)
        return;
    char cmd[2048], out[8192];
    snprintf(cmd, sizeof cmd, "'%s' render " SCENE " " COMMON " -q --spp 64 -o %s --checkpoint %s", exe,
             test_path("one.exr"), test_path("one_ck.exr"));
    run_ok(cmd, out, sizeof out);
    done = 1;
}

static int setup(void **state)
{
    (void)state;
    ckpt_aov = SPT_AOV_ALL;
    ckpt_spectral = 47;
    const char *e = test_exe();
    snprintf(exe, sizeof exe, "%s", e);
    snprintf(mpi_exe, sizeof mpi_exe, "%s-mpi", e);
    return test_dir_make("spt-mpi");
}

/* Skips (with the reason) where the MPI program cannot run. */
static int mpi_unavailable(void)
{
#if defined(__SANITIZE_ADDRESS__)
    printf("skipped: build/spectrace-mpi is built without sanitizers (Open MPI and its "
           "transports keep allocations alive at exit that LeakSanitizer would report); "
           "the MPI tests run in the plain build\n");
    return 1;
#else
    if (!test_exists(mpi_exe) || system("command -v mpirun >/dev/null 2>&1")) {
        printf("skipped: %s or mpirun missing (make mpi; tools/install_deps.sh mpi)\n", mpi_exe);
        return 1;
    }
    return 0;
#endif
}

/* Runs `spectrace-mpi ARGS` on two ranks, rank 1 started in a folder where
 * the scene's relative path does not exist (it gets the scene from rank 0),
 * RANKS_FIRST (rank 0's hook) giving each rank a chunk before any has a
 * second, so both render, whatever the timing; their messages into out.
 * Asserts that it succeeded and that the ranks' samples add up to spp. */
static void two_ranks_render(const char *args, unsigned spp, char *out, size_t cap)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, MPIRUN " " RANKS_FIRST " -n 1 '%s' %s : -wdir %s -n 1 '%s' %s", mpi_exe, args,
             test_dir(), mpi_exe, args);
    int rc = run(cmd, out, cap);
    printf("%s", out);
    assert_int_equal(rc, 0);
    unsigned r0, r1;
    const char *ranks = strstr(out, "ranks: 0: ");
    assert_non_null(ranks);
    assert_int_equal(sscanf(ranks, "ranks: 0: %u spp, 1: %u spp", &r0, &r1), 2);
    assert_int_equal(r0 + r1, spp);
    assert_true(r0 > 0 && r1 > 0);
}

/* Two ranks, rank 1 started in a folder where the scene's relative path does not
 * exist (it gets the scene from rank 0), give the one-process image; only rank 0
 * prints and writes. */
TEST(test_two_ranks_same_image)
{
    if (mpi_unavailable())
        skip();
    reference();
    char out[8192], args[512];
    snprintf(args, sizeof args, "render " SCENE " " COMMON " --spp 64 -o %s --checkpoint %s",
             test_path("two.exr"), test_path("two_ck.exr"));
    two_ranks_render(args, 64, out, sizeof out);
    /* One device line: rank 1 prints nothing. */
    const char *d = strstr(out, "device 0:");
    assert_non_null(d);
    assert_null(strstr(d + 1, "device 0:"));
    assert_same_render(test_path("one_ck.exr"), test_path("two_ck.exr"), 5, 64, test_path("one.exr"),
                       test_path("two.exr"));
}

/* A glTF scene whose meshes are placed by reference (docs/gltf.md,
 * "Instancing"): rank 1, where the file does not exist, gets the meshes and
 * instances packed by rank 0, and the two ranks give the one-process image. */
TEST(test_two_ranks_instanced)
{
    if (mpi_unavailable())
        skip();
    char cmd[4096], out[8192], args[512];
    snprintf(cmd, sizeof cmd,
             "'%s' render tests/data/scenes/instancing.gltf " COMMON " -q --spp 16 -o %s", exe,
             test_path("inst_one.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(args, sizeof args,
             "render tests/data/scenes/instancing.gltf " COMMON " --spp 16 -o %s",
             test_path("inst_two.exr"));
    snprintf(cmd, sizeof cmd, MPIRUN " " RANKS_FIRST " -n 1 '%s' %s : -wdir %s -n 1 '%s' %s", mpi_exe,
             args, test_dir(), mpi_exe, args);
    int rc = run(cmd, out, sizeof out);
    printf("%s", out);
    assert_int_equal(rc, 0);
    assert_non_null(strstr(out, "ranks: 0: "));
    assert_same_exr(test_path("inst_one.exr"), test_path("inst_two.exr"));
}

/* Photon merging (docs/architecture.md, "Caustics seen through specular
 * surfaces"), on by default for MERGE_SCENE's glass sphere: rank 1 decides
 * it from the scene rank 0 packs, and each rank's chunks sort their own
 * photon grids from their sample indices' light paths, so two ranks give the
 * one-process image; and merging ran (the image is not --merge off's). */
#define MERGE_SCENE "tests/data/scenes/caustic_sphere_area.gltf"
TEST(test_two_ranks_merge)
{
    if (mpi_unavailable())
        skip();
    static const char *opts = "--width 32 --height 32 --seed 5 --device 0 --spp 32";
    char cmd[4096], out[8192], args[512];
    snprintf(cmd, sizeof cmd, "'%s' render " MERGE_SCENE " %s --merge off -q -o %s", exe, opts,
             test_path("merge_off.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(cmd, sizeof cmd, "'%s' render " MERGE_SCENE " %s -q -o %s", exe, opts, test_path("merge_one.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(args, sizeof args, "render " MERGE_SCENE " %s -o %s", opts, test_path("merge_two.exr"));
    two_ranks_render(args, 32, out, sizeof out);
    assert_same_exr(test_path("merge_one.exr"), test_path("merge_two.exr"));
    static const char *rgb[3] = {"R", "G", "B"};
    ExrLayers a, b;
    SptError e = {0};
    if (exr_read_layers(test_path("merge_one.exr"), rgb, 3, &a, &e) ||
        exr_read_layers(test_path("merge_off.exr"), rgb, 3, &b, &e))
        fail_msg("%s", e.msg);
    double diff = 0;
    for (size_t i = 0; i < (size_t)a.width * a.height; i++)
        diff += fabs(((const float *)exr_layers_channel(&a, "G")->data)[i] -
                     ((const float *)exr_layers_channel(&b, "G")->data)[i]);
    printf("--merge on against off: summed |G| difference %.4g\n", diff);
    assert_true(diff > 0.0);
    exr_layers_free(&a);
    exr_layers_free(&b);
}

/* A one-process checkpoint of 32 spp resumed to 64 on two ranks. */
TEST(test_resume_on_two_ranks)
{
    if (mpi_unavailable())
        skip();
    reference();
    char cmd[4096], out[8192];
    snprintf(cmd, sizeof cmd, "'%s' render " SCENE " " COMMON " -q --spp 32 -o %s --checkpoint %s", exe,
             test_path("half.exr"), test_path("half_ck.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(cmd, sizeof cmd, MPIRUN " -n 2 '%s' render " SCENE " " COMMON " -q --spp 64 -o %s --resume %s",
             mpi_exe, test_path("resumed.exr"), test_path("half_ck.exr"));
    int rc = run(cmd, out, sizeof out);
    printf("%s", out);
    assert_int_equal(rc, 0);
    assert_same_render(test_path("one_ck.exr"), test_path("half_ck.exr"), 5, 64, test_path("one.exr"),
                       test_path("resumed.exr"));
}

/* Rank 1's device fails (test hook) or cannot be selected: the run fails with
 * one error line naming rank 1, and no image. */
TEST(test_failing_rank)
{
    if (mpi_unavailable())
        skip();
    /* Rank 1 fails as it starts its first chunk, which RANKS_FIRST guarantees it
     * gets (without it rank 0 might take every chunk first). */
    static const char *extra[2] = {"-x SPECTRACE_TEST_FAIL_DEVICE=0:0", ""};
    static const char *arg1[2] = {"", "--device 9"};
    static const char *says[2] = {"error: rank 1: injected failure", "error: rank 1: device selection '9'"};
    for (int k = 0; k < 2; k++) {
        char cmd[4096], out[8192], args[512];
        snprintf(args, sizeof args, "render " SCENE " " COMMON " -q --spp 64 -o %s", test_path("fail.exr"));
        snprintf(cmd, sizeof cmd, MPIRUN " " RANKS_FIRST " -n 1 '%s' %s : %s -n 1 '%s' %s %s", mpi_exe, args, extra[k],
                 mpi_exe, args, arg1[k]);
        int rc = run(cmd, out, sizeof out);
        printf("%s", out);
        assert_int_equal(rc, SPT_EXIT_DEVICE);
        const char *first = strstr(out, "error: ");
        assert_non_null(first);
        assert_true(!strncmp(first, says[k], strlen(says[k])));
        assert_null(strstr(first + 1, "error: "));
        assert_false(test_exists(test_path("fail.exr")));
    }
}

/* --frames on two ranks (a rank's share of each frame, every rank refitting
 * the BVH as rank 0 does): each frame the image of the one-process sequence,
 * with one program build on rank 0. */
TEST(test_frames_on_two_ranks)
{
    if (mpi_unavailable())
        skip();
    char cmd[4096], out[8192], args[512];
    const char *frames = "render tests/data/anim/turntable.gltf --frames 0:6:3 --width 32 "
                         "--height 32 --spp 16 --seed 5 --device 0 -o";
    snprintf(cmd, sizeof cmd, "'%s' %s %s -q", exe, frames, test_path("seq_#.exr"));
    run_ok(cmd, out, sizeof out);
    snprintf(args, sizeof args, "%s %s", frames, test_path("mpi_#.exr"));
    snprintf(cmd, sizeof cmd, MPIRUN " " RANKS_FIRST " -n 1 '%s' %s : -n 1 '%s' %s", mpi_exe, args,
             mpi_exe, args);
    run_ok(cmd, out, sizeof out);
    printf("%s", out);
    assert_non_null(strstr(out, "rendered 3 of 3 frames"));
    assert_non_null(strstr(out, "(1 program build)"));
    assert_non_null(strstr(out, "BVH refitted"));
    for (int f = 0; f <= 6; f += 3) {
        char a[64], b[64], pa[512];
        snprintf(a, sizeof a, "seq_%d.exr", f);
        snprintf(b, sizeof b, "mpi_%d.exr", f);
        snprintf(pa, sizeof pa, "%s", test_path(a));
        assert_same_exr(pa, test_path(b));
    }
}

/* What rank 1 gets: a scene with textures and spectral extras survives
 * scene_pack/scene_unpack with every array equal (and packs to the same bytes). */
TEST(test_scene_pack_round_trip)
{
    static const char *files[5] = {"tests/data/gltf/materials.gltf", "tests/data/scenes/furnace_spectral.gltf",
                                   "tests/data/textures/texcoord1.gltf", "tests/data/textures/color0_vec4_ubyte.gltf",
                                   "tests/data/gltf/spectral_lights.gltf"};
    for (int f = 0; f < 5; f++) {
        Scene a, b;
        SptError e = {0};
        if (scene_load_gltf(&a, files[f], &e))
            fail_msg("%s", e.msg);
        size_t n, m;
        void *bytes = scene_pack(&a, &n);
        assert_int_equal(scene_unpack(&b, bytes, n, "test", &e), 0);
        void *again = scene_pack(&b, &m);
        assert_int_equal(n, m);
        assert_int_equal(b.tri_count, a.tri_count);
        assert_memory_equal(b.tri_pos, a.tri_pos, (size_t)a.tri_count * 9 * sizeof(float));
        assert_memory_equal(b.tri_mat, a.tri_mat, (size_t)a.tri_count * sizeof(uint32_t));
        /* TEXCOORD_1 and COLOR_0, where the scene has them (files 2 and 3). */
        assert_int_equal(b.vtx_uv1 != NULL, a.vtx_uv1 != NULL);
        assert_int_equal(b.vtx_color != NULL, a.vtx_color != NULL);
        assert_int_equal(a.vtx_uv1 != NULL, f == 2);
        assert_int_equal(a.vtx_color != NULL, f == 3);
        if (a.vtx_uv1)
            assert_memory_equal(b.vtx_uv1, a.vtx_uv1, (size_t)a.vertex_count * 2 * sizeof(float));
        if (a.vtx_color)
            assert_memory_equal(b.vtx_color, a.vtx_color, (size_t)a.vertex_count * 4 * sizeof(float));
        assert_int_equal(b.texture_count, a.texture_count);
        for (uint32_t i = 0; i < a.texture_count; i++)
            if (a.textures[i].texels)
                assert_memory_equal(b.textures[i].texels, a.textures[i].texels,
                                    (size_t)a.textures[i].width * a.textures[i].height *
                                        a.textures[i].channels * sizeof(float));
        for (uint32_t i = 0; i < a.material_count; i++) {
            const Spd *x = &a.materials[i].reflectance_spd, *y = &b.materials[i].reflectance_spd;
            assert_int_equal(x->count, y->count);
            if (x->count)
                assert_memory_equal(x->value, y->value, (size_t)x->count * sizeof(double));
        }
        /* Lights' spectra (file 4: lines, an inline table, a named table). */
        assert_int_equal(b.light_count, a.light_count);
        assert_int_equal(a.light_count, f == 4 ? 3 : 0);
        for (uint32_t i = 0; i < a.light_count; i++) {
            const Spd *x = &a.lights[i].spd, *y = &b.lights[i].spd;
            assert_int_equal(x->count, y->count);
            assert_int_equal(x->line_count, y->line_count);
            assert_true(x->count + x->line_count > 0);
            if (x->count)
                assert_memory_equal(x->value, y->value, (size_t)x->count * sizeof(double));
            if (x->line_count)
                assert_memory_equal(x->line_nm, y->line_nm, (size_t)x->line_count * sizeof(double));
        }
        assert_string_equal(a.path, b.path);
        printf("%s: %zu bytes, %u triangles, %u textures, %u materials, %u lights\n", files[f], n,
               a.tri_count, a.texture_count, a.material_count, a.light_count);
        /* A truncated block is refused. */
        Scene c;
        assert_int_equal(scene_unpack(&c, bytes, n / 2, "half", &e), SPT_EXIT_INPUT);
        free(bytes);
        free(again);
        scene_free(&a);
        scene_free(&b);
    }
}

/* SIGUSR2 to mpirun (passed on to every rank) stops the render after the
 * current chunks: the image and checkpoint of the samples done are written, and
 * resuming in one process gives the one-process image. */
TEST(test_sigusr2_then_resume)
{
    if (mpi_unavailable())
        skip();
    reference();
    char cmd[4096], ck[256], img[256], log[256];
    snprintf(ck, sizeof ck, "%s", test_path("usr2_ck.exr"));
    snprintf(img, sizeof img, "%s", test_path("usr2.exr"));
    snprintf(log, sizeof log, "%s", test_path("usr2.log"));
    snprintf(cmd, sizeof cmd,
             "exec mpirun --allow-run-as-root --oversubscribe -x SPECTRACE_TEST_SLOW_DEVICE=0:100 -n 2 '%s' "
             "render " SCENE " " COMMON " -q --spp 64 -o %s --checkpoint %s --checkpoint-every 0.05 2>%s",
             mpi_exe, img, ck, log);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        execl("/bin/sh", "sh", "-c", cmd, (char *)NULL);
        _exit(127);
    }
    stop_after_checkpoint(pid, ck, SIGUSR2, log);
    char out[8192];
    assert_true(test_exists(img));
    Film part;
    uint32_t done = load_checkpoint(ck, 5, 64, &part);
    film_free(&part);
    printf("stopped after %u of 64 spp\n", done);
    assert_true(done > 0 && done < 64);
    snprintf(cmd, sizeof cmd, "'%s' render " SCENE " " COMMON " -q --spp 64 -o %s --resume %s", exe,
             test_path("usr2_done.exr"), ck);
    run_ok(cmd, out, sizeof out);
    assert_same_render(test_path("one_ck.exr"), ck, 5, 64, test_path("one.exr"),
                       test_path("usr2_done.exr"));
}

TEST_MAIN_ENV("mpi", setup, test_dir_teardown,
              "POCL_DEVICES=pthread", "POCL_MAX_PTHREAD_COUNT=1",
              "SPECTRACE_POOL=512")
