/* The film's extra EXR channels: the AOV layers of --aov and the spectral
 * bands of --spectral, as the command line and the library write them
 * (docs/outputs.md). */
#ifndef SPT_FILM_LAYERS_H
#define SPT_FILM_LAYERS_H

#include "io/exr.h"
#include "render/film.h"

/* The AOV layers an output may hold (albedo, N, Z, P, variance, spp). */
#define SPT_FILM_AOV_LAYERS 6

/* The channels, their pixels and names (owned), and the attributes of a
 * spectral EXR; channels has room for `spare` more that the caller adds. */
typedef struct FilmLayers {
    float *aov;           /* the AOV layers' pixels (3 floats per pixel each) */
    float *bands;         /* each band's mean spectral radiance, bands per pixel */
    char (*band_names)[40];
    ExrChannel *channels;
    int count;
    ExrAttr attrs[2];     /* spectralLayoutVersion, emissiveUnits (with bands) */
    int attr_count;
} FilmLayers;

/* The layers of aov_mask (SPT_AOV_*) that f keeps (spp always), as OpenEXR's
 * layer.channel names (as Cycles and Mitsuba write them), then f's bands as
 * the emissive channels of Fichet, Pacanowski and Wilkie 2021 ("An OpenEXR
 * Layout for Spectral Images", JCGT 10(3)): "S0." (Stokes component 0), the
 * band's centre wavelength with a comma as the decimal separator and the unit,
 * e.g. "S0.545,000000nm", each value the band's mean spectral radiance per nm,
 * with the attributes spectralLayoutVersion "1.0" and emissiveUnits
 * "W.m^-2.sr^-1". */
void film_layers_make(FilmLayers *L, const Film *f, unsigned aov_mask, int spare);
void film_layers_free(FilmLayers *L);

#endif
