/* The film's extra EXR channels (src/render/film_layers.h). */
#include "render/film_layers.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/util.h"

/* The AOV layers an output may hold: each keeps 3 floats per pixel in
 * L->aov, whichever of them the mask asks for. */
static const struct {
    unsigned bit;
    const char *names[3];
} aov_layer[] = {
    {SPT_AOV_ALBEDO, {"albedo.R", "albedo.G", "albedo.B"}},
    {SPT_AOV_NORMAL, {"N.X", "N.Y", "N.Z"}},
    {SPT_AOV_DEPTH, {"Z", NULL, NULL}},
    {SPT_AOV_POSITION, {"P.X", "P.Y", "P.Z"}},
    {SPT_AOV_VARIANCE, {"variance.R", "variance.G", "variance.B"}},
    {SPT_AOV_SPP, {"spp", NULL, NULL}},
};
#define AOV_LAYERS SPT_FILM_AOV_LAYERS
_Static_assert(sizeof aov_layer / sizeof aov_layer[0] == SPT_FILM_AOV_LAYERS, "one row per layer");

void film_layers_make(FilmLayers *L, const Film *f, unsigned mask, int spare)
{
    memset(L, 0, sizeof *L);
    size_t npix = (size_t)f->width * f->height;
    int nb = f->bands;
    L->channels = spt_malloc((size_t)(3 * AOV_LAYERS + nb + spare) * sizeof(ExrChannel));
    if (mask) {
        L->aov = spt_malloc((size_t)AOV_LAYERS * 3 * npix * sizeof(float));
        for (int l = 0; l < AOV_LAYERS; l++) {
            if (!(mask & aov_layer[l].bit) || (!f->aov && aov_layer[l].bit != SPT_AOV_SPP))
                continue;
            float *px = L->aov + (size_t)l * 3 * npix;
            int channels = film_aov_layer(f, aov_layer[l].bit, px);
            for (int c = 0; c < channels; c++)
                L->channels[L->count++] = (ExrChannel){aov_layer[l].names[c], SPT_EXR_FLOAT, px + c, channels};
        }
    }
    if (nb > 0) {
        L->bands = spt_malloc((size_t)nb * npix * sizeof(float));
        L->band_names = spt_malloc((size_t)nb * sizeof *L->band_names);
        film_spectral_layer(f, L->bands);
        double width = (SPT_SPECTRAL_MAX_NM - SPT_SPECTRAL_MIN_NM) / nb;
        for (int b = 0; b < nb; b++) {
            snprintf(L->band_names[b], sizeof L->band_names[b], "S0.%.6fnm",
                     SPT_SPECTRAL_MIN_NM + (b + 0.5) * width);
            char *dot = strchr(L->band_names[b] + 3, '.');
            if (dot)
                *dot = ',';
            L->channels[L->count++] = (ExrChannel){L->band_names[b], SPT_EXR_FLOAT, L->bands + b, nb};
        }
        L->attrs[0] = (ExrAttr){"spectralLayoutVersion", SPT_EXR_ATTR_STRING, "1.0", 0, 0};
        L->attrs[1] = (ExrAttr){"emissiveUnits", SPT_EXR_ATTR_STRING, "W.m^-2.sr^-1", 0, 0};
        L->attr_count = 2;
    }
}

void film_layers_free(FilmLayers *L)
{
    free(L->aov);
    free(L->bands);
    free(L->band_names);
    free(L->channels);
    memset(L, 0, sizeof *L);
}
