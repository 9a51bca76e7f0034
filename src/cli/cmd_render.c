/* spectrace render: load a glTF scene, render it on an OpenCL device, write the
 * outputs. */
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "render/checkpoint.h"
#include "cl/cl_device.h"
#include "cli/commands.h"
#include "mpi/mpi_hook.h"
#include "render/film.h"
#include "io/image_out.h"
#include "render/render.h"
#include "scene/scene.h"
#include "core/util.h"

static const char render_usage[] =
    "usage: spectrace render SCENE [options]\n"
    "\n"
    "Renders a glTF 2.0 scene (.gltf or .glb) with spectral path tracing.\n"
    "\n"
    "  -o, --output FILE      output image; repeatable; the format follows the extension:\n"
    "                         .exr (linear, 32-bit float), .png/.jpg (sRGB 8-bit),\n"
    "                         .tif (float), .hdr (linear). Default: SCENE-NAME.exr and .png\n"
    "      --spp N            samples per pixel (default 16)\n"
    "      --time SECONDS     render for this long instead (whole passes; --spp is the cap)\n"
    "      --width W          image width (default 512)\n"
    "      --height H         image height (default: from the camera's aspect ratio)\n"
    "      --max-depth D      path segments from the camera: 1 emitters only, 2 direct\n"
    "                         light, ...; -1 unlimited, ended by Russian roulette (default -1)\n"
    "      --seed S           random seed (default 0); the same seed on the same device\n"
    "                         gives the same image bit for bit\n"
    "      --device SEL       OpenCL device(s): index, name substring, cpu or gpu, a comma\n"
    "                         list, or all (default: SPECTRACE_DEVICE, else the first GPU,\n"
    "                         else the CPU); several devices share the samples\n"
    "      --exposure EV      display outputs (PNG, JPEG) are scaled by 2^EV\n"
    "      --tonemap MODE     display tone map: none (default) or neutral (Khronos PBR Neutral)\n"
    "      --env FILE         equirectangular environment map (.hdr, .exr) lighting the scene\n"
    "      --env-rotation DEG rotate the environment about +Y (default 0)\n"
    "      --env-intensity X  scale the environment (default 1)\n"
    "      --background SKY   uniform sky: R,G,B (linear sRGB, upsampled as an illuminant),\n"
    "                         an SPD (name, blackbody:K, CSV), or black. Default: a scene\n"
    "                         without lights gets a white (D65, radiance 1) sky\n"
    "      --aperture R       thin-lens radius in metres (default 0: pinhole)\n"
    "      --focus-distance D focus distance in metres (default: the distance at the\n"
    "                         image centre)\n"
    "      --checkpoint FILE  write the resumable film (an EXR) every --checkpoint-every\n"
    "                         seconds, at the end and when stopped by a signal\n"
    "      --checkpoint-every SECONDS  (default 60)\n"
    "      --resume FILE      continue the checkpoint FILE to --spp samples per pixel in\n"
    "                         total (same scene and settings; keeps checkpointing to FILE)\n"
    "      --profile          time the kernel stages and print where the time went\n"
    "  -q, --quiet            no progress display\n"
    "  -h, --help             this text\n"
    "\n"
    "Ctrl-C (SIGINT) or SIGTERM stops after the current pass and writes the image of\n"
    "the samples done so far (and the checkpoint, with --checkpoint).\n";

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

/* Whether the sky is black: --background black, none or R,G,B all 0, or --env
 * with intensity 0 (the renderer leaves these unlit). */
static int sky_is_black(const Sky *sky, double env_intensity)
{
    return sky->kind == SPT_SKY_BLACK ||
           (sky->kind == SPT_SKY_RGB && sky->rgb[0] == 0.0f && sky->rgb[1] == 0.0f &&
            sky->rgb[2] == 0.0f) ||
           (sky->kind == SPT_SKY_MAP && !(env_intensity > 0));
}

/* Parses a whole integer in [lo, hi]; 0 on success. */
static int parse_int(const char *s, long lo, long hi, long *out)
{
    char *end;
    long v = strtol(s, &end, 10);
    if (!*s || *end || v < lo || v > hi)
        return -1;
    *out = v;
    return 0;
}

static int parse_double(const char *s, double *out)
{
    char *end;
    double v = strtod(s, &end);
    if (!*s || *end || !(v == v))
        return -1;
    *out = v;
    return 0;
}

/* SCENE's file name without folder and extension, for default output names. */
static void scene_stem(const char *path, char *out, size_t n)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    snprintf(out, n, "%s", base);
    char *dot = strrchr(out, '.');
    if (dot && dot != out)
        *dot = 0;
}

int cmd_render(int argc, char **argv)
{
    enum { O_SPP = 256, O_TIME, O_WIDTH, O_HEIGHT, O_DEPTH, O_SEED, O_DEVICE, O_EXPOSURE,
           O_TONEMAP, O_PROFILE, O_ENV, O_ENV_ROT, O_ENV_INT, O_BACKGROUND, O_APERTURE, O_FOCUS,
           O_CHECKPOINT, O_CKPT_EVERY, O_RESUME };
    static const struct option opts[] = {
        {"output", required_argument, 0, 'o'},  {"spp", required_argument, 0, O_SPP},
        {"time", required_argument, 0, O_TIME}, {"width", required_argument, 0, O_WIDTH},
        {"height", required_argument, 0, O_HEIGHT}, {"max-depth", required_argument, 0, O_DEPTH},
        {"seed", required_argument, 0, O_SEED}, {"device", required_argument, 0, O_DEVICE},
        {"exposure", required_argument, 0, O_EXPOSURE},
        {"tonemap", required_argument, 0, O_TONEMAP}, {"profile", no_argument, 0, O_PROFILE},
        {"env", required_argument, 0, O_ENV}, {"env-rotation", required_argument, 0, O_ENV_ROT},
        {"env-intensity", required_argument, 0, O_ENV_INT},
        {"background", required_argument, 0, O_BACKGROUND},
        {"aperture", required_argument, 0, O_APERTURE},
        {"focus-distance", required_argument, 0, O_FOCUS},
        {"checkpoint", required_argument, 0, O_CHECKPOINT},
        {"checkpoint-every", required_argument, 0, O_CKPT_EVERY},
        {"resume", required_argument, 0, O_RESUME},
        {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'}, {0, 0, 0, 0}};
    const char *outputs[16];
    int n_out = 0;
    long spp = 16, width = 0, height = 0, depth = -1, seed = 0;
    double time_limit = 0, exposure = 0;
    int tonemap = SPT_TONEMAP_NONE, quiet = 0, profile = 0, spp_given = 0;
    const char *device_sel = NULL, *env_path = NULL, *background = NULL;
    double env_rot = 0, env_int = 1, aperture = 0, focus = 0;
    const char *ckpt_path = NULL, *resume_path = NULL;
    double ckpt_every = 60;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o':
            if (n_out == (int)(sizeof outputs / sizeof outputs[0])) {
                spt_error("render: too many outputs (at most 16)");
                return SPT_EXIT_USAGE;
            }
            outputs[n_out++] = optarg;
            break;
        case O_SPP:
            if (parse_int(optarg, 1, 1 << 24, &spp)) {
                spt_error("render: --spp '%s': expected a whole number from 1 to 16777216", optarg);
                return SPT_EXIT_USAGE;
            }
            spp_given = 1;
            break;
        case O_TIME:
            if (parse_double(optarg, &time_limit) || !(time_limit > 0)) {
                spt_error("render: --time '%s': expected a positive number of seconds", optarg);
                return SPT_EXIT_USAGE;
            }
            break;
        case O_WIDTH:
        case O_HEIGHT:
            if (parse_int(optarg, 1, 16384, c == O_WIDTH ? &width : &height)) {
                spt_error("render: --%s '%s': expected a whole number from 1 to 16384",
                          c == O_WIDTH ? "width" : "height", optarg);
                return SPT_EXIT_USAGE;
            }
            break;
        case O_DEPTH:
            if (parse_int(optarg, -1, 100000, &depth) || depth == 0) {
                spt_error("render: --max-depth '%s': expected -1 (unlimited) or a whole number >= 1",
                          optarg);
                return SPT_EXIT_USAGE;
            }
            break;
        case O_SEED:
            if (parse_int(optarg, 0, 4294967295L, &seed)) {
                spt_error("render: --seed '%s': expected a whole number from 0 to 4294967295", optarg);
                return SPT_EXIT_USAGE;
            }
            break;
        case O_DEVICE:
            device_sel = optarg;
            break;
        case O_EXPOSURE:
            if (parse_double(optarg, &exposure) || exposure < -64 || exposure > 64) {
                spt_error("render: --exposure '%s': expected a number of stops from -64 to 64", optarg);
                return SPT_EXIT_USAGE;
            }
            break;
        case O_TONEMAP:
            if (image_tonemap_parse(optarg, &tonemap)) {
                spt_error("render: --tonemap '%s': expected none or neutral", optarg);
                return SPT_EXIT_USAGE;
            }
            break;
        case O_PROFILE:
            profile = 1;
            break;
        case O_ENV:
            env_path = optarg;
            break;
        case O_BACKGROUND:
            background = optarg;
            break;
        case O_ENV_ROT:
        case O_ENV_INT:
        case O_APERTURE:
        case O_FOCUS: {
            double *dst = c == O_ENV_ROT ? &env_rot : c == O_ENV_INT ? &env_int
                        : c == O_APERTURE ? &aperture : &focus;
            static const char *names[] = {"env-rotation", "env-intensity", "aperture", "focus-distance"};
            const char *nm = names[c == O_ENV_ROT ? 0 : c == O_ENV_INT ? 1 : c == O_APERTURE ? 2 : 3];
            if (parse_double(optarg, dst) || !isfinite(*dst) ||
                (c != O_ENV_ROT && *dst < 0)) {
                spt_error("render: --%s '%s': expected a %snumber", nm, optarg,
                          c == O_ENV_ROT ? "" : "non-negative ");
                return SPT_EXIT_USAGE;
            }
            break;
        }
        case O_CHECKPOINT:
            ckpt_path = optarg;
            break;
        case O_RESUME:
            resume_path = optarg;
            break;
        case O_CKPT_EVERY:
            if (parse_double(optarg, &ckpt_every) || !(ckpt_every >= 0) || !isfinite(ckpt_every)) {
                spt_error("render: --checkpoint-every '%s': expected a number of seconds >= 0", optarg);
                return SPT_EXIT_USAGE;
            }
            break;
        case 'q':
            quiet = 1;
            break;
        case 'h':
            fputs(render_usage, stdout);
            return SPT_EXIT_OK;
        default:
            fputs(render_usage, stderr);
            return SPT_EXIT_USAGE;
        }
    }
    if (optind != argc - 1) {
        spt_error("render: expected exactly one SCENE (try: spectrace render --help)");
        return SPT_EXIT_USAGE;
    }
    const char *scene_path = argv[optind];
    if (time_limit > 0 && !spp_given)
        spp = 1 << 24;
    char def_exr[512], def_png[512], stem[256];
    if (n_out == 0) {
        scene_stem(scene_path, stem, sizeof stem);
        snprintf(def_exr, sizeof def_exr, "%s.exr", stem);
        snprintf(def_png, sizeof def_png, "%s.png", stem);
        outputs[n_out++] = def_exr;
        outputs[n_out++] = def_png;
    }
    SptError e = {0};
    for (int i = 0; i < n_out; i++)
        if (image_output_check(outputs[i], &e))
            return spt_report(&e);
    if ((ckpt_path || resume_path) && checkpoint_path_check(ckpt_path ? ckpt_path : resume_path, &e))
        return spt_report(&e);
    Sky sky;
    if (sky_from_args(&sky, env_path, background, &e))
        return spt_report(&e);

    Scene scene;
    int rc = scene_load_gltf(&scene, scene_path, &e);
    if (rc) {
        sky_free(&sky);
        return spt_report(&e);
    }
    const SceneCamera *cam = &scene.camera;
    if (!width && !height)
        width = 512;
    float aspect = cam->aspect > 0 ? cam->aspect : 1.0f;
    if (!height)
        height = (long)(width / aspect + 0.5f) > 0 ? (long)(width / aspect + 0.5f) : 1;
    if (!width)
        width = (long)(height * aspect + 0.5f) > 0 ? (long)(height * aspect + 0.5f) : 1;

    ClDeviceList devices = {0};
    GpuScene gpu;
    memset(&gpu, 0, sizeof gpu);
    Film film = {0};
    CheckpointRun ckpt;
    memset(&ckpt, 0, sizeof ckpt);
    float *rgb = NULL;
    int sel[64], nsel = 0;
    if ((rc = cl_device_list(&devices, &e)) ||
        (rc = cl_device_select(&devices, device_sel, sel, &nsel, &e))) {
        spt_report(&e);
        goto done;
    }
    const ClDeviceInfo *devs[64];
    for (int i = 0; i < nsel; i++) {
        devs[i] = &devices.devices[sel[i]];
        if (!quiet)
            fprintf(stderr, "device %d: %s (%s, %s)\n", sel[i], devs[i]->name,
                    devs[i]->platform_name, devs[i]->driver_version);
    }
    const ClDeviceInfo *dev = devs[0];
    if ((rc = gpu_scene_build(&gpu, &scene, &e))) {
        spt_report(&e);
        goto done;
    }

    RenderSettings rs;
    memset(&rs, 0, sizeof rs);
    rs.width = (int)width;
    rs.height = (int)height;
    rs.spp = (int)spp;
    rs.time_limit = time_limit;
    rs.max_depth = (int)depth;
    rs.seed = (uint32_t)seed;
    rs.progress = !quiet;
    rs.profile = profile;
    rs.sky = &sky;
    rs.env_rotation = (float)env_rot;
    rs.env_intensity = (float)env_int;
    rs.aperture = (float)aperture;
    rs.focus_distance = (float)focus;
    rs.stop = &stop_requested;
    stop_requested = 0;
    /* Without emitters or lights the default sky lights the scene
     * (src/render/render_lights.c); only a black sky leaves it dark. */
    if (gpu.emitter_count == 0 && scene.light_count == 0 && sky_is_black(&sky, env_int))
        spt_warn("%s: nothing lights the scene (no emissive surfaces, no lights, a black sky): the "
                 "image will be black", scene_path);
    if ((rc = checkpoint_run_begin(&ckpt, scene_path, ckpt_path, ckpt_every, resume_path, &rs,
                                   &film, &e))) {
        spt_report(&e);
        goto done;
    }
    if (ckpt.resumed && !quiet)
        fprintf(stderr, "resuming %s: %u of %ld samples per pixel done\n", resume_path,
                ckpt.resumed, spp);
    struct sigaction sa, old_int, old_term;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    RenderStats st;
    RenderDeviceStats per_dev[64];
    rc = spt_dist_render ? spt_dist_render(devs, nsel, &gpu, &scene, cam, &rs, &film, &st, per_dev, &e)
                         : render_devices(devs, nsel, &gpu, cam, &rs, &film, &st, per_dev, &e);
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    if (rc) {
        if (e.msg[0])
            spt_report(&e);
        goto done;
    }
    if (st.spp_done == 0) {
        spt_error("render: stopped before any pass completed; nothing written");
        rc = SPT_EXIT_INTERRUPTED;
        goto done;
    }
    if (stop_requested)
        spt_note("render: stopped by a signal after %u of %ld samples per pixel; writing them",
                 st.spp_done, spp);
    if (st.nan_dropped)
        spt_warn("render: %llu samples had NaN or infinite radiance and were dropped",
                 (unsigned long long)st.nan_dropped);
    /* Test hook (README, "Rendering"): SPECTRACE_TEST_FILM_NAN=N makes the first
     * N pixels of the film NaN, as a render gone wrong would leave them. */
    const char *film_nan = getenv("SPECTRACE_TEST_FILM_NAN");
    for (long i = 0, n = film_nan ? atol(film_nan) : 0; i < n && i < width * height; i++)
        film.xyz[3 * i] = NAN;
    size_t bad = film_nonfinite_pixels(&film);
    if (bad) {
        spt_error("render: %zu of %ld pixels came out NaN or infinite (an internal error); "
                  "no output written",
                  bad, width * height);
        rc = SPT_EXIT_FAILURE;
        goto done;
    }
    if (!quiet) {
        fprintf(stderr, "rendered %dx%d, %u spp in %.2f s (%.3f Mpaths/s; program build %.2f s)\n",
                rs.width, rs.height, st.spp_done, st.seconds,
                st.seconds > 0 ? st.paths / st.seconds * 1e-6 : 0.0, st.build_seconds);
        if (profile) {
            static const char *names[5] = {"generate", "extend", "shade", "connect", "accumulate"};
            double tot = 0;
            for (int i = 0; i < 5; i++)
                tot += st.stage_seconds[i];
            for (int i = 0; i < 5; i++)
                fprintf(stderr, "  %-10s %8.3f s  %5.1f%%\n", names[i], st.stage_seconds[i],
                        tot > 0 ? 100.0 * st.stage_seconds[i] / tot : 0.0);
        }
    }
    rgb = spt_malloc((size_t)rs.width * rs.height * 3 * sizeof(float));
    film_to_linear_srgb(&film, rgb);
    ImageMeta meta;
    memset(&meta, 0, sizeof meta);
    meta.spp = (int)st.spp_done;
    meta.render_seconds = st.seconds;
    char devdesc[4096], depth_s[32], nan_s[32];
    if (nsel == 1) {
        snprintf(devdesc, sizeof devdesc, "%s (%s)", dev->name, dev->platform_name);
    } else {
        /* Every device with the samples it rendered and its speed. */
        size_t len = 0;
        devdesc[0] = 0;
        for (int i = 0; i < nsel && len < sizeof devdesc; i++)
            len += (size_t)snprintf(devdesc + len, sizeof devdesc - len,
                                    "%s%s (%s): %u spp, %.3f Mpaths/s%s", i ? "; " : "",
                                    devs[i]->name, devs[i]->platform_name, per_dev[i].samples,
                                    per_dev[i].paths_per_second * 1e-6,
                                    per_dev[i].failed ? ", failed" : "");
        if (!quiet)
            fprintf(stderr, "devices: %s\n", devdesc);
    }
    meta.device = devdesc;
    meta.seed = (uint32_t)seed;
    meta.scene = scene_path;
    snprintf(depth_s, sizeof depth_s, "%ld", depth);
    snprintf(nan_s, sizeof nan_s, "%llu", (unsigned long long)st.nan_dropped);
    image_meta_add(&meta, "max_depth", depth_s);
    image_meta_add(&meta, "nan_dropped", nan_s);
    DisplayOptions disp = {(float)exposure, tonemap};
    for (int i = 0; i < n_out; i++) {
        if ((rc = image_write(outputs[i], rgb, rs.width, rs.height, &meta, &disp, &e))) {
            spt_report(&e);
            goto done;
        }
        if (!quiet)
            fprintf(stderr, "wrote %s\n", outputs[i]);
    }
    if ((rc = checkpoint_run_end(&ckpt, &film, quiet && !stop_requested, &e)))
        spt_report(&e);
done:
    checkpoint_run_free(&ckpt);
    free(rgb);
    film_free(&film);
    gpu_scene_free(&gpu);
    cl_device_list_free(&devices);
    scene_free(&scene);
    sky_free(&sky);
    return rc;
}
