/* A loaded Scene (and the Sky of the command line) as one block of bytes and
 * back, so MPI rank 0 can send the scene it read (with its buffers, textures and
 * environment map) to ranks that cannot see the files. Both sides are the same build on the same kind of machine: structs
 * without pointers travel as their bytes; every pointer field (the arrays, the
 * materials' SPDs, the texture texels, the path) is sent by content. A pointer
 * field added to Scene, SceneMaterial or SceneTexture must be added here too. */
#ifndef SPT_SCENE_PACK_H
#define SPT_SCENE_PACK_H

#include <stddef.h>

#include "scene/scene.h"
#include "scene/sky.h"
#include "core/util.h"

/* The bytes of s (malloc'd); *size receives their count. */
void *scene_pack(const Scene *s, size_t *size);

/* Fills s (free with scene_free) from bytes made by scene_pack. A short or
 * inconsistent block: SPT_EXIT_INPUT naming `what`, s left empty. */
int scene_unpack(Scene *s, const void *bytes, size_t size, const char *what, SptError *e);

/* The sky the same way: its bytes (malloc'd), and back (free with sky_free; a
 * short or inconsistent block: SPT_EXIT_INPUT naming `what`, sky left empty). */
void *sky_pack(const Sky *sky, size_t *size);
int sky_unpack(Sky *sky, const void *bytes, size_t size, const char *what, SptError *e);

#endif
