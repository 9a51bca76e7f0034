/* Film comparison shared by the tests of split, resumed and distributed renders
 * (test_multidevice, and through ckpt_test.h test_checkpoint and test_mpi). */
#ifndef SPT_FILM_TEST_H
#define SPT_FILM_TEST_H

#include <math.h>

#include "render/film.h"
#include "test_util.h"

/* Every pixel's XYZ sums agree within tol of the pixel's largest channel, and
 * the sample counts are equal. */
static inline void assert_same_film_tol(const Film *a, const Film *b, double tol)
{
    assert_int_equal(a->width, b->width);
    size_t n = (size_t)a->width * a->height;
    for (size_t i = 0; i < n; i++) {
        if (a->count[i] != b->count[i])
            fail_msg("pixel %zu: %g vs %g samples", i, a->count[i], b->count[i]);
        double m = 1e-12;
        for (int c = 0; c < 3; c++)
            m = fmax(m, fabs(a->xyz[3 * i + c]));
        for (int c = 0; c < 3; c++)
            if (fabs(a->xyz[3 * i + c] - b->xyz[3 * i + c]) > tol * m)
                fail_msg("pixel %zu channel %d: %.9g vs %.9g", i, c, a->xyz[3 * i + c],
                         b->xyz[3 * i + c]);
    }
}

/* The AOV sums of two films agree within tol of each pixel's largest AOV sum of
 * the same kind (albedo, normal, depth, position, squares). */
static inline void assert_same_aov_tol(const Film *a, const Film *b, double tol)
{
    assert_non_null(a->aov);
    assert_non_null(b->aov);
    static const int first[6] = {SPT_AOV_S_ALBEDO, SPT_AOV_S_N, SPT_AOV_S_Z, SPT_AOV_S_P, SPT_AOV_S_SQ,
                                 SPT_AOV_SUMS};
    size_t n = (size_t)a->width * a->height;
    for (size_t i = 0; i < n; i++)
        for (int g = 0; g < 5; g++) {
            const double *x = a->aov + SPT_AOV_SUMS * i, *y = b->aov + SPT_AOV_SUMS * i;
            double m = 1e-12;
            for (int c = first[g]; c < first[g + 1]; c++)
                m = fmax(m, fabs(x[c]));
            for (int c = first[g]; c < first[g + 1]; c++)
                if (fabs(x[c] - y[c]) > tol * m)
                    fail_msg("pixel %zu AOV sum %d: %.9g vs %.9g", i, c, x[c], y[c]);
        }
}

/* The spectral band sums of two films agree within tol of each pixel's largest
 * band sum. */
static inline void assert_same_bands_tol(const Film *a, const Film *b, double tol)
{
    assert_int_equal(a->bands, b->bands);
    assert_true(a->bands > 0);
    size_t n = (size_t)a->width * a->height;
    for (size_t i = 0; i < n; i++) {
        const double *x = a->spec + i * (size_t)a->bands, *y = b->spec + i * (size_t)b->bands;
        double m = 1e-12;
        for (int k = 0; k < a->bands; k++)
            m = fmax(m, fabs(x[k]));
        for (int k = 0; k < a->bands; k++)
            if (fabs(x[k] - y[k]) > tol * m)
                fail_msg("pixel %zu band %d: %.9g vs %.9g", i, k, x[k], y[k]);
    }
}

/* The same within 1e-4: the films of one implementation. */
static inline void assert_same_film(const Film *a, const Film *b)
{
    assert_same_film_tol(a, b, 1e-4);
}

/* Split invariance of four films of one render: f[0] the samples [0, N), f[1]
 * and f[2] two parts of them, f[3] the same samples with another path pool.
 * The parts' sum equals the whole within 1e-5 relative (float sums in another
 * order), the pool changes nothing, and the image is not black. f[1] is
 * replaced by the sum. */
static inline void assert_split_films(Film f[4], const char *what)
{
    film_add(&f[1], &f[2]);
    size_t n = (size_t)f[0].width * f[0].height;
    double worst = 0, sum = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        worst = fmax(worst, fabs(f[1].xyz[i] - f[0].xyz[i]) / fmax(fabs(f[0].xyz[i]), 1e-6));
        sum += f[0].xyz[i];
    }
    print_message("%s: whole vs parts: largest relative difference %.3g\n", what, worst);
    assert_true(sum > 0.0);
    assert_true(worst < 1e-5);
    assert_memory_equal(f[0].xyz, f[3].xyz, 3 * n * sizeof(double));
}

#endif
