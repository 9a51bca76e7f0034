/* libFuzzer target for the SPD/CSV reader: the input is the text of a CSV file
 * of `wavelength_nm,value` lines (spd_parse_csv), and a successful parse is
 * integrated to XYZ as `spectrace color` does. */
#include <stddef.h>
#include <stdint.h>

#include "color/spd.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Spd spd;
    SptError e;
    if (spd_parse_csv(&spd, "fuzz.csv", (const char *)data, size, &e) == 0) {
        double xyz[3];
        spd_to_xyz(&spd, xyz);
        spd_reflectance_to_xyz(&spd, xyz);
        spd_free(&spd);
    }
    return 0;
}
