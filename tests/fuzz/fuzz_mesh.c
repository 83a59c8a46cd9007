/*
 * fuzz_mesh.c - one mesh reader (mesh_parse), the format chosen at build
 * time by FUZZ_FORMAT (MESH_OFF, MESH_OBJ, MESH_PLY or MESH_STL; STL both
 * ASCII and binary). A mesh that parses must pass mesh_validate, before and
 * after its vertex normals are computed; one that does not must leave the
 * Mesh empty and a message "fuzz.in:line:col: ...", as the scene's.
 */
#include "fuzz.h"

#include "lancer/mesh.h"

#ifndef FUZZ_FORMAT
#error "FUZZ_FORMAT must name the mesh format"
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Mesh m;
    char err[1024] = "";
    if (mesh_parse(FUZZ_NAME, (const char *)data, size, FUZZ_FORMAT, &m, err, sizeof err) != 0) {
        fuzz_check_message(err, 2, 2);
        fuzz_require(!m.v && !m.n && !m.tri && !m.ntri && !m.nv && !m.nt && !m.nn,
                     "a failed parse left data in the mesh", err);
        return 0;
    }
    fuzz_require(mesh_validate(&m, err, sizeof err) == 0, "a parsed mesh fails mesh_validate", err);
    if (!m.n) {
        fuzz_require(mesh_vertex_normals(&m, err, sizeof err) == 0, "mesh_vertex_normals failed", err);
        fuzz_require(mesh_validate(&m, err, sizeof err) == 0, "the mesh with normals fails mesh_validate", err);
    }
    mesh_free(&m);
    return 0;
}
