/*
 * fuzz_rays.c - ray files (rayfile_parse). A file that reads must give
 * exactly the rays its size holds, each one traceable (rayfile_ray_ok); one
 * that does not must give no rays and a message "fuzz.in: ...".
 */
#include "fuzz.h"

#include "lancer/rayfile.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    Ray *r;
    size_t n;
    char err[1024] = "";
    if (rayfile_parse(FUZZ_NAME, data, size, &r, &n, err, sizeof err) != 0) {
        fuzz_check_message(err, 0, 0);
        fuzz_require(r == NULL && n == 0, "a failed read left rays", err);
        return 0;
    }
    fuzz_require(n == (size - 16) / 32, "the ray count disagrees with the size", "count");
    for (size_t i = 0; i < n; i++)
        fuzz_require(rayfile_ray_ok(&r[i]), "a ray read cannot be traced", "ray");
    free(r);
    return 0;
}
