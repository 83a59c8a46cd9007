/*
 * cmd_bench.c - lancer bench: benchmark rays for a mesh, timed ray casting,
 * and the BVH's build series.
 */
#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "bench.h"
#include "cli.h"
#include "clock.h"
#include "lancer/afile.h"
#include "lancer/image.h"
#include "lancer/rayfile.h"

static const char usage[] =
    "usage: lancer bench --gen-rays MESH OUTDIR [W H] [--tight]\n"
    "       lancer bench --mesh MESH [--pn [--pn-mode M]] --rays FILE --kind closest|any|packet|stream\n"
    "                    [--passes N] [--classic] [--threads N]\n"
    "       lancer bench --build-series MESH [--max-mtris M] [--classic]\n"
    "\n"
    "The first form writes OUTDIR/primary.rays, shadow.rays and diffuse.rays\n"
    "(OUTDIR made if missing) for a W x H camera framing the mesh (default\n"
    "1024 x 1024): one ray per pixel; from each hit, one to a point light and\n"
    "one in a random direction of the hemisphere, shuffled. With --tight, the\n"
    "camera looks at the surface seen at the centre, its view narrowed until\n"
    "90% of the rays hit.\n"
    "Ray files: \"LNCRAYS1\", a uint64 count, and\n"
    "per ray 8 little-endian float32 ox oy oz dx dy dz tmin tmax.\n"
    "\n"
    "The second builds the BVH over the mesh, traces every ray of FILE on one\n"
    "thread (closest hit, any hit, closest hits eight neighbouring rays at a\n"
    "time, as the renderer traces camera rays, or closest hits of the whole file\n"
    "at once, in an order of lancer's own for incoherent rays) for one warm-up\n"
    "and N timed passes (default 3), and prints one line:\n"
    "  mrays=<best Mrays/s> hits=<hits> sumt=<sum of t over hits> build_ms=<build> rays=<count>\n"
    "With --pn, every triangle is a PN patch of the mesh's vertex normals\n"
    "(angle-weighted where the file has none), traced in mode M, exact or fast\n"
    "(default exact).\n"
    "\n"
    "The third builds the BVH over the mesh, then splits every triangle in two\n"
    "and builds again, up to M million triangles (default 10), printing build\n"
    "times on 1 and 2 threads and memory per triangle for each size.\n"
    "\n"
    "options:\n"
    "      --tight      (--gen-rays) frame the mesh tightly: most rays hit\n"
    "      --passes N   timed passes (default 3)\n"
    "      --classic    the classic intersection routines, not the robust ones\n"
    "      --pn         trace the mesh's PN surface, not its flat triangles\n"
    "      --pn-mode M  exact (default) or fast\n"
    "      --threads N  threads for the BVH build (default 1)\n"
    "      --max-mtris M  (--build-series) the last size, in millions of\n"
    "                   triangles (1 to 100, default 10)\n"
    "  -h, --help       show this help\n";

typedef struct {
    const char *gen, *mesh, *rays, *kind, *series, *pn_mode;
    int passes, classic, threads, max_mtris, pn, tight;
} Args;

/* 0: not given (each takes 1 at least), which run() checks before it
 * puts the defaults in. */
static void defaults(void *args) { (void)args; }

enum { FORM_GEN = 1, FORM_MESH = 2, FORM_SERIES = 4 };

/* A usage error for the first option given that form does not take, else
 * 0 (--classic goes with every form). */
static int stray_option(const Args *a, unsigned form)
{
    const struct {
        const char *name;
        int given;
        unsigned forms;
    } opt[] = {
        {"--gen-rays", a->gen != NULL, FORM_GEN},
        {"--mesh", a->mesh != NULL, FORM_MESH},
        {"--build-series", a->series != NULL, FORM_SERIES},
        {"--rays", a->rays != NULL, FORM_MESH},
        {"--kind", a->kind != NULL, FORM_MESH},
        {"--passes", a->passes != 0, FORM_MESH},
        {"--pn", a->pn, FORM_MESH},
        {"--pn-mode", a->pn_mode != NULL, FORM_MESH},
        {"--tight", a->tight, FORM_GEN},
        {"--threads", a->threads != 0, FORM_GEN | FORM_MESH},
        {"--max-mtris", a->max_mtris != 0, FORM_SERIES},
    };
    const char *name = form == FORM_GEN ? "--gen-rays" : form == FORM_MESH ? "--mesh" : "--build-series";
    for (size_t i = 0; i < sizeof opt / sizeof opt[0]; i++)
        if (opt[i].given && !(opt[i].forms & form))
            return cli_usage_error("bench", "%s does not go with %s", opt[i].name, name);
    return 0;
}

/* A scene of the mesh's flat triangles, or with pn = 1 + PnMode its PN
 * patches, and one plain material. */
static int mesh_scene(const char *path, int pn, Scene *s)
{
    Mesh m;
    char err[CLI_ERR_LEN];
    memset(s, 0, sizeof *s);
    if (mesh_load(path, &m, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    if (m.nt == 0) { /* nothing to build, trace or split */
        if (m.degenerate)
            fprintf(stderr, "lancer: %s: no triangles but %d of zero area\n", path, m.degenerate);
        else
            fprintf(stderr, "lancer: %s: no triangles\n", path);
        mesh_free(&m);
        return -1;
    }
    if (pn && !m.n && mesh_vertex_normals(&m, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s: %s\n", path, err);
        mesh_free(&m);
        return -1;
    }
    int rc = pn ? scene_from_pn_mesh(s, &m, pn - 1) : scene_from_mesh(s, &m);
    mesh_free(&m);
    if (rc != 0)
        fprintf(stderr, "lancer: %s: out of memory\n", path);
    return rc;
}

/* The three ray files, put in place together or not at all, as render's
 * outputs are. */
static int write_rays(const char *const paths[3], const RaySet *const sets[3])
{
    char err[AFILE_PATH_MAX + 256];
    AfileSet set;
    afile_set_init(&set);
    for (int i = 0; i < 3; i++) {
        const char *tmp = afile_set_add(&set, paths[i], err, sizeof err);
        FILE *f = tmp ? fopen(tmp, "wb") : NULL;
        if (!f) {
            if (tmp)
                snprintf(err, sizeof err, "%s: cannot write: %s", paths[i], strerror(errno));
            afile_set_abort(&set);
            fprintf(stderr, "lancer: %s\n", err);
            return -1;
        }
        int bad = rayfile_write_stream(f, sets[i]->rays, sets[i]->n) != 0;
        if (fclose(f) != 0 || bad) {
            fprintf(stderr, "lancer: %s: cannot write: %s\n", paths[i], strerror(errno));
            afile_set_abort(&set);
            return -1;
        }
    }
    if (afile_set_commit(&set, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return -1;
    }
    return 0;
}

/* Build time and memory of the BVH as the mesh is split again and again
 * (scene_split_triangles) up to max_tris. */
static int build_series(Scene *s, PrimVariant v, long max_tris)
{
    printf("| triangles | build ms, 1 thread | build ms, 2 threads | ns per triangle (1 thread) | BVH bytes per "
           "triangle |\n| --- | --- | --- | --- | --- |\n");
    for (;;) {
        double ms[2];
        size_t bytes = 0;
        for (int t = 0; t < 2; t++) {
            double t0 = clock_now();
            Accel *acc = accel_build(s, v, t + 1);
            if (!acc) {
                fprintf(stderr, "lancer: out of memory building the BVH\n");
                return 1;
            }
            ms[t] = 1e3 * (clock_now() - t0);
            bytes = accel_bytes(acc);
            accel_free(acc);
        }
        printf("| %d | %.1f | %.1f | %.0f | %.1f |\n", s->nprims, ms[0], ms[1], 1e6 * ms[0] / s->nprims,
               (double)bytes / s->nprims);
        fflush(stdout);
        if (2L * s->nprims > max_tris)
            return 0;
        if (scene_split_triangles(s) != 0) {
            fprintf(stderr, "lancer: out of memory splitting the mesh\n");
            return 1;
        }
    }
}

/* --gen-rays: the three ray files of a w x h camera. */
static int gen_rays(const Scene *s, const Accel *acc, const char *mesh, const char *dir, int w, int h, int tight)
{
    static const char *const names[3] = {"primary.rays", "shadow.rays", "diffuse.rays"};
    if (mkdir(dir, 0777) != 0 && errno != EEXIST) { /* made when missing, as out/ by render */
        fprintf(stderr, "lancer: cannot create directory '%s': %s\n", dir, strerror(errno));
        return 1;
    }
    char paths[3][AFILE_PATH_MAX];
    CliOutput outs[3];
    for (int i = 0; i < 3; i++) {
        snprintf(paths[i], sizeof paths[i], "%s/%s", dir, names[i]);
        outs[i] = (CliOutput){"OUTDIR", paths[i], NULL};
    }
    if (cli_check_outputs(outs, 3, &mesh, 1) != 0)
        return 1;
    RaySet p, sh, d;
    if (bench_gen_rays(s, acc, w, h, tight, 1, &p, &sh, &d) != 0) {
        fprintf(stderr, "lancer: %s: no triangles to frame, or out of memory\n", mesh);
        return 1;
    }
    int rc = 0;
    const char *const names_out[3] = {paths[0], paths[1], paths[2]};
    const RaySet *const sets[3] = {&p, &sh, &d};
    if (write_rays(names_out, sets) != 0)
        rc = 1;
    else
        printf("primary=%zu shadow=%zu diffuse=%zu\n", p.n, sh.n, d.n);
    bench_free(&p);
    bench_free(&sh);
    bench_free(&d);
    return rc;
}

/* --kind's name as a BenchKind into *k; -1 when it names none. */
static int parse_kind(const char *name, BenchKind *k)
{
    static const char *const names[] = {"closest", "any", "packet", "stream"};
    static const BenchKind kinds[] = {BENCH_CLOSEST, BENCH_ANY, BENCH_PACKET, BENCH_STREAM};
    for (size_t i = 0; name && i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(name, names[i])) {
            *k = kinds[i];
            return 0;
        }
    return -1;
}

/* --mesh: timed passes over a ray file. */
static int trace_rays(const Accel *acc, const Args *a, BenchKind kind, double build_ms)
{
    Ray *r;
    size_t n;
    char err[CLI_ERR_LEN];
    if (rayfile_read(a->rays, &r, &n, err, sizeof err) != 0) {
        fprintf(stderr, "lancer: %s\n", err);
        return 1;
    }
    BenchResult res;
    if (bench_trace(acc, r, n, kind, a->passes, &res) != 0) {
        fprintf(stderr, "lancer: out of memory tracing %s\n", a->rays);
        free(r);
        return 1;
    }
    printf("mrays=%.3f hits=%zu sumt=%.6g build_ms=%.2f rays=%zu\n", res.mrays, res.hits, res.sumt, build_ms, n);
    free(r);
    return 0;
}

static int run(void *args, const char **pos, int npos)
{
    Args *a = args;
    PrimVariant v = a->classic ? PRIM_CLASSIC : PRIM_ROBUST;
    Scene s;
    int rc;
    const unsigned form = a->series ? FORM_SERIES : a->gen ? FORM_GEN : a->mesh ? FORM_MESH : 0;
    if (!form)
        return cli_usage_error("bench", "give --gen-rays MESH OUTDIR, --mesh MESH --rays FILE --kind K, or "
                                        "--build-series MESH");
    if ((rc = stray_option(a, form)) != 0)
        return rc;
    a->passes = a->passes ? a->passes : 3;
    a->threads = a->threads ? a->threads : 1;
    a->max_mtris = a->max_mtris ? a->max_mtris : 10;
    if (a->series) {
        if (npos != 0)
            return cli_usage_error("bench", "--build-series takes no other arguments");
        if (mesh_scene(a->series, 0, &s) != 0)
            return 1;
        rc = build_series(&s, v, 1000000L * a->max_mtris);
        scene_free(&s);
        return rc;
    }
    int w = 1024, h = 1024;
    if (a->gen && (npos != 1 && npos != 3))
        return cli_usage_error("bench", "--gen-rays needs MESH OUTDIR [W H]");
    if (a->gen && npos == 3 &&
        (cli_parse_int(pos[1], 1, LIMIT_IMAGE_SIDE, &w) != 0 || cli_parse_int(pos[2], 1, LIMIT_IMAGE_SIDE, &h) != 0))
        return cli_usage_error("bench", "W and H must be whole numbers from 1 to %d", LIMIT_IMAGE_SIDE);
    BenchKind kind = BENCH_CLOSEST;
    if (a->mesh && (!a->rays || parse_kind(a->kind, &kind) != 0 || npos != 0))
        return cli_usage_error("bench", "--mesh needs --rays FILE and --kind closest, any, packet or stream");
    int pn = 0;
    if (a->pn_mode && !a->pn)
        return cli_usage_error("bench", "--pn-mode needs --pn");
    if (a->pn) {
        pn = 1 + (a->pn_mode ? pn_mode_named(a->pn_mode) : PN_EXACT);
        if (!pn)
            return cli_usage_error("bench", "--pn-mode must be exact or fast, not '%s'", a->pn_mode);
    }
    if (mesh_scene(a->gen ? a->gen : a->mesh, pn, &s) != 0)
        return 1;
    double t0 = clock_now();
    Accel *acc = accel_build(&s, v, a->threads);
    if (!acc) {
        fprintf(stderr, "lancer: out of memory building the BVH\n");
        scene_free(&s);
        return 1;
    }
    double build_ms = 1e3 * (clock_now() - t0);
    rc = a->gen ? gen_rays(&s, acc, a->gen, pos[0], w, h, a->tight) : trace_rays(acc, a, kind, build_ms);
    accel_free(acc);
    scene_free(&s);
    return rc;
}

static const Opt opts[] = {
    {"--gen-rays", NULL, OPT_STRING, offsetof(Args, gen), 0, 0},
    {"--mesh", NULL, OPT_STRING, offsetof(Args, mesh), 0, 0},
    {"--rays", NULL, OPT_STRING, offsetof(Args, rays), 0, 0},
    {"--kind", NULL, OPT_STRING, offsetof(Args, kind), 0, 0},
    {"--passes", NULL, OPT_INT, offsetof(Args, passes), 1, 1000},
    {"--classic", NULL, OPT_FLAG, offsetof(Args, classic), 0, 0},
    {"--tight", NULL, OPT_FLAG, offsetof(Args, tight), 0, 0},
    {"--pn", NULL, OPT_FLAG, offsetof(Args, pn), 0, 0},
    {"--pn-mode", NULL, OPT_STRING, offsetof(Args, pn_mode), 0, 0},
    {"--threads", NULL, OPT_INT, offsetof(Args, threads), 1, LIMIT_THREADS},
    {"--build-series", NULL, OPT_STRING, offsetof(Args, series), 0, 0},
    {"--max-mtris", NULL, OPT_INT, offsetof(Args, max_mtris), 1, 100},
};

const Command cmd_bench = {"bench", usage, opts, (int)(sizeof opts / sizeof opts[0]), 3, sizeof(Args), defaults, run};
