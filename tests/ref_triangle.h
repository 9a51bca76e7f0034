/* The tests' reference ray-triangle intersection in double precision
 * (Moller and Trumbore 1997), independent of the BVH's watertight test. */
#ifndef SPT_TEST_REF_TRIANGLE_H
#define SPT_TEST_REF_TRIANGLE_H

#include <math.h>

/* 1 when the ray o + t d hits the triangle of vertices v (9 doubles: v0, v1,
 * v2) with t > 0 and all barycentrics >= -eps; *t and *margin (the smallest
 * barycentric) filled. */
static inline int ref_tri_d(const double v[9], const double o[3], const double d[3], double eps,
                            double *t, double *margin)
{
    double e1[3], e2[3], pv[3], tv[3], qv[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = v[3 + a] - v[a];
        e2[a] = v[6 + a] - v[a];
    }
    pv[0] = d[1] * e2[2] - d[2] * e2[1];
    pv[1] = d[2] * e2[0] - d[0] * e2[2];
    pv[2] = d[0] * e2[1] - d[1] * e2[0];
    double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
    if (det == 0.0)
        return 0;
    double inv = 1.0 / det;
    for (int a = 0; a < 3; a++)
        tv[a] = o[a] - v[a];
    double u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) * inv;
    qv[0] = tv[1] * e1[2] - tv[2] * e1[1];
    qv[1] = tv[2] * e1[0] - tv[0] * e1[2];
    qv[2] = tv[0] * e1[1] - tv[1] * e1[0];
    double w = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) * inv;
    double tt = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) * inv;
    double m = fmin(fmin(u, w), 1.0 - u - w);
    if (m < -eps || !(tt > 0.0))
        return 0;
    *t = tt;
    *margin = m;
    return 1;
}

#endif
