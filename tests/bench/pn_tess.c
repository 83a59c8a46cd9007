/*
 * pn_tess.c - the tessellation that PN triangles replace, for the time
 * against error benchmark (scripts/bench-pn.sh): every triangle of MESH
 * becomes its PN patch (lancer's own, from the file's vertex normals or
 * angle-weighted ones) tessellated into N x N triangles on its (u, v)
 * grid, with the patch's shading normals as vertex normals, as export-pov
 * writes it for POV-Ray (pn_tessellate). Written as a NOFF file.
 *
 *     pn_tess MESH N OUT.off
 */
#include <stdio.h>
#include <stdlib.h>

#include "lancer/mesh.h"
#include "lancer/pntri.h"

int main(int argc, char **argv)
{
    if (argc != 4 || atoi(argv[2]) < 1 || atoi(argv[2]) > 1024) {
        fprintf(stderr, "usage: pn_tess MESH N OUT.off  (N from 1 to 1024)\n");
        return 2;
    }
    int n = atoi(argv[2]);
    Mesh m;
    char err[1024];
    if (mesh_load(argv[1], &m, err, sizeof err) != 0 || (!m.n && mesh_vertex_normals(&m, err, sizeof err) != 0)) {
        fprintf(stderr, "pn_tess: %s\n", err);
        return 1;
    }
    FILE *f = fopen(argv[3], "w");
    if (!f) {
        perror(argv[3]);
        return 1;
    }
    long per = pn_grid_points(n);
    Vec3 *pts = malloc(sizeof(Vec3) * (size_t)per), *nrm = malloc(sizeof(Vec3) * (size_t)per);
    int(*faces)[3] = malloc(sizeof(int[3]) * (size_t)n * (size_t)n);
    if (!pts || !nrm || !faces) {
        fprintf(stderr, "pn_tess: out of memory\n");
        return 1;
    }
    fprintf(f, "NOFF\n%ld %ld 0\n", per * m.nt, (long)n * n * m.nt);
    for (int t = 0; t < m.nt; t++) {
        Vec3 p[3], nn[3];
        for (int k = 0; k < 3; k++) {
            p[k] = m.v[m.tri[t][k]];
            nn[k] = vec_normalize(m.n[m.ntri[t][k]]);
        }
        PnPatch pn;
        pn_patch_init(&pn, p, nn);
        pn_tessellate(&pn, n, pts, nrm, faces);
        for (long k = 0; k < per; k++)
            fprintf(f, "%.9g %.9g %.9g %.9g %.9g %.9g\n", (double)pts[k].x, (double)pts[k].y, (double)pts[k].z,
                    (double)nrm[k].x, (double)nrm[k].y, (double)nrm[k].z);
    }
    /* the faces, after every point: every patch's are the same, from its
     * own points, which start at t * per */
    for (int t = 0; t < m.nt; t++) {
        for (int k = 0; k < n * n; k++)
            fprintf(f, "3 %ld %ld %ld\n", t * per + faces[k][0], t * per + faces[k][1], t * per + faces[k][2]);
    }
    free(pts);
    free(nrm);
    free(faces);
    mesh_free(&m);
    if (fclose(f) != 0) {
        perror(argv[3]);
        return 1;
    }
    return 0;
}
