/*
 * pn_tess.c - the tessellation that PN triangles replace, for the time
 * against error benchmark (scripts/bench-pn.sh): every triangle of MESH
 * becomes its PN patch (lancer's own, from the file's vertex normals or
 * angle-weighted ones) tessellated into N x N triangles on its (u, v)
 * grid, with the patch's shading normals as vertex normals, as export-pov
 * writes it for POV-Ray. Written as a NOFF file.
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
    long per = (long)(n + 1) * (n + 2) / 2;
    fprintf(f, "NOFF\n%ld %ld 0\n", per * m.nt, (long)n * n * m.nt);
    for (int t = 0; t < m.nt; t++) {
        Vec3 p[3], nn[3];
        for (int k = 0; k < 3; k++) {
            p[k] = m.v[m.tri[t][k]];
            nn[k] = vec_normalize(m.n[m.ntri[t][k]]);
        }
        PnPatch pn;
        pn_patch_init(&pn, p, nn);
        for (int a = 0; a <= n; a++)
            for (int b = 0; a + b <= n; b++) {
                double pt[3];
                pn_eval(&pn, (double)a / n, (double)b / n, pt, NULL, NULL);
                Vec3 s = pn_shading_normal(&pn, (float)a / (float)n, (float)b / (float)n);
                fprintf(f, "%.9g %.9g %.9g %.9g %.9g %.9g\n", pt[0], pt[1], pt[2], (double)s.x, (double)s.y,
                        (double)s.z);
            }
    }
    /* vertex (a, b), a + b <= n, of patch t */
#define V(t, a, b) ((long)(t) * per + (a) * (n + 1) - (a) * ((a) - 1) / 2 + (b))
    for (int t = 0; t < m.nt; t++)
        for (int a = 0; a < n; a++)
            for (int b = 0; a + b < n; b++) {
                fprintf(f, "3 %ld %ld %ld\n", V(t, a, b), V(t, a + 1, b), V(t, a, b + 1));
                if (a + b < n - 1)
                    fprintf(f, "3 %ld %ld %ld\n", V(t, a + 1, b), V(t, a + 1, b + 1), V(t, a, b + 1));
            }
#undef V
    mesh_free(&m);
    if (fclose(f) != 0) {
        perror(argv[3]);
        return 1;
    }
    return 0;
}
