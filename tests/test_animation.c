/* src/scene/gltf_pose.cpp: scenes posed by --at, --animation and --camera
 * (animation channels, skins, morph targets) against the world-space positions
 * tools/make_anim_scenes.py computed independently from the same accessor
 * values (tests/data/anim/expected.txt); bad animations, skins and selections
 * refused with one message; a posed scene rendering as the same scene written
 * at that pose. */
#include "test_util.h"

#include <unistd.h>

#include "io/image_in.h"
#include "scene/scene.h"

#define ANIM(f) SPT_TEST_DATA("anim/" f)

/* Reads a pose "AT ANIM CAMERA" (rest / - for not given) into p; the strings
 * point into the caller's buffers. */
static void read_pose(FILE *f, ScenePose *p, char *anim, char *cam)
{
    char at[64];
    assert_int_equal(fscanf(f, "%63s %127s %127s", at, anim, cam), 3);
    p->at = strcmp(at, "rest") ? strtod(at, NULL) : NAN;
    p->animation = strcmp(anim, "-") ? anim : NULL;
    p->camera = strcmp(cam, "-") ? cam : NULL;
    /* The expected triangles are the flattened world-space ones. */
    p->instancing = SCENE_INSTANCING_OFF;
}

static int load_posed(Scene *s, const char *file, const ScenePose *p, SptError *e)
{
    char path[512];
    snprintf(path, sizeof path, "%s%s", ANIM(""), file);
    return scene_load_gltf_posed(s, path, p, e);
}

/* The n values of a line "TAG N v..." (N triangles: 9 N values). */
static double *read_values(FILE *f, const char *tag, uint32_t *tris)
{
    char t[16];
    assert_int_equal(fscanf(f, "%15s %u", t, tris), 2);
    assert_string_equal(t, tag);
    double *v = malloc(sizeof(double) * 9 * (*tris ? *tris : 1));
    for (uint32_t i = 0; i < 9 * *tris; i++) assert_int_equal(fscanf(f, "%lf", &v[i]), 1);
    return v;
}

TEST(test_expected_poses)
{
    FILE *f = fopen(ANIM("expected.txt"), "r");
    assert_non_null(f);
    char word[64], file[256], anim[128], cam[128];
    int cases = 0;
    while (fscanf(f, "%63s", word) == 1) {
        if (word[0] == '#' || !strcmp(word, "bad")) {
            int c;
            while ((c = fgetc(f)) != '\n' && c != EOF) {}
            continue;
        }
        assert_string_equal(word, "case");
        ScenePose p;
        assert_int_equal(fscanf(f, "%255s", file), 1);
        read_pose(f, &p, anim, cam);
        Scene s;
        SptError e = {0};
        if (load_posed(&s, file, &p, &e))
            fail_msg("%s at %g: %s", file, p.at, e.msg);
        uint32_t nt, nn;
        double *pos = read_values(f, "tri", &nt), *nrm = read_values(f, "nrm", &nn);
        printf("%s --at %g --animation %s --camera %s: %u triangles\n", file, p.at,
               p.animation ? p.animation : "(all)", p.camera ? p.camera : "(first)", nt);
        assert_int_equal(s.tri_count, nt);
        for (uint32_t t = 0; t < nt; t++)
            for (int k = 0; k < 3; k++) {
                const float *got = &s.tri_pos[t * 9 + k * 3];
                const float *gn = &s.vtx_normal[s.tri_vidx[t * 3 + k] * 3];
                for (int r = 0; r < 3; r++) {
                    if (fabs(got[r] - pos[t * 9 + k * 3 + r]) > 1e-5)
                        fail_msg("%s at %g: triangle %u vertex %d coordinate %d is %.9g, expected "
                                 "%.9g",
                                 file, p.at, t, k, r, got[r], pos[t * 9 + k * 3 + r]);
                    if (fabs(gn[r] - nrm[t * 9 + k * 3 + r]) > 1e-5)
                        fail_msg("%s at %g: triangle %u vertex %d normal %d is %.9g, expected %.9g",
                                 file, p.at, t, k, r, gn[r], nrm[t * 9 + k * 3 + r]);
                }
            }
        free(pos);
        free(nrm);
        while (fscanf(f, "%63s", word) == 1 && strcmp(word, "end")) {
            double v[6];
            if (!strcmp(word, "cam")) {
                for (int i = 0; i < 6; i++) assert_int_equal(fscanf(f, "%lf", &v[i]), 1);
                for (int i = 0; i < 3; i++) {
                    assert_close(s.camera.position[i], v[i], 1e-5);
                    assert_close(s.camera.forward[i], v[3 + i], 1e-5);
                }
            } else {
                assert_string_equal(word, "light");
                for (int i = 0; i < 3; i++) assert_int_equal(fscanf(f, "%lf", &v[i]), 1);
                assert_int_equal(s.light_count, 1);
                for (int i = 0; i < 3; i++) assert_close(s.lights[0].position[i], v[i], 1e-5);
            }
        }
        scene_free(&s);
        cases++;
    }
    fclose(f);
    printf("%d posed cases\n", cases);
    assert_true(cases >= 16);
}

/* Each bad file or selection: refused with SPT_EXIT_INPUT, the message naming
 * the file and the fault. */
TEST(test_bad_inputs)
{
    FILE *f = fopen(ANIM("expected.txt"), "r");
    assert_non_null(f);
    char line[1024], file[256], anim[128], cam[128], want[512];
    int bad = 0;
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "bad ", 4)) continue;
        char at[64];
        int used = 0;
        assert_int_equal(sscanf(line + 4, "%255s %63s %127s %127s %n", file, at, anim, cam, &used), 4);
        snprintf(want, sizeof want, "%s", line + 4 + used);
        want[strcspn(want, "\n")] = 0;
        ScenePose p = {strcmp(at, "rest") ? strtod(at, NULL) : NAN,
                       strcmp(anim, "-") ? anim : NULL, strcmp(cam, "-") ? cam : NULL,
                       SCENE_INSTANCING_AUTO};
        Scene s;
        SptError e = {0};
        int rc = load_posed(&s, file, &p, &e);
        printf("%s: %s\n", file, e.msg);
        if (rc != SPT_EXIT_INPUT) fail_msg("%s: exit %d, expected %d", file, rc, SPT_EXIT_INPUT);
        if (!strstr(e.msg, file) || !strstr(e.msg, want))
            fail_msg("%s: the message '%s' should name the file and say '%s'", file, e.msg, want);
        assert_int_equal(s.tri_count, 0);
        bad++;
    }
    fclose(f);
    assert_true(bad >= 10);
}

/* The command line: an unknown camera is one error line, exit 3 (README.md,
 * "Exit codes"); a bad --at is a usage error. */
TEST(test_cli_errors)
{
    char err[4096];
    int rc = test_run_exe("", 60, "render -q --camera Nope -o /tmp/spt_anim_never.png "
                          "tests/data/anim/anim_triangle.gltf", err, sizeof err);
    printf("%s", err);
    assert_int_equal(rc, 3);
    assert_non_null(strstr(err, "error: tests/data/anim/anim_triangle.gltf: --camera 'Nope'"));
    assert_null(strchr(err, '\n') ? strstr(strchr(err, '\n') + 1, "error:") : NULL);
    rc = test_run_exe("", 60, "render -q --at soon tests/data/anim/anim_triangle.gltf", err,
                      sizeof err);
    printf("%s", err);
    assert_int_equal(rc, 2);
    assert_non_null(strstr(err, "--at 'soon'"));
    assert_int_equal(access("/tmp/spt_anim_never.png", F_OK), -1);
}

/* Without --at the rest state: a NULL pose and a pose of NaN load the same
 * scene; --animation alone poses at time 0. */
TEST(test_rest_state)
{
    Scene a, b, c;
    SptError e = {0};
    assert_int_equal(scene_load_gltf(&a, ANIM("anim_triangle.gltf"), &e), 0);
    ScenePose rest = {NAN, NULL, NULL, 0}, start = {NAN, "move", NULL, 0}, zero = {0, "move", NULL, 0};
    assert_int_equal(scene_load_gltf_posed(&b, ANIM("anim_triangle.gltf"), &rest, &e), 0);
    assert_int_equal(a.tri_count, b.tri_count);
    assert_memory_equal(a.tri_pos, b.tri_pos, a.tri_count * 9 * sizeof(float));
    scene_free(&b);
    assert_int_equal(scene_load_gltf_posed(&b, ANIM("anim_triangle.gltf"), &start, &e), 0);
    assert_int_equal(scene_load_gltf_posed(&c, ANIM("anim_triangle.gltf"), &zero, &e), 0);
    assert_memory_equal(b.tri_pos, c.tri_pos, b.tri_count * 9 * sizeof(float));
    assert_memory_equal(b.lights[0].position, c.lights[0].position, sizeof(float) * 3);
    assert_int_equal(a.animation_info_count, 2);
    assert_string_equal(a.animation_info[1].name, "cubic");
    assert_close(a.animation_info[1].end, 3.0, 0);
    assert_int_equal(a.camera_info_count, 2);
    assert_int_equal(a.camera_info[1].node, 3); /* the first of its two nodes */
    scene_free(&a);
    scene_free(&b);
    scene_free(&c);
}

/* render_posed.gltf at --at 0.25 is render_static.gltf: the loaded scenes are
 * equal bit for bit, and so are the rendered images. */
TEST(test_posed_renders_as_static)
{
    Scene a, b;
    SptError e = {0};
    ScenePose p = {0.25, NULL, NULL, SCENE_INSTANCING_AUTO};
    assert_int_equal(scene_load_gltf_posed(&a, ANIM("render_posed.gltf"), &p, &e), 0);
    assert_int_equal(scene_load_gltf(&b, ANIM("render_static.gltf"), &e), 0);
    assert_int_equal(a.tri_count, b.tri_count);
    assert_memory_equal(a.tri_pos, b.tri_pos, a.tri_count * 9 * sizeof(float));
    assert_memory_equal(a.vtx_normal, b.vtx_normal, a.vertex_count * 3 * sizeof(float));
    assert_memory_equal(&a.camera, &b.camera, sizeof a.camera);
    assert_memory_equal(a.lights[0].position, b.lights[0].position, sizeof(float) * 3);
    scene_free(&a);
    scene_free(&b);

    char dir[] = "/tmp/spt_anim_XXXXXX", args[1024], err[4096];
    assert_non_null(mkdtemp(dir));
    const char *common = "render -q --spp 4 --width 32 --height 24 --seed 3";
    snprintf(args, sizeof args, "%s --at 0.25 --camera 0 -o %s/posed.exr -o %s/posed.png %s",
             common, dir, dir, ANIM("render_posed.gltf"));
    if (test_run_exe("", 300, args, err, sizeof err)) fail_msg("%s", err);
    snprintf(args, sizeof args, "%s -o %s/static.exr %s", common, dir, ANIM("render_static.gltf"));
    if (test_run_exe("", 300, args, err, sizeof err)) fail_msg("%s", err);
    char pa[600], pb[600];
    /* The image records its pose (PNG tEXt: key, NUL, value). */
    snprintf(pa, sizeof pa, "%s/posed.png", dir);
    FILE *png = fopen(pa, "rb");
    assert_non_null(png);
    static char bytes[1 << 16];
    size_t nb = fread(bytes, 1, sizeof bytes, png);
    fclose(png);
    assert_non_null(memmem(bytes, nb, "spectrace:at\0" "0.25", 17));
    assert_non_null(memmem(bytes, nb, "spectrace:camera\0" "0", 18));
    unlink(pa);
    snprintf(pa, sizeof pa, "%s/posed.exr", dir);
    snprintf(pb, sizeof pb, "%s/static.exr", dir);
    float *ia = NULL, *ib = NULL;
    int wa, ha, wb, hb;
    assert_int_equal(image_read_rgb(pa, &ia, &wa, &ha, &e), 0);
    assert_int_equal(image_read_rgb(pb, &ib, &wb, &hb, &e), 0);
    assert_int_equal(wa, wb);
    assert_int_equal(ha, hb);
    double sum = 0;
    for (int i = 0; i < wa * ha * 3; i++) sum += ia[i];
    printf("mean pixel value %.4g\n", sum / (wa * ha * 3));
    assert_true(sum > 0); /* something was lit */
    assert_memory_equal(ia, ib, sizeof(float) * 3 * wa * ha);
    /* The rest pose (no --at) of the posed file is another image. */
    snprintf(args, sizeof args, "%s -o %s/rest.exr %s", common, dir, ANIM("render_posed.gltf"));
    if (test_run_exe("", 300, args, err, sizeof err)) fail_msg("%s", err);
    char pr[600];
    snprintf(pr, sizeof pr, "%s/rest.exr", dir);
    float *ir = NULL;
    assert_int_equal(image_read_rgb(pr, &ir, &wb, &hb, &e), 0);
    assert_true(memcmp(ia, ir, sizeof(float) * 3 * wa * ha) != 0);
    free(ia);
    free(ib);
    free(ir);
    unlink(pa), unlink(pb), unlink(pr);
    rmdir(dir);
}

TEST_MAIN("animation", NULL, NULL)
