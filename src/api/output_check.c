/* Outputs against inputs (src/api/output_check.h). */
#include "api/output_check.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "io/atomic_file.h"

/* An output's identity: the file it would replace (device and inode) when that
 * exists, else its folder's device and inode and its name. */
typedef struct OutputId {
    int exists;
    struct stat st;
    char name[NAME_MAX + 1];
} OutputId;

static void output_id(const char *path, OutputId *id)
{
    memset(id, 0, sizeof *id);
    if (stat(path, &id->st) == 0) {
        id->exists = 1;
        return;
    }
    char real[PATH_MAX], dir[PATH_MAX];
    const char *base;
    atomic_resolve(path, real, sizeof real);
    atomic_split_path(real, dir, sizeof dir, &base);
    snprintf(id->name, sizeof id->name, "%s", base);
    if (stat(dir, &id->st) != 0)
        memset(&id->st, 0, sizeof id->st);
}

static int same_output(const OutputId *a, const OutputId *b)
{
    return a->exists == b->exists && a->st.st_dev == b->st.st_dev &&
           a->st.st_ino == b->st.st_ino && !strcmp(a->name, b->name);
}

int outputs_check_not_inputs(const InputList *inputs, const char *const *outputs, int count,
                             const char *checkpoint, const char *resume, SptError *e)
{
    const char *ckpt = checkpoint ? checkpoint : resume;
    int n = count + (ckpt ? 1 : 0);
    OutputId *ids = spt_calloc((size_t)(n ? n : 1), sizeof *ids);
    const char **names = spt_calloc((size_t)(n ? n : 1), sizeof *names);
    for (int i = 0; i < count; i++)
        names[i] = outputs[i];
    if (ckpt)
        names[n - 1] = ckpt;
    struct stat resume_st;
    int have_resume = resume && stat(resume, &resume_st) == 0;
    int rc = SPT_EXIT_OK;
    for (int i = 0; i < n && !rc; i++) {
        output_id(names[i], &ids[i]);
        const char *input = ids[i].exists ? input_list_match(inputs, &ids[i].st) : NULL;
        int is_ckpt = ckpt && i == n - 1;
        if (input)
            rc = spt_fail(e, SPT_EXIT_USAGE, "%s: this %s is the input file %s; writing it "
                          "would destroy it (choose another name)", names[i],
                          is_ckpt ? "checkpoint" : "output", input);
        else if (!is_ckpt && have_resume && ids[i].exists &&
                 ids[i].st.st_dev == resume_st.st_dev && ids[i].st.st_ino == resume_st.st_ino)
            rc = spt_fail(e, SPT_EXIT_USAGE, "%s: this output is the checkpoint %s being "
                          "resumed (choose another name)", names[i], resume);
        for (int k = 0; k < i && !rc; k++)
            if (same_output(&ids[i], &ids[k]))
                rc = spt_fail(e, SPT_EXIT_USAGE, "-o %s and %s %s name the same file (give "
                              "each output its own name)", names[k],
                              !is_ckpt ? "-o" : checkpoint ? "--checkpoint" : "--resume",
                              names[i]);
    }
    free(ids);
    free(names);
    return rc;
}
