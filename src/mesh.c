/*
 * mesh.c - triangle meshes: the choice of reader by format (mesh_off.c,
 * mesh_obj.c, mesh_ply.c, mesh_stl.c, which build the mesh through
 * mesh_build.c), loading from a file, vertex normals and the mesh's
 * validate function.
 */
#include "mesh_read.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "lancer/afile.h"
#include "lancer/thread.h"
#include "dvec.h"

/* ---- public ---- */

int mesh_parse(const char *name, const char *data, size_t len, MeshFormat fmt, Mesh *m, char *err, size_t errlen)
{
    LexReader R;
    MeshBuild B;
    memset(m, 0, sizeof *m);
    memset(&B, 0, sizeof B);
    if (errlen > 0)
        err[0] = '\0';
    if (!data)
        data = "", len = 0;
    R.name = name;
    R.data = data;
    R.end = data + len;
    R.p = data;
    R.line = 0;
    R.ls = R.lf_from = R.lf = R.cr_from = R.cr = NULL;
    R.err = err;
    R.errlen = errlen;
    R.p += lex_bom_len(R.p, R.end);
    int rc;
    switch (fmt) {
    case MESH_OFF:
        rc = mesh_read_off(&R, &B);
        break;
    case MESH_OBJ:
        rc = mesh_read_obj(&R, &B);
        break;
    case MESH_PLY:
        rc = mesh_read_ply(&R, &B);
        break;
    case MESH_STL:
        rc = mesh_read_stl(&R, &B);
        break;
    default:
        rc = lex_fail(&R, 1, NULL, "unknown mesh format %d", (int)fmt);
        break;
    }
    if (rc != 0) {
        mesh_free(&B.m);
        return -1;
    }
    *m = B.m;
    return 0;
}

int mesh_format_from_path(const char *path, MeshFormat *fmt)
{
    static const struct {
        const char *ext;
        MeshFormat fmt;
    } exts[] = {{"off", MESH_OFF}, {"obj", MESH_OBJ}, {"ply", MESH_PLY}, {"stl", MESH_STL}};
    const char *dot = strrchr(path, '.');
    if (!dot || strchr(dot, '/'))
        return -1;
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++)
        if (strcasecmp(dot + 1, exts[i].ext) == 0) {
            *fmt = exts[i].fmt;
            return 0;
        }
    return -1;
}

typedef struct {
    const char *buf;
    size_t len;
    unsigned char *out;
} HashJob;

static void *hash_bytes(void *arg)
{
    HashJob *j = arg;
    Sha256 h;
    sha256_init(&h);
    sha256_update(&h, j->buf, j->len);
    sha256_final(&h, j->out);
    return NULL;
}

int mesh_load(const char *path, Mesh *m, char *err, size_t errlen)
{
    MeshFormat fmt;
    char *buf;
    size_t len;
    memset(m, 0, sizeof *m);
    if (mesh_format_from_path(path, &fmt) != 0) {
        snprintf(err, errlen, "%s: unknown mesh format (the name must end in .off, .obj, .ply or .stl)", path);
        return -1;
    }
    if (afile_read(path, (unsigned long long)LIMIT_MESH_BYTES, "meshes", &buf, &len, err, errlen) != 0)
        return -1;
    /* The digest on another thread, beside the parse: both only read buf,
     * and the parse takes longer. */
    unsigned char digest[SHA256_BYTES];
    HashJob job = {buf, len, digest};
    pthread_t tid;
    int threaded = thread_start(&tid, hash_bytes, &job) == 0;
    if (!threaded)
        hash_bytes(&job);
    int rc = mesh_parse(path, buf, len, fmt, m, err, errlen);
    if (threaded)
        pthread_join(tid, NULL);
    if (rc == 0)
        memcpy(m->sha256, digest, SHA256_BYTES);
    free(buf);
    return rc;
}

void mesh_free(Mesh *m)
{
    MESH_FREE(m->v);
    MESH_FREE(m->n);
    MESH_FREE(m->tri);
    MESH_FREE(m->ntri);
    memset(m, 0, sizeof *m);
}

/* The angle between u and w, well conditioned near 0 and pi. */
static double d3_angle(const double u[3], const double w[3])
{
    double c[3];
    d3_cross(c, u, w);
    return atan2(sqrt(d3_dot(c, c)), d3_dot(u, w));
}

/* Unit normal of triangle i into fn. Returns 0, or -1 when it has no
 * direction in double (a sliver whose cross product rounds to zero). */
static int face_normal(const Mesh *m, int i, double fn[3], double e[3][3])
{
    const int *c = m->tri[i];
    d3_sub(e[0], m->v[c[1]], m->v[c[0]]); /* c0 -> c1 */
    d3_sub(e[1], m->v[c[2]], m->v[c[1]]); /* c1 -> c2 */
    d3_sub(e[2], m->v[c[0]], m->v[c[2]]); /* c2 -> c0 */
    d3_cross(fn, e[0], e[1]);
    double len = sqrt(d3_dot(fn, fn));
    if (!(len > 0) || !isfinite(len))
        return -1;
    for (int k = 0; k < 3; k++)
        fn[k] /= len;
    return 0;
}

int mesh_zero_normal(const Mesh *m)
{
    int first = -1;
    for (int i = 0; m->n && i < m->nt; i++)
        for (int k = 0; k < 3; k++) {
            const int j = m->ntri[i][k];
            const Vec3 n = m->n[j];
            if (n.x == 0.0f && n.y == 0.0f && n.z == 0.0f && (first < 0 || j < first))
                first = j;
        }
    return first;
}

int mesh_vertex_normals(Mesh *m, char *err, size_t errlen)
{
    if (m->nt == 0 || m->nv == 0) {
        mesh_drop_normals(m);
        return 0;
    }
    size_t nv = (size_t)m->nv, nt = (size_t)m->nt, all = nt + (size_t)m->nline;
    double *acc = mesh_array(NULL, 0, nv, 3 * sizeof *acc);
    unsigned char *state = mesh_array(NULL, 0, nv, 1); /* 0 unused, 1 used, 2 waiting for a fallback */
    Vec3 *n = mesh_array(NULL, 0, nv, sizeof *n);
    int(*ntri)[3] = mesh_array(NULL, 0, all, sizeof *ntri);
    if (!acc || !state || !n || !ntri) {
        MESH_FREE(acc), MESH_FREE(state), MESH_FREE(n), MESH_FREE(ntri);
        snprintf(err, errlen, "out of memory for the normals of %d vertices", m->nv);
        return -1;
    }
    memset(acc, 0, nv * 3 * sizeof *acc);
    memset(state, 0, nv);
    for (size_t i = 0; i < nt; i++) {
        double fn[3], e[3][3];
        for (int k = 0; k < 3; k++)
            state[m->tri[i][k]] = 1;
        if (face_normal(m, (int)i, fn, e) != 0)
            continue;
        for (int k = 0; k < 3; k++) {
            /* corner k lies between edge k (leaving it) and edge k-1 (arriving) */
            double in[3], *out = e[k], *prev = e[(k + 2) % 3];
            for (int a = 0; a < 3; a++)
                in[a] = -prev[a];
            double w = d3_angle(out, in);
            double *s = acc + 3 * (size_t)m->tri[i][k];
            for (int a = 0; a < 3; a++)
                s[a] += w * fn[a];
        }
    }
    int waiting = 0;
    for (size_t v = 0; v < nv; v++) {
        double *s = acc + 3 * v, len = sqrt(d3_dot(s, s));
        if (len > 0 && isfinite(len)) {
            n[v] = vec3((float)(s[0] / len), (float)(s[1] / len), (float)(s[2] / len));
        } else {
            n[v] = vec3(0, 0, 0);
            if (state[v] == 1)
                state[v] = 2, waiting++;
        }
    }
    for (size_t i = 0; i < nt && waiting > 0; i++) { /* sums that cancelled: the first triangle's normal */
        double fn[3], e[3][3];
        if (face_normal(m, (int)i, fn, e) != 0)
            continue;
        for (int k = 0; k < 3; k++) {
            int v = m->tri[i][k];
            if (state[v] == 2) {
                n[v] = vec3((float)fn[0], (float)fn[1], (float)fn[2]);
                state[v] = 1, waiting--;
            }
        }
    }
    memcpy(ntri, m->tri, all * sizeof *ntri); /* (the collinear ones' corners too: no area, no weight) */
    MESH_FREE(acc);
    MESH_FREE(state);
    mesh_drop_normals(m);
    m->n = n;
    m->nn = m->nv;
    m->ntri = ntri;
    return 0;
}

int mesh_validate(const Mesh *m, char *err, size_t errlen)
{
#define BAD(...) return snprintf(err, errlen, __VA_ARGS__), -1
    if (m->nv < 0 || m->nn < 0 || m->nt < 0 || m->nline < 0 || m->degenerate < 0)
        BAD("negative count");
    if (m->nt == 0 && m->nline > 0)
        BAD("%d collinear triangles without triangles", m->nline);
    if ((m->nv > 0) != (m->v != NULL))
        BAD("nv is %d but v is %s", m->nv, m->v ? "set" : "NULL");
    if ((m->nt > 0) != (m->tri != NULL))
        BAD("nt is %d but tri is %s", m->nt, m->tri ? "set" : "NULL");
    if ((m->n != NULL) != (m->ntri != NULL) || (m->n != NULL) != (m->nn > 0))
        BAD("normals half present (n %s, nn %d, ntri %s)", m->n ? "set" : "NULL", m->nn, m->ntri ? "set" : "NULL");
    if (m->ntri && m->nt == 0)
        BAD("normals without triangles");
    for (int i = 0; i < m->nv; i++)
        if (!vec_is_finite(m->v[i]))
            BAD("vertex %d is not finite", i);
    for (int i = 0; i < m->nn; i++)
        if (!vec_is_finite(m->n[i]))
            BAD("normal %d is not finite", i);
    for (int i = 0; i < m->nt + m->nline; i++) {
        for (int k = 0; k < 3; k++) {
            if (m->tri[i][k] < 0 || m->tri[i][k] >= m->nv)
                BAD("triangle %d: vertex index %d out of range (%d vertices)", i, m->tri[i][k], m->nv);
            if (m->ntri && (m->ntri[i][k] < 0 || m->ntri[i][k] >= m->nn))
                BAD("triangle %d: normal index %d out of range (%d normals)", i, m->ntri[i][k], m->nn);
        }
        if (i < m->nt && mesh_tri_degenerate(m->v, m->tri[i]))
            BAD("triangle %d has zero area", i);
        if (i >= m->nt && !mesh_tri_line(m->v, m->tri[i]))
            BAD("triangle %d is not collinear with three distinct corners", i);
    }
#undef BAD
    return 0;
}
