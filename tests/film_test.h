/* Film comparison shared by the tests of split, resumed and distributed renders
 * (test_multidevice, and through ckpt_test.h test_checkpoint and test_mpi). */
#ifndef SPT_FILM_TEST_H
#define SPT_FILM_TEST_H

#include <math.h>

#include "render/film.h"
#include "test_util.h"

/* Every pixel's XYZ sums agree within tol of the pixel's largest channel, and
 * the sample counts are equal. */
static void assert_same_film_tol(const Film *a, const Film *b, double tol)
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

/* The same within 1e-4: the films of one implementation. */
static void assert_same_film(const Film *a, const Film *b)
{
    assert_same_film_tol(a, b, 1e-4);
}

#endif
