/* Light models shared by the kernels and the host tests (C99 and OpenCL C 1.2):
 * punctual lights (glTF KHR_lights_punctual: point, spot, directional) as delta
 * lights, and the environment (an equirectangular map importance-sampled by a
 * piecewise-constant 2D distribution, pbrt-v4 ImageInfiniteLight / PBR book 3rd
 * ed. 14.2.4, or a uniform background). src/render/host_lights.c builds the structs.
 *
 * Units (all spectral, per nm, on the 1 nm grid 360..830):
 *  - point and spot: radiant intensity I(l) in W/(sr nm); the contribution at a
 *    point at distance r is I(l) falloff / r^2 in W/(m^2 nm) (an irradiance on a
 *    surface facing the light; the caller multiplies by the BSDF and cos).
 *  - directional: irradiance E(l) in W/(m^2 nm) on a surface facing the light.
 *  - environment and background: radiance L(l) in W/(m^2 sr nm).
 * glTF's `range` is ignored: the specification allows a renderer to keep the
 * physical inverse-square falloff everywhere.
 *
 * Image units: the film's Y is luminance in cd/m^2 (nits), the unit that
 * KHR_materials_emissive_strength gives glTF's emissive colour (emissive (1,1,1)
 * is D65 of Y = 1) and that makes KHR_lights_punctual's candela and lux agree
 * with it (the convention of the Khronos glTF Sample Viewer). The film stores
 * Y = integral(L ybar) / integral(ybar) (kernels/integrator/path.h path_radiance_to_xyz), so
 * a light's spectra are kept in "film" units: a physical spectral radiance in
 * W/(m^2 sr nm) is multiplied by 683 lm/W * integral(ybar) = 72982.3
 * (SPT_LIGHT_FILM_PER_WATT). Example: a white Lambertian (albedo 1) facing a
 * 1 cd point light at 1 m has Lv = 1/pi cd/m^2 and film Y = 1/pi. An environment
 * texel or a background of linear RGB (1,1,1) becomes D65 of film Y = 1.
 *
 * Integration (renderer): src/render/host_lights.c lights_build_selection makes one CDF over
 * [emissive triangles | punctual lights | environment]. Next-event estimation
 * picks an entry with spt_discrete_sample (probability P). Triangle: as before,
 * pdf = P / area (converted to solid angle). Punctual: light_punctual_sample,
 * contribution f cos value / P, no MIS (delta). Environment: env_sample_at gives
 * wi and pdf (for the shading point's normal and sides); the light-sampling pdf
 * is P_env * pdf, MIS-weighted against the BSDF pdf; a BSDF ray that escapes adds
 * env_eval weighted by the power heuristic of its BSDF pdf against
 * P_env * env_pdf_at(wi) at the vertex it left. The GpuEnvMap is passed by pointer
 * to a private copy (e.g. a kernel parameter or a struct read from a buffer). */
#ifndef SPT_LIGHTS_H
#define SPT_LIGHTS_H

#include "util/portable.h"
#include "util/vecmath.h"
#include "sample/sampling.h"
#include "spectrum/spectrum.h"
#include "util/render_types.h"

/* Film Y of one cd/m^2 (the film's unit is the nit). */
#define SPT_LIGHT_FILM_Y_PER_NIT 1.0f
/* Film units of one W/(m^2 sr nm) of spectral radiance (or W/(sr nm), W/(m^2 nm)):
 * 683 lm/W * integral(ybar dl). */
#define SPT_LIGHT_FILM_PER_WATT (683.0f * SPT_CIE_Y_INTEGRAL)

/* The distance reported for a directional light or the environment: a finite
 * stand-in for infinity, so code built with -cl-fast-relaxed-math (which may
 * assume no infinities) still compares it correctly; use it as a shadow ray's
 * t_max. */
#define SPT_LIGHT_FAR 1e30f

/* GpuLight, GpuEnvMap and their kinds are in render_types.h (kernel parameters). */

/* What a light sample gives the shading point: the unit direction toward the
 * light, the distance to it (SPT_LIGHT_FAR when at infinity), the contribution at
 * the four wavelengths (see units above) and the pdf (solid angle; 1 for a delta
 * light, which must not be weighted by MIS). */
typedef struct LightSample {
    vec3 wi;
    float dist;
    float value[SPT_NUM_LAMBDA];
    float pdf;
    spt_i32 is_delta;
} LightSample;

/* Linear interpolation of a 1 nm table t (SPT_CIE_SAMPLES floats) at lambda; 0
 * outside 360..830 nm. */
SPT_FN float light_table_lerp(const SPT_GLOBAL float *t, float lambda)
{
    SPT_TABLE_LERP(t, lambda);
}

/* The value of spectrum s at lambda (nm): see SpecRef in render_types.h. Tables
 * are read from spectra + s.offset. SPT_SPEC_NONE gives 0. */
SPT_FN float light_spec_value(SpecRef s, const SPT_GLOBAL float *spectra, float lambda)
{
    if (s.kind == SPT_SPEC_SIGMOID) {
        float v = s.scale * spt_sigmoid_poly(s.c[0], s.c[1], s.c[2], lambda);
        if (s.flags & SPT_SPEC_ILLUMINANT)
            v *= spt_d65_norm(lambda);
        return v;
    }
    if (s.kind == SPT_SPEC_TABLE)
        return s.scale * light_table_lerp(spectra + s.offset, lambda);
    return 0.0f;
}

/* 1 - cos of the angle between unit vectors a and b, without cancellation
 * near 0: sin^2 / (1 + cos) from the cross product while cos > 0. */
SPT_FN float light_one_minus_cos(vec3 a, vec3 b)
{
    float c = v3_dot(a, b);
    if (!(c > 0.0f))
        return 1.0f - c;
    vec3 k = v3_cross(a, b);
    return v3_dot(k, k) / (1.0f + c);
}

/* The spot factor of light l for a direction whose angle with l->dir has
 * 1 - cos = x (light_one_minus_cos): the KHR_lights_punctual smooth falloff
 * (see GpuLight), in [0, 1]; 1 for point and directional lights. */
SPT_FN float light_spot_falloff(const SPT_GLOBAL GpuLight *l, float x)
{
    if (l->type != SPT_PUNCTUAL_SPOT)
        return 1.0f;
    float t = fminf(fmaxf((l->spot_span - x) * l->spot_scale, 0.0f), 1.0f);
    return t * t;
}

/* ---- Light paths aimed at the caustic spheres (kernels/integrator/light_trace.h) ---- */

/* Whether the ray from o along unit d meets caustic sphere k of p, or starts
 * in it. */
SPT_FN int lt_meets_caustic(const RenderParams *p, spt_u32 k, vec3 o, vec3 d)
{
    vec3 v = v3_sub(v3(p->caustic[4 * k + 0], p->caustic[4 * k + 1], p->caustic[4 * k + 2]), o);
    float r = p->caustic[4 * k + 3];
    float v2 = v3_dot(v, v), t = v3_dot(v, d);
    return v2 <= r * r || (t > 0.0f && v2 - t * t <= r * r);
}

/* 1 - cos of the half angle of the cone that caustic sphere k subtends from q,
 * without cancellation for small cones; 0 when q is near the sphere or in it
 * (sin^2 of the half angle 0.9 or more: most directions meet it anyway). */
SPT_FN float lt_caustic_span(const RenderParams *p, spt_u32 k, vec3 q)
{
    vec3 v = v3_sub(v3(p->caustic[4 * k + 0], p->caustic[4 * k + 1], p->caustic[4 * k + 2]), q);
    float r = p->caustic[4 * k + 3];
    float s2 = r * r / v3_dot(v, v);
    return s2 < 0.9f ? s2 / (1.0f + sqrtf(1.0f - s2)) : 0.0f;
}

/* Whether a light path from q is aimed at the caustic spheres (the spheres of
 * the surfaces that may be delta, p->caustic): when there are some and q lies
 * outside each of them by a margin (lt_caustic_span). Then 1, with the sum of
 * their cones' solid angles in *omega (lt_aim_dir samples a cone in
 * proportion to its solid angle, then uniformly within it); else 0. The
 * host's sizing of the pass (src/render/scheduler.c, caustic_share) calls it
 * too. */
SPT_FN int lt_aim_cones(const RenderParams *p, vec3 q, float *omega)
{
    if (p->caustic_count == 0u)
        return 0;
    float total = 0.0f;
    for (spt_u32 k = 0; k < p->caustic_count; k++) {
        float span = lt_caustic_span(p, k, q);
        if (!(span > 0.0f))
            return 0;
        total += 2.0f * SPT_PI * span;
    }
    *omega = total;
    return 1;
}

/* Whether punctual light l's (a point or spot light's) light paths are aimed:
 * lt_aim_cones at its position, and for a spot only when those cones' solid
 * angle is below the spot's. */
SPT_FN int lt_aims_punctual(const RenderParams *p, const SPT_GLOBAL GpuLight *l, float *omega)
{
    if (l->type == SPT_PUNCTUAL_DIRECTIONAL || !lt_aim_cones(p, v3(l->pos[0], l->pos[1], l->pos[2]), omega))
        return 0;
    return l->type != SPT_PUNCTUAL_SPOT || *omega < 2.0f * SPT_PI * l->spot_span;
}

/* Samples punctual light l from shading point p: fills s with the direction to
 * the light, the distance, and value[i] = I(lambda[i]) falloff / r^2 (point,
 * spot) or E(lambda[i]) (directional), pdf 1 and is_delta 1. A point at the
 * light's position gets value 0 (and wi = +Y, dist 0). */
SPT_FN void light_punctual_sample(const SPT_GLOBAL GpuLight *l, const SPT_GLOBAL float *spectra,
                                  vec3 p, const float *lambda, LightSample *s)
{
    float factor;
    s->pdf = 1.0f;
    s->is_delta = 1;
    if (l->type == SPT_PUNCTUAL_DIRECTIONAL) {
        s->wi = v3(-l->dir[0], -l->dir[1], -l->dir[2]);
        s->dist = SPT_LIGHT_FAR;
        factor = 1.0f;
    } else {
        vec3 d = v3_sub(v3(l->pos[0], l->pos[1], l->pos[2]), p);
        float r2 = v3_dot(d, d);
        if (!(r2 > 0.0f)) {
            s->wi = v3(0.0f, 1.0f, 0.0f);
            s->dist = 0.0f;
            for (int i = 0; i < SPT_NUM_LAMBDA; i++)
                s->value[i] = 0.0f;
            return;
        }
        float r = sqrtf(r2);
        s->wi = v3_scale(d, 1.0f / r);
        s->dist = r;
        /* The spot axis against the direction from the light to p (-wi). */
        float x = light_one_minus_cos(v3_scale(s->wi, -1.0f), v3(l->dir[0], l->dir[1], l->dir[2]));
        factor = light_spot_falloff(l, x) / r2;
    }
    for (int i = 0; i < SPT_NUM_LAMBDA; i++)
        s->value[i] = factor * light_spec_value(l->spectrum, spectra, lambda[i]);
}

/* ---- Environment ------------------------------------------------------------- */

/* A world direction turned into the map's frame (inverse of the rotation). */
SPT_FN vec3 env_to_map(const GpuEnvMap *env, vec3 d)
{
    return v3(env->rot_cos * d.x - env->rot_sin * d.z, d.y, env->rot_sin * d.x + env->rot_cos * d.z);
}

/* A map-frame direction turned into the world frame (the rotation). */
SPT_FN vec3 env_to_world(const GpuEnvMap *env, vec3 d)
{
    return v3(env->rot_cos * d.x + env->rot_sin * d.z, d.y, -env->rot_sin * d.x + env->rot_cos * d.z);
}

/* The map coordinates (u, v) in [0,1]^2 of world direction d (unit), and
 * sin(theta); see GpuEnvMap for the convention. */
SPT_FN void env_dir_to_uv(const GpuEnvMap *env, vec3 d, float *u, float *v, float *sin_theta)
{
    vec3 m = env_to_map(env, d);
    float cy = fminf(fmaxf(m.y, -1.0f), 1.0f);
    float phi = atan2f(-m.x, m.z);
    if (phi < 0.0f)
        phi += 2.0f * SPT_PI;
    *u = fminf(phi * SPT_INV_2PI, SPT_ONE_MINUS_EPSILON);
    *v = fminf(acosf(cy) * SPT_INV_PI, SPT_ONE_MINUS_EPSILON);
    *sin_theta = sqrtf(fmaxf(0.0f, 1.0f - cy * cy));
}

/* The texel (x, y) containing map coordinates (u, v), clamped to the map. */
SPT_FN void env_texel_of(const GpuEnvMap *env, float u, float v, spt_i32 *x, spt_i32 *y)
{
    spt_i32 ix = (spt_i32)(u * (float)env->width), iy = (spt_i32)(v * (float)env->height);
    *x = ix < 0 ? 0 : (ix >= env->width ? env->width - 1 : ix);
    *y = iy < 0 ? 0 : (iy >= env->height ? env->height - 1 : iy);
}

/* Radiance (W/(m^2 sr nm)) arriving from world direction d (unit, pointing away
 * from the scene) at the four wavelengths: the map's texel (nearest, the same
 * piecewise-constant function the sampling distribution follows), or the uniform
 * background; 0 for SPT_ENV_NONE. */
SPT_FN void env_eval(const GpuEnvMap *env, const SPT_GLOBAL float *data, vec3 d,
                     const float *lambda, float *out)
{
    if (env->kind == SPT_ENV_MAP) {
        float u, v, st;
        spt_i32 x, y;
        env_dir_to_uv(env, d, &u, &v, &st);
        env_texel_of(env, u, v, &x, &y);
        const SPT_GLOBAL float *t = data + env->texel_offset + 4u * (spt_u32)(y * env->width + x);
        for (int i = 0; i < SPT_NUM_LAMBDA; i++)
            out[i] = t[3] * spt_sigmoid_poly(t[0], t[1], t[2], lambda[i]) * spt_d65_norm(lambda[i]);
        return;
    }
    for (int i = 0; i < SPT_NUM_LAMBDA; i++)
        out[i] = env->kind == SPT_ENV_UNIFORM ? light_spec_value(env->uniform, data, lambda[i]) : 0.0f;
}

/* Solid-angle density with which env_sample picks world direction d (unit):
 * p(u, v) / (2 pi^2 sin(theta)) for a map, p(u, v) = W H P(row) P(column | row);
 * 1/(4 pi) for the uniform background; 0 for SPT_ENV_NONE or at the poles. */
SPT_FN float env_pdf(const GpuEnvMap *env, const SPT_GLOBAL float *data, vec3 d)
{
    if (env->kind == SPT_ENV_UNIFORM)
        return spt_pdf_uniform_sphere();
    if (env->kind != SPT_ENV_MAP)
        return 0.0f;
    float u, v, st;
    spt_i32 x, y;
    env_dir_to_uv(env, d, &u, &v, &st);
    if (!(st > 0.0f))
        return 0.0f;
    env_texel_of(env, u, v, &x, &y);
    const SPT_GLOBAL float *cond = data + env->conditional_offset + (spt_u32)y * (spt_u32)(env->width + 1);
    float p = spt_discrete_pdf(data + env->marginal_offset, (spt_u32)y) *
              spt_discrete_pdf(cond, (spt_u32)x) * (float)(env->width * env->height);
    return p / (2.0f * SPT_PI * SPT_PI * st);
}

/* A world direction toward the environment from uniform (u1, u2) in [0,1)^2, with
 * its solid-angle pdf in *pdf (equal to env_pdf of the direction): a map picks a
 * row by the marginal CDF (u2) and a texel by its row's CDF (u1), then a uniform
 * point in the texel in (u, v); the uniform background samples the sphere
 * uniformly. *pdf is 0 (and the direction +Y) when nothing can be sampled. */
SPT_FN vec3 env_sample(const GpuEnvMap *env, const SPT_GLOBAL float *data, float u1, float u2,
                       float *pdf)
{
    if (env->kind == SPT_ENV_UNIFORM) {
        *pdf = spt_pdf_uniform_sphere();
        return spt_sample_uniform_sphere(u1, u2);
    }
    *pdf = 0.0f;
    if (env->kind != SPT_ENV_MAP)
        return v3(0.0f, 1.0f, 0.0f);
    float prow, pcol, fy, fx;
    spt_i32 y = spt_discrete_sample(data + env->marginal_offset, (spt_u32)env->height, u2, &prow, &fy);
    if (y < 0)
        return v3(0.0f, 1.0f, 0.0f);
    const SPT_GLOBAL float *cond = data + env->conditional_offset + (spt_u32)y * (spt_u32)(env->width + 1);
    spt_i32 x = spt_discrete_sample(cond, (spt_u32)env->width, u1, &pcol, &fx);
    if (x < 0)
        return v3(0.0f, 1.0f, 0.0f);
    float u = ((float)x + fx) / (float)env->width;
    float v = ((float)y + fy) / (float)env->height;
    float theta = SPT_PI * v, phi = 2.0f * SPT_PI * u;
    float st = sinf(theta);
    if (!(st > 0.0f))
        return v3(0.0f, 1.0f, 0.0f);
    vec3 m = v3(-sinf(phi) * st, cosf(theta), cosf(phi) * st);
    *pdf = prow * pcol * (float)(env->width * env->height) / (2.0f * SPT_PI * SPT_PI * st);
    return env_to_world(env, m);
}

/* Next-event estimation of the environment from a surface point whose BSDF is
 * zero but on the side of the unit shading normal n (two_sided 0), or on both
 * sides (two_sided 1, a transmissive surface); t and b complete n's frame.
 * The uniform background is sampled in proportion to |cos| to n over those sides
 * (density cos/pi on one side, |cos|/(2 pi) over both; u1 < 1/2 picks n's side,
 * then is stretched back to [0,1)), so none of its samples falls below a point's
 * horizon, where the BSDF is 0, and a Lambertian surface's estimate is exact.
 * A map keeps env_sample's distribution over the sphere. The density is
 * env_pdf_at of the direction. */
SPT_FN vec3 env_sample_at(const GpuEnvMap *env, const SPT_GLOBAL float *data, vec3 n, vec3 t, vec3 b,
                          spt_i32 two_sided, float u1, float u2, float *pdf)
{
    if (env->kind != SPT_ENV_UNIFORM)
        return env_sample(env, data, u1, u2, pdf);
    float side = 1.0f, share = 1.0f;
    if (two_sided) {
        share = 0.5f;
        if (u1 < 0.5f) {
            u1 = 2.0f * u1;
        } else {
            u1 = 2.0f * u1 - 1.0f;
            side = -1.0f;
        }
        u1 = fminf(u1, SPT_ONE_MINUS_EPSILON);
    }
    vec3 l = spt_sample_cosine_hemisphere(u1, u2);
    *pdf = share * l.z * SPT_INV_PI;
    return v3_add(v3_add(v3_scale(t, l.x), v3_scale(b, l.y)), v3_scale(n, side * l.z));
}

/* The solid-angle density with which env_sample_at picks world direction d (unit)
 * at a point of normal n with the BSDF's sides two_sided: what next-event
 * estimation's MIS weight needs for a BSDF-sampled ray that escapes. */
SPT_FN float env_pdf_at(const GpuEnvMap *env, const SPT_GLOBAL float *data, vec3 n, spt_i32 two_sided, vec3 d)
{
    if (env->kind != SPT_ENV_UNIFORM)
        return env_pdf(env, data, d);
    float c = v3_dot(n, d);
    if (two_sided)
        return 0.5f * fabsf(c) * SPT_INV_PI;
    return c > 0.0f ? c * SPT_INV_PI : 0.0f;
}

#endif
